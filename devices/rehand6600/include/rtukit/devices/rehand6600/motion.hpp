// What each hold-type motion command of the Rehand 6600 moves, and how table 1
// shows it: the one statement of "posture N drives actuators A, B and reports
// in status register S", read by the controller model (which actuators a
// command drives, which status it reports), by the host (is a press still in
// effect on the controller, or did the controller stop it by itself?) and by
// every view that shows a posture.
//
// Pure data and constexpr functions over a Snapshot: no I/O, no heap.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/snapshot.hpp"

namespace rtukit::rehand6600 {

/// One posture command of table 2 (0x0062..0x0068).
struct Posture {
  uint16_t command;  ///< the hold row it is written to
  /// Its status register in table 1 (0x0010..0x0014), 0 when table 1 has
  /// none (the seat-plate tilt: only its actuator's state shows it).
  uint16_t status;
  /// The status values that show this posture moving: [0] while the command
  /// holds 1, [1] while it holds 2. The leg rest's register tells rotation
  /// (1 up, 2 down) from extension alone (3 both ways).
  std::array<uint16_t, 2> status_values;
  /// The actuators it drives (1-based), 0 after the last. Stand/sit drives
  /// 1, 2 and 4 together; leg-rest rotation carries the extension (4 and 5).
  std::array<uint8_t, 3> actuators;

  constexpr std::span<const uint8_t> driven() const noexcept {
    size_t n = 0;
    while (n < actuators.size() && actuators[n] != 0) ++n;
    return {actuators.data(), n};
  }
  /// The status value that shows it moving with `value` (1 or 2), 0 for none.
  constexpr uint16_t moving_status(uint16_t value) const noexcept {
    return status == 0 || value < 1 || value > 2 ? 0 : status_values[value - 1];
  }
};

/// The seven postures, in table 2's order. Value 1 drives their actuators
/// towards 1000 per-mille (up, forward, out, standing), value 2 towards 0.
inline constexpr std::array<Posture, 7> kPostures = {{
    {reg::kStandSit, reg::kStandStatus, {1, 2}, {1, 2, 4}},
    {reg::kSeatLift, reg::kSeatLiftStatus, {1, 2}, {1, 0, 0}},
    {reg::kBackrest, reg::kBackrestStatus, {1, 2}, {2, 0, 0}},
    {reg::kSeatTilt, reg::kSeatTiltStatus, {1, 2}, {3, 0, 0}},
    {reg::kLegRotate, reg::kLegRestStatus, {1, 2}, {4, 5, 0}},
    {reg::kLegExtend, reg::kLegRestStatus, {3, 3}, {5, 0, 0}},
    {reg::kPlateTilt, 0, {0, 0}, {6, 0, 0}},
}};

/// The posture written at `command`, or nullptr when it is none.
constexpr const Posture* find_posture(uint16_t command) noexcept {
  for (const Posture& p : kPostures)
    if (p.command == command) return &p;
  return nullptr;
}

/// Actuator states of table 1 (0x001B..0x0020).
inline constexpr uint16_t kActuatorStill = 0, kActuatorMoving = 1, kUpperLimit = 2, kLowerLimit = 3,
                          kOverCurrent = 4;
/// Motion states of table 1 (0x0005) a single direction shows.
inline constexpr uint16_t kStatic = 1, kForward = 2, kReverse = 3, kSpinLeft = 4, kSpinRight = 5;

/// The motion state a phone drive command (0x006E..0x0071) shows while the
/// chair obeys it; 0 for any other register.
constexpr uint16_t phone_motion(uint16_t command) noexcept {
  switch (command) {
    case reg::kPhoneForward:
      return kForward;
    case reg::kPhoneReverse:
      return kReverse;
    case reg::kPhoneLeft:
      return kSpinLeft;
    case reg::kPhoneRight:
      return kSpinRight;
    default:
      return 0;
  }
}

/// What a reading of table 1 shows of hold-type `command` held at `value`.
enum class Effect : uint8_t {
  moving,   ///< the controller obeys it: its status, its actuators or the chair's motion say so
  at_end,   ///< a posture pushing against its end: every actuator it drives at that limit
  none,     ///< nothing of it shows: the controller is not (or no longer) doing it
  unknown,  ///< table 1 shows nothing of this command (the horn, anti-pinch, settings)
};

/// How `s` shows `command` = `value`. A posture moves when its status
/// register shows its value or one of its actuators moves; it is at its end
/// when every actuator it drives reports the limit of its direction. A phone
/// drive command moves when the motion state is its direction.
constexpr Effect effect_of(uint16_t command, uint16_t value, const Snapshot& s) noexcept {
  if (value == 0) return Effect::none;
  if (const Posture* p = find_posture(command)) {
    if (p->status != 0 && s[p->status] == p->moving_status(value)) return Effect::moving;
    const uint16_t limit = value == 1 ? kUpperLimit : kLowerLimit;
    bool all_at_limit = true;
    for (uint8_t a : p->driven()) {
      const uint16_t state = s[static_cast<uint16_t>(reg::kActuatorState + a - 1)];
      if (state == kActuatorMoving) return Effect::moving;
      all_at_limit = all_at_limit && state == limit;
    }
    return all_at_limit ? Effect::at_end : Effect::none;
  }
  if (const uint16_t motion = phone_motion(command))
    return s.motion() == motion ? Effect::moving : Effect::none;
  return Effect::unknown;
}

}  // namespace rtukit::rehand6600
