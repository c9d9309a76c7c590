// The Inverjet's state-machine names and baud codes. The register table
// itself is data in registers.hpp.
#include "rtukit/devices/inverjet/registers.hpp"

namespace rtukit::inverjet {

uint16_t state_value(Family family, Phase phase) noexcept {
  if (phase == Phase::off) return 0;
  if (phase == Phase::menu) return 16;
  if (phase == Phase::fault) return 17;
  const uint16_t base = family == Family::timer ? 6 : family == Family::training ? 11 : 1;
  return static_cast<uint16_t>(base + static_cast<uint16_t>(phase) - static_cast<uint16_t>(Phase::initial));
}

Phase phase_of(uint16_t state) noexcept {
  if (state == 0) return Phase::off;
  if (state == 16) return Phase::menu;
  if (state >= 17) return Phase::fault;
  return static_cast<Phase>(static_cast<uint16_t>(Phase::initial) + (state - 1) % 5);
}

Family family_of(uint16_t state) noexcept {
  if (state >= 1 && state <= 5) return Family::free;
  if (state >= 6 && state <= 10) return Family::timer;
  if (state >= 11 && state <= 15) return Family::training;
  return Family::none;
}

std::string_view phase_name(Phase phase) noexcept {
  constexpr std::string_view kNames[] = {"off",    "initial", "starting",       "running",
                                         "paused", "ended",   "operation menu", "fault screen"};
  return kNames[static_cast<size_t>(phase)];
}

std::string_view family_name(Family family) noexcept {
  constexpr std::string_view kNames[] = {"none", "free", "timer", "training"};
  return kNames[static_cast<size_t>(family)];
}

// The rates are the baud row's value names (D-4: 4 = 19200).
uint32_t baud_of_code(uint16_t code) noexcept {
  return profile::baud_of(kMap.row(reg::baud), code);
}

int code_of_baud(uint32_t baud) noexcept {
  return static_cast<int>(profile::raw_of_baud(kMap.row(reg::baud), baud));
}

}  // namespace rtukit::inverjet
