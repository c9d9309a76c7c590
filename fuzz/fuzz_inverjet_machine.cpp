// The Inverjet model on arbitrary sequences of writes, reads, time steps and
// injected faults. Properties: never crashes; every register stays within the
// range the table gives it; settings stay valid (they are saved as is); a
// refused write changes nothing (all or nothing); faults always show as 17.
//
// Input: a stream of 6-byte commands: op, address (2), value (2), extra.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/devices/inverjet/registers.hpp"

namespace {

using namespace rtukit::inverjet;

// Holding registers worth comparing (config, control, memory, plan P1 start).
constexpr uint16_t kWatched[] = {0x0000, 0x0001, 0x0002, 0x0004, 0x0021, 0x0022, 0x0023, 0x0024,
                                 0x0080, 0x0081, 0x0082, 0x0083, 0x0100, 0x0101, 0x0102, 0x0103};

// The watched registers as a master reads them, plus every stored word.
std::vector<uint16_t> snapshot(Machine& m) {
  std::vector<uint16_t> out(m.image().words().begin(), m.image().words().end());
  for (const uint16_t address : kWatched) {
    std::array<uint16_t, 1> v{};
    if (m.read_holding(address, v) != rtukit::Errc::ok) std::abort();
    out.push_back(v[0]);
  }
  return out;
}

void check_ranges(Machine& m) {
  // Every stored register (the state file saves them as they are) and every
  // holding register a master reads stays within its row's range.
  for (const Row& r : kRows) {
    for (unsigned i = 0; i < r.repeat; ++i) {
      if (r.space == Space::holding && !r.valid_range().contains(m.image().get(r, i))) std::abort();
    }
    if (r.space != Space::holding || r.repeat > 1) continue;
    std::array<uint16_t, 1> v{};
    if (m.read_holding(r.address, v) != rtukit::Errc::ok) std::abort();
    if (!r.valid_range().contains(v[0])) std::abort();
  }
  std::array<uint16_t, 17> in{};
  if (m.read_input(0, in) != rtukit::Errc::ok) std::abort();
  if ((in[8] != 0) != (m.state() == 17)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Machine m;
  uint64_t now = 0;
  for (size_t at = 0; at + 6 <= size; at += 6) {
    const uint8_t op = data[at];
    const auto address = static_cast<uint16_t>(data[at + 1] << 8 | data[at + 2]);
    const auto value = static_cast<uint16_t>(data[at + 3] << 8 | data[at + 4]);
    const uint8_t extra = data[at + 5];
    switch (op % 6) {
      case 0: {  // write a few registers (near the interesting ones)
        const auto base = static_cast<uint16_t>(address % 0x0300);
        std::array<uint16_t, 4> values{value, static_cast<uint16_t>(value >> 3), extra,
                                       static_cast<uint16_t>(value % 7)};
        const auto before = snapshot(m);
        const auto n = static_cast<size_t>(1 + extra % 4);
        if (m.write_holding(base, std::span<const uint16_t>(values.data(), n)) != rtukit::Errc::ok &&
            snapshot(m) != before)
          std::abort();  // a refused write changed something
        break;
      }
      case 1: {  // control block with small, meaningful values
        const std::array<uint16_t, 4> values{
            static_cast<uint16_t>(value % 6), static_cast<uint16_t>(extra % 19),
            static_cast<uint16_t>(address % 102), static_cast<uint16_t>(address % 6001)};
        (void)m.write_holding(0x0021, values);
        break;
      }
      case 2:  // time passes: up to ~4 minutes in one step
        now += static_cast<uint64_t>(value) * (extra % 4 + 1);
        m.advance_to(now);
        break;
      case 3:
        m.set_injected_faults(value);
        break;
      case 4:
        m.set_mosfet_temperature(static_cast<double>(value % 1500) / 10.0);
        m.set_mains_voltage(static_cast<double>(address % 5000) / 10.0);
        break;
      default: {
        std::array<uint16_t, 8> out{};
        (void)m.read_holding(address, std::span<uint16_t>(out.data(), 1 + extra % 8));
        (void)m.read_input(address, std::span<uint16_t>(out.data(), 1 + extra % 8));
        break;
      }
    }
    check_ranges(m);
  }
  return 0;
}
