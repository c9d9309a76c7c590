// The Rehand 6600's one-shot handshake and its commands by name.
#include "rtukit/devices/rehand6600/verbs.hpp"

#include <fmt/core.h>

#include <array>
#include <cstdlib>
#include <string>
#include <vector>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/host.hpp"

namespace rtukit::rehand6600 {

std::string device_id_mismatch(uint16_t id) {
  return fmt::format("device ID 0x{:02X}, expected 0x{:02X}", id, kDeviceId);
}

rtukit::Status handshake(Master& master, UnitId unit) {
  std::array<uint16_t, 1> id{};
  if (Error e = master.read_holding_registers(unit, reg::kDeviceId, id)) {
    if (e.code() == Errc::io_error || e.code() == Errc::not_connected) return e;
    // An exception is an answer from something that is not the controller.
    if (e.is_exception())
      return rtukit::Status(Errc::refused,
                            fmt::format("handshake: Modbus exception {:02X}", e.exception_code()));
    return rtukit::Status(e, fmt::format("handshake: no answer ({})", e.name()));
  }
  if (id[0] != kDeviceId)
    return rtukit::Status(Errc::refused, fmt::format("handshake: {} (not a Rehand 6600 controller?)",
                                                     device_id_mismatch(id[0])));
  return {};
}

Outcome<const Register*> command_register(std::string_view key, Kind kind) {
  const Register* r = profile::find_row(kMap, key);  // seat_lift or seat-lift
  if (r && r->role == kind && r->address != reg::kHostReady) return r;
  std::string names;
  for (const Register& x : registers()) {
    if (x.role == kind && x.address != reg::kHostReady)
      names += (names.empty() ? "" : ", ") + std::string(x.key);
  }
  return rtukit::Status(Errc::invalid_argument, fmt::format("'{}' is not a {} command ({})", key,
                                                            kind == Kind::hold ? "hold" : "pulse", names));
}

Outcome<uint16_t> command_value(const Register& r, std::string_view text) {
  std::vector<const profile::Named*> directions;
  for (const profile::Named& c : r.names)
    if (c.value != 0) directions.push_back(&c);
  if (text.empty() && directions.size() <= 1) return directions.empty() ? uint16_t{1} : directions[0]->value;
  for (const profile::Named* c : directions)
    if (c->name == text) return c->value;
  // The number, when it is one of the listed values (seat_lift 1 = up).
  const std::string digits(text);
  char* end = nullptr;
  const unsigned long n = std::strtoul(digits.c_str(), &end, 0);
  if (!digits.empty() && *end == '\0') {
    for (const profile::Named* c : directions)
      if (c->value == n) return c->value;
  }
  std::string names;
  for (size_t i = 0; i < directions.size(); ++i) {
    if (i > 0) names += i + 1 == directions.size() ? " or " : ", ";
    names += fmt::format("{} ({})", directions[i]->name, directions[i]->value);
  }
  if (text.empty())
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("hold {} needs a direction: {} (nothing sent)", r.key, names));
  return rtukit::Status(
      Errc::invalid_argument,
      fmt::format("hold {}: '{}' is not one of its directions: {} (nothing sent)", r.key, text, names));
}

Outcome<std::chrono::milliseconds> parse_hold_duration(std::string_view text) {
  const auto too_long = [&] {
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("duration '{}': e.g. 2s, 500ms, 1m (at most 10 minutes)", text));
  };
  // The one duration form every front-end takes (1m, 1m30s, 1:30, 90s), then
  // what a short hold needs beyond it: milliseconds and decimal seconds.
  if (!text.ends_with("ms")) {
    if (const Result<uint32_t> s = profile::parse_duration(text); s.ok()) {
      if (*s == 0 || *s > 600) return too_long();
      return std::chrono::milliseconds(*s * 1000LL);
    }
  }
  std::string t(text);
  double scale = 1000;
  if (t.ends_with("ms")) {
    scale = 1;
    t.resize(t.size() - 2);
  } else if (t.ends_with("s")) {
    t.resize(t.size() - 1);
  }
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || *end != '\0' || !(v > 0) || v * scale > 600000) return too_long();
  return std::chrono::milliseconds(static_cast<long>(v * scale));
}

Outcome<SettingChange> parse_setting(std::string_view what, std::string_view value) {
  // The setting's row decides what the value may be ("outdoor" or 3; 1..5).
  const Register* r = what == "host-fault" ? find_register(reg::kHostFault)
                                           : find_register(std::string_view(profile::canonical_key(what)));
  if (!r || r->role != Kind::setting)
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("set {}: expected drive-mode, speed-level or host-fault", what));
  const Outcome<int64_t> n = profile::parse_value(*r, value);
  if (!n.ok()) return n.error();
  return SettingChange{r, static_cast<uint16_t>(*n)};
}

rtukit::Status write_setting(Host& host, const SettingChange& c) {
  if (c.row->address == reg::kDriveMode) return host.set_drive_mode(c.raw);
  if (c.row->address == reg::kSpeedLevel) return host.set_speed_level(c.raw);
  return host.set_host_fault(c.raw);
}

}  // namespace rtukit::rehand6600
