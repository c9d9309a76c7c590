// Table 1 of the Rehand 6600 as the host last read it: one consistent
// reading (one FC03 of 48 registers), with the accessors the host's rules use.
#pragma once

#include <array>
#include <cstdint>

#include "rtukit/devices/rehand6600/registers.hpp"

namespace rtukit::rehand6600 {

/// Table 1 as one consistent reading.
struct Snapshot {
  std::array<uint16_t, reg::kStatusCount> regs{};
  bool valid = false;  ///< false until the first successful poll
  uint64_t sequence = 0;

  uint16_t operator[](uint16_t address) const noexcept { return regs[address]; }
  unsigned battery() const noexcept { return regs[reg::kBattery]; }
  bool charging() const noexcept { return regs[reg::kCharging] != 0; }
  unsigned speed_kmh() const noexcept { return regs[reg::kSpeed]; }
  double speed_mph() const noexcept { return regs[reg::kSpeed] * 0.621371; }
  bool clutch_drive() const noexcept { return regs[reg::kClutch] == 1; }
  uint16_t motion() const noexcept { return regs[reg::kMotion]; }
  bool is_static() const noexcept { return regs[reg::kMotion] == 1 && regs[reg::kSpeed] == 0; }
  /// Still: static and at 0 km/h, and no actuator moving (state 1). What an
  /// emergency stop waits for before 0x006A is released.
  bool still() const noexcept {
    for (uint16_t a = reg::kActuatorState; a < reg::kActuatorState + 6; ++a)
      if (regs[a] == 1) return false;
    return is_static();
  }
  uint16_t error_code() const noexcept { return regs[reg::kErrorCode]; }
  /// D-10: seat lift (actuator 1) and whole-seat tilt (actuator 3) at their seated end.
  bool seated() const noexcept {
    // Stand/sit moves actuator 1 too, so a standing chair is not seated.
    return regs[reg::kActuatorPosition] == 0 && regs[reg::kActuatorPosition + 2] == 0;
  }
  bool joystick_neutral() const noexcept { return regs[reg::kJoystickX] == 0 && regs[reg::kJoystickY] == 0; }
};

}  // namespace rtukit::rehand6600
