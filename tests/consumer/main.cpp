// The README's library snippet, plus a profile lookup, as a consumer of an
// installed rtukit builds it. Run with a port: reads the Inverjet's state
// registers and prints them decoded; without one, checks the profile only.
#include <cstdio>

#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/driver/master.hpp"

int main(int argc, char** argv) {
  const rtukit::profile::Row* state = rtukit::inverjet::kMap.find("state");
  if (state == nullptr) return 1;
  std::printf("state register at 0x%04X\n", static_cast<unsigned>(state->address));
  if (argc < 2) return 0;

  auto spec = rtukit::io::parse_port(argv[1], /*listening=*/false);
  if (!spec) return 2;
  spec->serial.baud = 9600;
  rtukit::Master master(rtukit::io::make_link(*spec),
                        {.response_timeout = std::chrono::milliseconds(500), .retries = 2});
  std::array<uint16_t, 4> regs{};
  if (rtukit::Error e = master.read_holding_registers(rtukit::UnitId{21}, 0x0021, regs)) {
    std::printf("error: %.*s\n", static_cast<int>(e.name().size()), e.name().data());
    return 3;
  }
  std::printf("state = %s\n", rtukit::profile::format_value(*state, regs[1]).c_str());
  return 0;
}
