// The simulated controller's runtime: clock scaling, the ticker that keeps
// the model (and its watchdog) running when nobody polls, the console.
#include "rtukit/devices/rehand6600/simulator.hpp"

#include <fmt/core.h>

#include <asio.hpp>
#include <cctype>
#include <charconv>
#include <optional>
#include <vector>

namespace rtukit::rehand6600 {

Simulator::Simulator(SimulatorOptions options)
    : options_(std::move(options)), clock_(options_.time_scale), chair_(0, options_.watchdog_ms) {}

Result<std::unique_ptr<Simulator>> Simulator::start(asio::io_context& ctx, SimulatorOptions options,
                                                    std::string* why) {
  if (!DeviceClock::valid_scale(options.time_scale)) {
    if (why) *why = "--time-scale must be > 0 (and at most 100000)";
    return Errc::invalid_argument;
  }
  if (options.unit < 1 || options.unit > 247) {
    if (why) *why = "unit must be 1..247";
    return Errc::invalid_argument;
  }
  std::unique_ptr<Simulator> sim(new Simulator(std::move(options)));
  Simulator* self = sim.get();
  sim->bank_ = std::make_unique<ChairBank>(sim->chair_, [self] { return self->device_ms(); });
  (void)sim->engine_.add_unit(sim->options_.unit, *sim->bank_);
  auto listener = SlaveListener::start(ctx, sim->engine_, sim->options_.listen, why, sim->options_.log);
  if (!listener.ok()) return listener.error();
  sim->listener_ = std::move(*listener);
  // The model (and its watchdog) runs even when nobody polls.
  sim->ticker_ = std::make_unique<PeriodicTimer>(ctx, std::chrono::milliseconds(10),
                                                 [self] { self->chair_.advance_to(self->device_ms()); });
  return sim;
}

std::string Simulator::where() const {
  return listener_->where();
}

Chair& Simulator::chair() {
  chair_.advance_to(device_ms());
  return chair_;
}

std::string Simulator::status_text() {
  Chair& c = chair();
  std::string out = fmt::format("device time {:.1f} s (x{:g}), watchdog {} ms, {} trip(s)\n",
                                static_cast<double>(c.now_ms()) / 1000.0, options_.time_scale,
                                options_.watchdog_ms, c.watchdog_trips());
  for (const Register& r : registers()) {
    if (r.table != Table::status || r.key.starts_with("reserved")) continue;
    out += fmt::format("  {:<42} {}\n", r.title, format_value(r, c.status(r.address)));
  }
  out += "  held commands:";
  bool any = false;
  for (const Register& r : registers()) {
    if (r.table == Table::command && r.kind == Kind::hold && c.command(r.address)) {
      out += fmt::format(" {}={}", r.key, c.command(r.address));
      any = true;
    }
  }
  out += any ? "\n" : " none\n";
  return out;
}

namespace {
std::optional<bool> on_off(const std::string& w, const char* on, const char* off) {
  if (w == on) return true;
  if (w == off) return false;
  return std::nullopt;
}
}  // namespace

std::string Simulator::command(std::string_view line) {
  const std::vector<std::string> w = split_words(line);
  if (w.empty()) return {};
  Chair& c = chair();
  const std::string& verb = w[0];
  const auto arg = [&](size_t i) { return i < w.size() ? w[i] : std::string(); };
  if (verb == "help" || verb == "?") {
    return "commands:\n"
           "  status                                  print the whole chair\n"
           "  joystick X Y                            deflection -100..100 (0 0 = neutral)\n"
           "  button POSTURE up|down|stand|sit|release  a physical posture button (stand, seat_lift, "
           "backrest,\n"
           "                                          seat_tilt, leg_rotate, leg_extend, plate_tilt); "
           "outranks the UI\n"
           "  charger on|off, clutch push|drive\n"
           "  distance front|rear|left|right MM       ultrasonic distances\n"
           "  battery PCT\n"
           "  error CODE|clear                        a table-3 code in hex (e.g. 10C3)\n"
           "  overcurrent N on|off                    actuator 1..6\n"
           "  horn on|off, view on|off                joystick buttons\n"
           "  id 0xNN                                 the device ID the controller reports (0x68)\n"
           "  quit\n";
  }
  if (verb == "status") return status_text();
  if (verb == "quit" || verb == "exit") {
    quit_ = true;
    return "bye";
  }
  if (verb == "joystick") {
    const auto x = parse_long(arg(1)), y = parse_long(arg(2));
    if (!x || !y || *x < -100 || *x > 100 || *y < -100 || *y > 100) return "usage: joystick X Y (-100..100)";
    c.set_joystick(static_cast<int>(*x), static_cast<int>(*y));
    return fmt::format("joystick {} {}", *x, *y);
  }
  if (verb == "button") {
    const Register* r = find_register(arg(1));
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

}  // namespace rtukit::rehand6600
