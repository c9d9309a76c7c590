// The simulated Rehand 6600's console: what the person in the chair and the
// service technician do (joystick, buttons, charger, faults). The rest of the
// simulator is the profile kit's one simulator host.
#include "rtukit/devices/rehand6600/sim.hpp"

#include <fmt/core.h>

#include "rtukit/devices/rehand6600/chair.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/driver/simulation.hpp"

namespace rtukit::rehand6600 {
namespace {

std::optional<bool> on_off(const std::string& w, const char* on, const char* off) {
  if (w == on) return true;
  if (w == off) return false;
  return std::nullopt;
}

// One console line for the chair (the verb and its words), as the console
// always answered it: a reply line, or a usage line.
std::string chair_command(Chair& c, const std::string& verb, std::span<const std::string> words) {
  const auto arg = [&](size_t i) { return i >= 1 && i <= words.size() ? words[i - 1] : std::string(); };
  if (verb == "joystick") {
    const auto x = parse_long(arg(1)), y = parse_long(arg(2));
    if (!x || !y || *x < -100 || *x > 100 || *y < -100 || *y > 100) return "usage: joystick X Y (-100..100)";
    c.set_joystick(static_cast<int>(*x), static_cast<int>(*y));
    return fmt::format("joystick {} {}", *x, *y);
  }
  if (verb == "button") {
    const Register* r = find_register(std::string_view(arg(1)));
    if (!r || r->address < reg::kStandSit || r->address > reg::kPlateTilt)
      return "usage: button stand|seat_lift|backrest|seat_tilt|leg_rotate|leg_extend|plate_tilt "
             "up|down|release";
    const std::string& d = arg(2);
    const uint16_t v = d == "release"                                                   ? 0
                       : (d == "up" || d == "stand" || d == "forward" || d == "extend") ? 1
                       : (d == "down" || d == "sit" || d == "back" || d == "retract")   ? 2
                                                                                        : 3;
    if (v == 3) return "direction: up|down (stand|sit, forward|back, extend|retract) or release";
    c.press_button(r->address, v);
    return fmt::format("button {} {}", r->key, v ? d : "released");
  }
  if (verb == "charger" || verb == "clutch" || verb == "horn" || verb == "view") {
    const auto v = verb == "clutch" ? on_off(arg(1), "drive", "push") : on_off(arg(1), "on", "off");
    if (!v) return fmt::format("usage: {} {}", verb, verb == "clutch" ? "push|drive" : "on|off");
    if (verb == "charger") c.set_charging(*v);
    if (verb == "clutch") c.set_clutch_drive(*v);
    if (verb == "horn") c.set_horn_button(*v);
    if (verb == "view") c.set_view_button(*v);
    return fmt::format("{} {}", verb, arg(1));
  }
  if (verb == "distance") {
    const std::string sides[] = {"front", "rear", "left", "right"};
    const auto mm = parse_long(arg(2));
    for (unsigned i = 0; i < 4; ++i) {
      if (arg(1) == sides[i] && mm && *mm >= 0 && *mm <= 65535) {
        c.set_distance(i, static_cast<uint16_t>(*mm));
        return fmt::format("distance {} {} mm", sides[i], *mm);
      }
    }
    return "usage: distance front|rear|left|right MM";
  }
  if (verb == "battery") {
    const auto v = parse_long(arg(1));
    if (!v || *v < 0 || *v > 100) return "usage: battery PCT (0..100)";
    c.set_battery(static_cast<double>(*v));
    return fmt::format("battery {} %", *v);
  }
  if (verb == "error") {
    if (arg(1) == "clear") {
      c.set_error(0);
      return "error cleared";
    }
    const auto code = parse_long(arg(1), 16);
    if (!code || *code <= 0 || *code > 0xFFFF) return "usage: error CODE (hex, e.g. 10C3) | error clear";
    c.set_error(static_cast<uint16_t>(*code));
    return fmt::format("error {}", error_text(static_cast<uint16_t>(*code)));
  }
  if (verb == "overcurrent") {
    const auto n = parse_long(arg(1));
    const auto v = on_off(arg(2).empty() ? "on" : arg(2), "on", "off");
    if (!n || *n < 1 || *n > 6 || !v) return "usage: overcurrent N (1..6) on|off";
    c.set_actuator_overcurrent(static_cast<unsigned>(*n), *v);
    return fmt::format("actuator {} over-current {}", *n, *v ? "on" : "off");
  }
  if (verb == "id") {
    const auto v = parse_long(arg(1));
    if (!v || *v < 0 || *v > 0xFFFF) return "usage: id 0xNN";
    c.set_device_id(static_cast<uint16_t>(*v));
    return fmt::format("device ID 0x{:02X}", *v);
  }
  return fmt::format("unknown command '{}' (try help)", verb);
}

}  // namespace

profile::SimDevice make_sim_device(const SimConfig& config) {
  auto model = std::make_unique<Chair>(0, config.watchdog_ms);
  Chair& c = *model;
  struct Verb {
    std::string_view verb, usage, help;
  };
  static constexpr Verb kVerbs[] = {
      {"joystick", "joystick X Y", "deflection -100..100 (0 0 = neutral)"},
      {"button", "button POSTURE up|down|stand|sit|release",
       "a physical posture button (stand, seat_lift, backrest, seat_tilt, leg_rotate, leg_extend, "
       "plate_tilt); "
       "outranks the UI"},
      {"charger", "charger on|off", "the charger plugged in (no driving while charging)"},
      {"clutch", "clutch push|drive", "push: free-wheel"},
      {"distance", "distance front|rear|left|right MM", "ultrasonic distances"},
      {"battery", "battery PCT", "battery level"},
      {"error", "error CODE|clear", "a table-3 code in hex (e.g. 10C3)"},
      {"overcurrent", "overcurrent N on|off", "actuator 1..6"},
      {"horn", "horn on|off", "the joystick's horn button"},
      {"view", "view on|off", "the joystick's 360-view button"},
      {"id", "id 0xNN", "the device ID the controller reports (0x68)"},
  };
  std::vector<profile::ConsoleVerb> verbs;
  for (const Verb& v : kVerbs) {
    verbs.push_back(
        {v.verb, v.usage, v.help, [&c, verb = std::string(v.verb)](std::span<const std::string> w) {
           return Outcome<std::string>(chair_command(c, verb, w));
         }});
  }
  const uint32_t watchdog = config.watchdog_ms;
  const auto status_extra = [&c, watchdog]() {
    std::string out = fmt::format("  watchdog {} ms, {} trip(s)\n", watchdog, c.watchdog_trips());
    const uint16_t error = c.status(reg::kErrorCode);
    if (error) out += fmt::format("  local error: {}\n", error_text(error));
    out += "  held commands:";
    bool any = false;
    for (const Register& r : registers()) {
      if (table_of(r) == Table::command && r.role == Role::hold && c.command(r.address)) {
        out += fmt::format(" {}={}", r.key, c.command(r.address));
        any = true;
      }
    }
    out += any ? "\n" : " none\n";
    return out;
  };
  return profile::SimDevice{std::move(model), std::move(verbs), status_extra,
                            fmt::format(", watchdog {} ms", config.watchdog_ms)};
}

}  // namespace rtukit::rehand6600
