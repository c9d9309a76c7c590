// libmodbus drives the simulated Inverjet through a timer-mode run: start,
// read state and time, pause (time frozen), resume (counting again), stop.
//   inverjet_libmodbus_run DEVICE     (unit 21, 9600 8N1; sim at --time-scale 10)
// Exit 0 and "OK" when every check passed; else the first failure and exit 1.
#include <modbus/modbus.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>

static const char* const kPeer = "inverjet_libmodbus_run";
#include "check.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  modbus_t* ctx = modbus_new_rtu(argv[1], 9600, 'N', 8, 1);
  modbus_set_slave(ctx, 21);
  modbus_set_response_timeout(ctx, 2, 0);
  CHECK(modbus_connect(ctx) == 0, "connect");

  const uint16_t start[4] = {0, 8, 60, 600};  // timer running, 60 %, 10:00
  CHECK(modbus_write_registers(ctx, 0x21, 4, start) == 4, "start timer");
  uint16_t r[4] = {};
  CHECK(modbus_read_registers(ctx, 0x21, 4, r) == 4, "read block");
  CHECK(r[0] == 0 && (r[1] == 7 || r[1] == 8) && r[2] == 60 && r[3] > 0 && r[3] <= 600,
        "timer started: %u %u %u %u", r[0], r[1], r[2], r[3]);

  CHECK(modbus_write_register(ctx, 0x22, 9) == 1, "pause");
  CHECK(modbus_read_registers(ctx, 0x21, 4, r) == 4 && r[1] == 9, "paused: state %u", r[1]);
  const uint16_t t1 = r[3];
  usleep(300000);  // several device seconds at --time-scale 10
  CHECK(modbus_read_registers(ctx, 0x21, 4, r) == 4 && r[1] == 9 && r[3] == t1, "frozen: %u then %u", t1,
        r[3]);

  CHECK(modbus_write_register(ctx, 0x22, 8) == 1, "resume");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  do {
    CHECK(modbus_read_registers(ctx, 0x21, 4, r) == 4, "read while running");
    if (r[3] < t1) break;
    usleep(50000);
  } while (std::chrono::steady_clock::now() < deadline);
  CHECK((r[1] == 7 || r[1] == 8) && r[3] < t1, "counting down again: state %u, %u -> %u", r[1], t1, r[3]);

  CHECK(modbus_write_register(ctx, 0x22, 0) == 1, "stop");
  CHECK(modbus_read_registers(ctx, 0x22, 1, r) == 1 && r[0] == 0, "off after stop: %u", r[0]);
  uint16_t faults = 1;
  CHECK(modbus_read_input_registers(ctx, 0x08, 1, &faults) == 1 && faults == 0, "no faults");
  errno = 0;
  CHECK(modbus_write_register(ctx, 0x23, 101) == -1 && errno == EMBXILVAL, "speed 101 -> exception 03");
  errno = 0;
  CHECK(modbus_read_registers(ctx, 0x05, 1, r) == -1 && errno == EMBXILADD,
        "reserved 0x0005 -> exception 02");

  std::printf("OK\n");
  modbus_close(ctx);
  modbus_free(ctx);
  return 0;
}
