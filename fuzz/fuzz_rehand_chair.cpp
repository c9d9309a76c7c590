// The Rehand 6600 controller model on arbitrary sequences of host writes,
// time steps (with or without frames) and physical inputs. Properties: never
// crashes; a refused write changes no command (all or nothing); table 1 is
// always readable and within its listed values; during a local fault the
// speed never rises and no actuator moves; a host silent for longer than
// the watchdog plus the braking time leaves no phone drive active; and the
// safety rules:
//  - D-5a: only executed requests feed the watchdog (the writes go through
//    write_holding_registers, which feeds it only when they succeed);
//  - D-8: after a stop nobody asked for, every hold-type motion command stays
//    0 until a new write sets one (nothing restarts by itself);
//  - D-9: a host lost while the phone drives: the chair stands within 1.5 s
//    of the last executed request (the joystick untouched);
//  - D-10: not seated, the speed never rises above 1.2 km/h;
//  - D-11: while charging, the seat never rises and the speed never rises.
//
// Input: a stream of 6-byte commands: op, address (2), value (2), extra.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "rtukit/devices/rehand6600/chair.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"

namespace {

using namespace rtukit::rehand6600;

constexpr uint16_t kHolds[] = {reg::kStandSit,     reg::kSeatLift,  reg::kBackrest,   reg::kSeatTilt,
                               reg::kLegRotate,    reg::kLegExtend, reg::kPlateTilt,  reg::kPhoneForward,
                               reg::kPhoneReverse, reg::kPhoneLeft, reg::kPhoneRight, reg::kPhoneHorn};

bool any_hold(const Chair& c) {
  for (uint16_t r : kHolds) {
    if (c.command(r)) return true;
  }
  return false;
}

bool phone_drive(const Chair& c) {
  for (uint16_t r = reg::kPhoneForward; r <= reg::kPhoneRight; ++r) {
    if (c.command(r)) return true;
  }
  return false;
}

std::array<uint16_t, reg::kCommandCount> commands(Chair& c) {
  std::array<uint16_t, reg::kCommandCount> out{};
  for (uint16_t i = 0; i < reg::kCommandCount; ++i)
    out[i] = c.command(static_cast<uint16_t>(reg::kCommandFirst + i));
  return out;
}

void check_table1(Chair& c) {
  std::array<uint16_t, reg::kStatusCount> t{};
  if (c.read(0, t) != rtukit::Errc::ok) std::abort();
  for (const Register& r : registers()) {
    if (table_of(r) != Table::status || r.names.empty()) continue;
    if (check_value(r, t[r.address]) != rtukit::Errc::ok) std::abort();
  }
  if (t[reg::kBattery] > 100) std::abort();
  for (unsigned i = 0; i < 6; ++i) {
    if (t[reg::kActuatorPosition + i] > 1000) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Chair chair(0, 500);
  uint64_t now = 0;
  uint64_t silent_since = 0;
  unsigned stops_seen = 0;
  bool held_since_stop = true;    // D-8: a hold was set after the last stop
  bool phone_at_silence = false;  // D-9: the phone drove when the host fell silent
  bool joystick_neutral = true;
  uint64_t joystick_neutral_since = 0;
  for (size_t at = 0; at + 6 <= size; at += 6) {
    const uint8_t op = data[at];
    const auto address = static_cast<uint16_t>(data[at + 1] << 8 | data[at + 2]);
    const auto value = static_cast<uint16_t>(data[at + 3] << 8 | data[at + 4]);
    const uint8_t extra = data[at + 5];
    switch (op % 5) {
      case 0: {  // a host write near table 2
        const auto base = static_cast<uint16_t>(0x0058 + address % 0x30);
        const std::array<uint16_t, 3> values{static_cast<uint16_t>(value % 4),
                                             static_cast<uint16_t>(value >> 14), extra};
        const auto before = commands(chair);
        const size_t n = 1 + extra % 3;
        if (chair.write_holding_registers(base, std::span<const uint16_t>(values.data(), n)) ==
            rtukit::Errc::ok) {
          silent_since = now;  // D-5a: executed
          phone_at_silence = phone_drive(chair);
          if (any_hold(chair)) held_since_stop = true;
        } else if (commands(chair) != before) {
          std::abort();  // all or nothing
        }
        break;
      }
      case 1: {  // time passes; a polling host (extra odd) or a silent one
        const double speed_before = chair.speed_kmh();
        std::array<double, 6> pos{};
        for (unsigned i = 0; i < 6; ++i) pos[i] = chair.actuator(i + 1);
        const bool fault = chair.status(reg::kErrorCode) != 0;
        const bool seated = chair.seated();
        const bool charging = chair.status(reg::kCharging) != 0;
        const uint64_t step = value % 3000;
        if (extra & 1) {
          for (uint64_t t = 0; t < step; t += 50) {
            now += 50;
            chair.advance_to(now);
            std::array<uint16_t, 1> id{};
            if (chair.read_holding_registers(0, id) != rtukit::Errc::ok) std::abort();  // a poll
          }
          silent_since = now;
          phone_at_silence = phone_drive(chair);
        } else {
          now += step;
          chair.advance_to(now);
        }
        // D-10: raised, the speed never climbs above the crawl limit.
        if (!seated && !chair.seated() && chair.speed_kmh() > 1.2 + 1e-9 && chair.speed_kmh() > speed_before)
          std::abort();
        // D-11: charging, the seat does not rise and the chair does not speed up.
        if (charging && (chair.actuator(1) > pos[0] || chair.speed_kmh() > speed_before)) std::abort();
        // D-9: host lost while the phone drove, joystick untouched: standing within 1.5 s.
        if (phone_at_silence && joystick_neutral && joystick_neutral_since <= silent_since &&
            now - silent_since >= 1500 && chair.speed_kmh() != 0)
          std::abort();
        if (fault && chair.status(reg::kErrorCode) != 0) {
          if (chair.speed_kmh() > speed_before) std::abort();
          for (unsigned i = 0; i < 6; ++i) {
            if (chair.actuator(i + 1) != pos[i]) std::abort();
          }
        }
        break;
      }
      case 2: {
        const int x = static_cast<int8_t>(value & 0xFF), y = static_cast<int8_t>(value >> 8);
        chair.set_joystick(x, y);
        const bool neutral = x > -10 && x < 10 && y > -10 && y < 10;
        if (!neutral) joystick_neutral_since = UINT64_MAX;
        if (neutral && !joystick_neutral) joystick_neutral_since = now;
        joystick_neutral = neutral;
        break;
      }
      case 3:
        switch (extra % 6) {
          case 0:
            chair.set_charging(value & 1);
            break;
          case 1:
            chair.set_clutch_drive(value & 1);
            break;
          case 2:
            chair.set_error(value & 1 ? 0x10C3 : 0);
            break;
          case 3:
            chair.set_distance(value % 4, address);
            break;
          case 4:
            chair.set_actuator_overcurrent(1 + value % 6, address & 1);
            break;
          default:
            chair.press_button(static_cast<uint16_t>(0x0062 + value % 7), address % 3);
            break;
        }
        break;
      default: {
        std::array<uint16_t, 8> out{};
        (void)chair.read(address, std::span<uint16_t>(out.data(), 1 + extra % 8));
        break;
      }
    }
    check_table1(chair);
    // D-8: after a stop, no hold-type motion command comes back by itself.
    if (chair.safety_stops() != stops_seen) {
      stops_seen = chair.safety_stops();
      held_since_stop = false;
    }
    if (!held_since_stop && any_hold(chair)) std::abort();
    if (now - silent_since > 500) {
      for (uint16_t r = reg::kPhoneForward; r <= reg::kPhoneRight; ++r) {
        if (chair.command(r)) std::abort();  // the watchdog must have dropped it
      }
    }
  }
  return 0;
}
