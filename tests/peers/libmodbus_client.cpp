// A libmodbus client that exercises a server the way the interop tests expect:
// it writes, reads back and checks, and checks the exception for a bad address.
//   libmodbus_client rtu DEVICE | tcp PORT
// Exit 0 and "OK" when everything matched; else the first mismatch and exit 1.
#include <modbus/modbus.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <string>

static const char* const kPeer = "libmodbus_client";
#include "check.hpp"

int main(int argc, char** argv) {
  if (argc < 3) return 2;
  const std::string mode = argv[1];
  modbus_t* ctx = mode == "rtu" ? modbus_new_rtu(argv[2], 9600, 'N', 8, 1)
                                : modbus_new_tcp("127.0.0.1", std::atoi(argv[2]));
  modbus_set_slave(ctx, 1);
  modbus_set_response_timeout(ctx, 2, 0);
  CHECK(modbus_connect(ctx) == 0, "connect");

  CHECK(modbus_write_register(ctx, 5, 1234) == 1, "write_register");
  uint16_t regs[8] = {};
  CHECK(modbus_read_registers(ctx, 5, 1, regs) == 1 && regs[0] == 1234, "read back 1234, got %u", regs[0]);

  const uint16_t many[3] = {1, 2, 65535};
  CHECK(modbus_write_registers(ctx, 10, 3, many) == 3, "write_registers");
  CHECK(modbus_read_registers(ctx, 10, 3, regs) == 3 && regs[0] == 1 && regs[1] == 2 && regs[2] == 65535,
        "read back 1 2 65535");

  CHECK(modbus_write_bit(ctx, 3, 1) == 1, "write_bit");
  const uint8_t bits_in[4] = {1, 0, 1, 1};
  CHECK(modbus_write_bits(ctx, 20, 4, bits_in) == 4, "write_bits");
  uint8_t bits[8] = {};
  CHECK(
      modbus_read_bits(ctx, 20, 4, bits) == 4 && bits[0] == 1 && bits[1] == 0 && bits[2] == 1 && bits[3] == 1,
      "read_bits");
  CHECK(modbus_read_bits(ctx, 3, 1, bits) == 1 && bits[0] == 1, "read_bit 3");
  CHECK(modbus_read_input_registers(ctx, 0, 2, regs) == 2, "read_input_registers");
  CHECK(modbus_read_input_bits(ctx, 0, 2, bits) == 2, "read_input_bits");

  errno = 0;
  CHECK(modbus_read_registers(ctx, 65000, 10, regs) == -1 && errno == EMBXILADD, "exception 02 expected");
  errno = 0;
  CHECK(modbus_read_registers(ctx, 0, 126, regs) == -1, "quantity 126 must fail");

  // FC16 mask write and FC17 read/write multiple (issue 14).
  CHECK(modbus_write_register(ctx, 50, 0x12) == 1, "write 50");
  CHECK(modbus_mask_write_register(ctx, 50, 0x00F2, 0x0025) == 1, "mask_write_register");
  CHECK(modbus_read_registers(ctx, 50, 1, regs) == 1 && regs[0] == 0x17, "mask result 0x17, got 0x%X",
        regs[0]);
  const uint16_t rw_values[] = {7, 8};
  uint16_t rw_back[3] = {};
  CHECK(modbus_write_and_read_registers(ctx, 60, 2, rw_values, 59, 3, rw_back) == 3 && rw_back[0] == 0 &&
            rw_back[1] == 7 && rw_back[2] == 8,
        "write_and_read_registers: the write comes first (%u %u %u)", rw_back[0], rw_back[1], rw_back[2]);

  // FC11 report slave id: our slave's unit, "on", then "vendor product revision".
  uint8_t id[MODBUS_MAX_PDU_LENGTH] = {};
  const int n = modbus_report_slave_id(ctx, sizeof id, id);
  CHECK(n > 2 && id[1] == 0xFF && std::string(reinterpret_cast<char*>(id + 2), n - 2).find("rtukit") == 0,
        "report_slave_id: %d bytes", n);

  std::printf("OK\n");
  modbus_close(ctx);
  modbus_free(ctx);
  return 0;
}
