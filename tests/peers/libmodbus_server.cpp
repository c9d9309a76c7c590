// A Modbus server built on libmodbus, for interop tests and as the benchmark's
// reference. Holding register i = 10 * i, input register i = 1000 + i,
// coil i = i % 2, discrete input i = (i + 1) % 2, for i in 0..199; unit 1.
//   libmodbus_server rtu DEVICE [BAUD]
//   libmodbus_server tcp PORT          (many connections at once, via select)
// Prints "ready" on stdout once it serves. Stops on SIGTERM/SIGINT.
#include <modbus/modbus.h>
#include <sys/select.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace {

modbus_mapping_t* make_mapping() {
  modbus_mapping_t* m = modbus_mapping_new(200, 200, 200, 200);
  for (int i = 0; i < 200; ++i) {
    m->tab_registers[i] = static_cast<uint16_t>(10 * i);
    m->tab_input_registers[i] = static_cast<uint16_t>(1000 + i);
    m->tab_bits[i] = static_cast<uint8_t>(i % 2);
    m->tab_input_bits[i] = static_cast<uint8_t>((i + 1) % 2);
  }
  // A device ID at holding register 0 (the Rehand 6600 host's handshake reads it).
  if (const char* id = std::getenv("LIBMODBUS_SERVER_REG0"))
    m->tab_registers[0] = static_cast<uint16_t>(std::strtoul(id, nullptr, 0));
  return m;
}

int serve_rtu(const char* device, int baud) {
  modbus_t* ctx = modbus_new_rtu(device, baud, 'N', 8, 1);
  modbus_set_slave(ctx, 1);
  if (modbus_connect(ctx) == -1) {
    std::fprintf(stderr, "libmodbus_server: %s: %s\n", device, modbus_strerror(errno));
    return 1;
  }
  modbus_mapping_t* mapping = make_mapping();
  std::printf("ready\n");
  std::fflush(stdout);
  uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
  for (;;) {
    const int rc = modbus_receive(ctx, query);
    if (rc > 0) {
      modbus_reply(ctx, query, rc, mapping);
    } else if (rc == -1 && errno != EMBBADCRC && errno != EMBBADDATA && errno != EMBMDATA) {
      // A pty with no reader returns EIO now and then: keep serving.
      usleep(1000);
    }
  }
}

int serve_tcp(int port) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  const int server = modbus_tcp_listen(ctx, 32);
  if (server == -1) {
    std::fprintf(stderr, "libmodbus_server: listen %d: %s\n", port, modbus_strerror(errno));
    return 1;
  }
  modbus_mapping_t* mapping = make_mapping();
  std::printf("ready\n");
  std::fflush(stdout);
  fd_set all;
  FD_ZERO(&all);
  FD_SET(server, &all);
  int max_fd = server;
  uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
  for (;;) {
    fd_set ready = all;
    if (select(max_fd + 1, &ready, nullptr, nullptr, nullptr) == -1) {
      if (errno == EINTR) continue;
      return 1;
    }
    for (int fd = 0; fd <= max_fd; ++fd) {
      if (!FD_ISSET(fd, &ready)) continue;
      if (fd == server) {
        int client = modbus_tcp_accept(ctx, const_cast<int*>(&server));
        // modbus_tcp_accept closes and overwrites its argument on error only.
        if (client != -1) {
          FD_SET(client, &all);
          if (client > max_fd) max_fd = client;
        }
        continue;
      }
      modbus_set_socket(ctx, fd);
      const int rc = modbus_receive(ctx, query);
      if (rc > 0) {
        modbus_reply(ctx, query, rc, mapping);
      } else if (rc == -1) {
        close(fd);
        FD_CLR(fd, &all);
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGPIPE, SIG_IGN);
  if (argc >= 3 && std::string(argv[1]) == "rtu")
    return serve_rtu(argv[2], argc > 3 ? std::atoi(argv[3]) : 9600);
  if (argc >= 3 && std::string(argv[1]) == "tcp") return serve_tcp(std::atoi(argv[2]));
  std::fprintf(stderr, "usage: libmodbus_server rtu DEVICE [BAUD] | tcp PORT\n");
  return 2;
}
