// The Rehand 6600's table 1 as text and JSON: what `status` and `watch` print.
#include "rtukit/devices/rehand6600/views.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/motion.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"

namespace rtukit::rehand6600 {
namespace {

using Json = nlohmann::ordered_json;

uint16_t actuator(const Snapshot& s, unsigned i) {
  return s[reg::actuator_position(i + 1)];
}

}  // namespace

std::string value_text(const Snapshot& s, std::string_view key) {
  const Register& r = *find_register(key);
  const std::string_view name = profile::name_of(r, s[r.address]);
  return name.empty() ? format_value(r, s[r.address]) : std::string(name);
}

std::string speed_text(const Snapshot& s, bool mph) {
  return mph ? fmt::format("{:.1f} mph", s.speed_mph()) : fmt::format("{} km/h", s.speed_kmh());
}

std::string wrapped(std::string_view head, std::string_view text) {
  std::string out, line(head);
  size_t at = 0;
  while (at < text.size()) {
    size_t end = text.find(' ', at);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view word = text.substr(at, end - at);
    if (line.size() > head.size() && line.size() + 1 + word.size() > 80) {
      out += line + "\n";
      line = std::string(head.size(), ' ');
    }
    line += (line.size() > head.size() ? " " : "") + std::string(word);
    at = end + 1;
  }
  return out + line + "\n";
}

std::string actuators(const Snapshot& s) {
  std::string out;
  for (unsigned i = 0; i < 6; ++i) out += fmt::format("{}{}", i ? " " : "", actuator(s, i));
  return out;
}

std::string panel(const Snapshot& s, bool mph, const Highlight& alert) {
  const auto mark = [&alert](std::string_view text) { return alert ? alert(text) : std::string(text); };
  const auto v = [&s](std::string_view key) { return value_text(s, key); };
  std::string out;
  if (s.error_code())
    out += mark(fmt::format("!!! {} : every function is disabled !!!", error_text(s.error_code()))) + "\n";
  out += fmt::format("battery   {} %{}   clutch {}\n", s.battery(), s.charging() ? " (charging)" : "",
                     v("clutch"));
  out += fmt::format("motion    {}   speed {}\n", v("motion"), speed_text(s, mph));
  out += fmt::format("lights    main {}, left {}, right {}\n", v("main_light"), v("left_signal"),
                     v("right_signal"));
  out += fmt::format("posture   seat lift {}, backrest {}, stand/sit {}\n", v("seat_lift_status"),
                     v("backrest_status"), v("stand_status"));
  out += fmt::format("          seat tilt {}, leg rest {}\n", v("seat_tilt_status"), v("leg_rest_status"));
  out += "actuators";
  for (unsigned i = 0; i < 6; ++i) {
    if (i == 3) out += "\n         ";  // three a line: 80 columns
    out += fmt::format(" {}:{} {}", i + 1, actuator(s, i), v(fmt::format("actuator{}_state", i + 1)));
  }
  out += fmt::format("\ndistances front {} mm, rear {} mm, left {} mm, right {} mm\n", s[reg::kDistanceFront],
                     s[reg::kDistanceRear], s[reg::kDistanceLeft], s[reg::kDistanceRight]);
  out += fmt::format("buttons   horn {}, 360 view {}\n", v("horn_button"), v("view_button"));
  out +=
      fmt::format("error     {}\n", s.error_code() ? mark(error_text(s.error_code())) : std::string("none"));
  if (s.error_code()) out += wrapped("advice    ", error_advice(s.error_code()));
  return out;
}

std::string line(const Snapshot& s, bool mph) {
  const auto v = [&s](std::string_view key) { return value_text(s, key); };
  return fmt::format("battery {}%{} | {} {} | light {} | seat {} stand {} legs {} | act {} | error {}",
                     s.battery(), s.charging() ? "+" : "", v("motion"), speed_text(s, mph), v("main_light"),
                     v("seat_lift_status"), v("stand_status"), v("leg_rest_status"), actuators(s),
                     s.error_code() ? error_text(s.error_code()) : "none");
}

Json snapshot_values(const Snapshot& s, bool mph) {
  Json values = Json::object();
  for (const Register& r : registers()) {
    if (table_of(r) != Table::status || r.key.starts_with("reserved")) continue;
    const int64_t raw = r.is_signed() ? int64_t{static_cast<int16_t>(s[r.address])} : int64_t{s[r.address]};
    values[std::string(r.key)] = profile::entry_json(r, raw);
  }
  if (mph)
    values["speed_mph"] =
        profile::quantity_json(std::round(s.speed_mph() * 10) / 10, "mph", speed_text(s, true));
  const std::string error = s.error_code() ? error_text(s.error_code()) : std::string();
  values["error_text"] = profile::quantity_json(error, {}, error.empty() ? "none" : error);
  const std::string advice = s.error_code() ? error_advice(s.error_code()) : std::string();
  values["error_advice"] = profile::quantity_json(advice, {}, advice.empty() ? "none" : advice);
  return values;
}

Json status_numbers(const Snapshot& s) {
  Json values = Json::object();
  for (const Register& r : registers()) {
    if (table_of(r) != Table::status || r.key.starts_with("reserved")) continue;
    values[std::string(r.key)] =
        r.is_signed() ? int64_t{static_cast<int16_t>(s[r.address])} : int64_t{s[r.address]};
  }
  return values;
}

Json state_view(const HostState& s, const ClientNames& names) {
  const Snapshot& snap = s.snapshot;
  Json text = Json::object();
  for (const Register& r : registers())
    if (table_of(r) == Table::status && !r.key.starts_with("reserved"))
      text[std::string(r.key)] = format_value(r, snap[r.address]);
  const auto held_on = [&s](uint16_t command) -> uint16_t {
    for (const Session::Press& h : s.presses)
      if (h.command == command) return h.value;
    return 0;
  };
  Json presses = Json::array();
  for (const Session::Press& p : s.presses)
    presses.push_back({{"command", std::string(find_register(p.command)->key)},
                       {"value", p.value},
                       {"owner", names.owner ? names.owner(p.client) : std::string("display")}});
  const std::string_view mode = profile::name_of(*find_register(reg::kDriveMode), s.drive_mode);
  const uint16_t error = s.active_error;
  return Json{
      {"connected", s.connected && snap.valid},
      {"error", error},
      {"error_text", error ? error_text(error) : ""},
      {"error_advice", error ? error_advice(error) : ""},
      {"values", status_numbers(snap)},
      {"text", text},
      {"drive_mode", mode.empty() ? std::to_string(s.drive_mode) : std::string(mode)},
      {"speed_level", s.speed_level},
      {"postures", postures_view(snap, held_on)},
      {"stand_progress", stand_progress(snap)},
      {"distances", distances_view(snap)},
      {"near_obstacle", s.near_obstacle},
      {"emergency", s.emergency},
      {"stop", s.stop_latched},
      {"presses", presses},
      {"disabled", {{"all", s.disabled.all}, {"drive", s.disabled.drive}, {"raise", s.disabled.raise}}},
      {"driver", s.driver && names.phone ? names.phone(*s.driver) : std::string()}};
}

Json postures_view(const Snapshot& s, const std::function<uint16_t(uint16_t)>& held) {
  const auto name = [](uint16_t address, uint16_t value) {
    const std::string_view n = profile::name_of(*find_register(address), value);
    return n.empty() ? std::to_string(value) : std::string(n);
  };
  Json postures = Json::array();
  for (const Posture& p : kPostures) {
    Json actuators = Json::array();
    bool actuator_moving = false, over_current = false;
    std::string limit;  // the first actuator's limit, if one is at a limit
    for (uint8_t n : p.driven()) {
      const uint16_t state = s[reg::actuator_state(n)];
      actuator_moving = actuator_moving || state == kActuatorMoving;
      over_current = over_current || state == kOverCurrent;
      if (limit.empty() && (state == kUpperLimit || state == kLowerLimit))
        limit = name(reg::actuator_state(n), state);
      actuators.push_back({{"n", n},
                           {"state", name(reg::actuator_state(n), state)},
                           {"position", s[reg::actuator_position(n)]}});
    }
    const uint16_t held_value = held ? held(p.command) : 0;
    const uint16_t status = p.status ? s[p.status] : 0;
    const bool own_status = status != 0 && (status == p.status_values[0] || status == p.status_values[1]);
    const bool moving = own_status || (held_value != 0 && actuator_moving);
    // The one word a screen shows: a fault first; then a motion under way
    // (a limit one actuator reached while the posture still moves is not
    // where the posture is: "lower limit" showed while the seat still came
    // down); then a limit; else still.
    const auto [badge, kind] =
        over_current ? std::pair<std::string, std::string>{"over-current", "over-current"}
        : moving
            ? std::pair<std::string, std::string>{own_status ? name(p.status, status) : "moving", "moving"}
        : !limit.empty() ? std::pair<std::string, std::string>{limit, "limit"}
                         : std::pair<std::string, std::string>{"still", "still"};
    postures.push_back({{"key", std::string(find_register(p.command)->key)},
                        {"status", own_status ? name(p.status, status) : "still"},
                        {"held", held_value ? name(p.command, held_value) : ""},
                        {"moving", moving},
                        {"badge", badge},
                        {"badge_kind", kind},
                        {"actuators", actuators}});
  }
  return postures;
}

int stand_progress(const Snapshot& s) {
  const Posture& stand = *find_posture(reg::kStandSit);
  unsigned sum = 0;
  for (uint8_t n : stand.driven()) sum += s[reg::actuator_position(n)];
  // Positions are per mille: the mean over ten is a percentage.
  return std::min(100, static_cast<int>(sum / (stand.driven().size() * 10)));
}

Json distances_view(const Snapshot& s) {
  return {{"front", s[reg::kDistanceFront]},
          {"rear", s[reg::kDistanceRear]},
          {"left", s[reg::kDistanceLeft]},
          {"right", s[reg::kDistanceRight]}};
}

Json error_json(uint16_t code) {
  Json e;
  e["code"] = fmt::format("{:04X}", code);
  e["function"] = error_function(code);
  e["text"] = error_text(code);
  e["advice"] = error_advice(code);
  return e;
}

std::string link_failure_text(std::string_view reason, bool another_device) {
  const std::string check =
      another_device ? std::string("check --port and --unit: another device answers there")
                     : fmt::format(
                           "check that the controller is powered on, the UART cable and its connectors, "
                           "--baud ({} unless changed) and --unit ({})",
                           kDefaultBaud, kDefaultAddress);
  return fmt::format("{}: {}; {}", error_text(kMasterCommunicationError), reason, check);
}

}  // namespace rtukit::rehand6600
