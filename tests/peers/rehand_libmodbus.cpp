// libmodbus, as a host would, reads table 1 and writes table 2 of the
// simulated Rehand 6600 controller.   rehand_libmodbus DEVICE
// Exit 0 and "OK" when every check passed; else the first failure and exit 1.
#include <modbus/modbus.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>

static const char* const kPeer = "rehand_libmodbus";
#include "check.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  modbus_t* ctx = modbus_new_rtu(argv[1], 115200, 'N', 8, 1);
  modbus_set_slave(ctx, 1);
  modbus_set_response_timeout(ctx, 1, 0);
  CHECK(modbus_connect(ctx) == 0, "connect");

  uint16_t t1[48] = {};
  CHECK(modbus_read_registers(ctx, 0, 48, t1) == 48, "read table 1");
  CHECK(t1[0] == 0x68 && t1[1] == 80 && t1[5] == 1, "ID 0x68, battery 80, static: %x %u %u", t1[0], t1[1],
        t1[5]);

  CHECK(modbus_write_register(ctx, 0x0062, 1) == 1, "hold stand");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  uint16_t r[8] = {};
  do {  // polling also feeds the controller's watchdog
    CHECK(modbus_read_registers(ctx, 0x0012, 1, r) == 1, "read stand status");
    if (r[0] == 1) break;
    usleep(50000);
  } while (std::chrono::steady_clock::now() < deadline);
  CHECK(r[0] == 1, "standing up: %u", r[0]);
  CHECK(modbus_write_register(ctx, 0x0062, 0) == 1, "release stand");

  const uint16_t cmds[2] = {2, 1};  // indoor, light pulse
  CHECK(modbus_write_registers(ctx, 0x0060, 2, cmds) == 2, "drive mode and light");
  CHECK(modbus_read_registers(ctx, 0x000D, 1, r) == 1 && r[0] == 1, "main light on");

  errno = 0;
  CHECK(modbus_write_register(ctx, 0x0069, 6) == -1 && errno == EMBXILVAL, "speed level 6 -> exception 03");
  errno = 0;
  CHECK(modbus_read_registers(ctx, 0x0060, 1, r) == -1 && errno == EMBXILADD, "table 2 read -> exception 02");
  errno = 0;
  CHECK(modbus_write_register(ctx, 0x0030, 1) == -1 && errno == EMBXILADD, "gap -> exception 02");

  std::printf("OK\n");
  modbus_close(ctx);
  modbus_free(ctx);
  return 0;
}
