// The host daemon's messages, checked: see rehand_message.hpp. Every field is
// read with its type checked first (nlohmann::json::value() throws on a
// field of another type, and an exception here would end the web thread).
#include "rtukit/programs/rehand_message.hpp"

#include <fmt/core.h>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"

namespace rtukit::programs {
namespace {

namespace rh = rehand6600;
using Json = nlohmann::json;
using Kind = HostCommand::Kind;

rtukit::Status refuse(std::string reason) {
  return rtukit::Status(Errc::refused, std::move(reason));
}
rtukit::Status bad(std::string reason) {
  return rtukit::Status(Errc::invalid_argument, std::move(reason));
}

HostCommand command(Kind kind, uint16_t address = 0, uint16_t value = 0) {
  HostCommand c;
  c.kind = kind;
  c.address = address;
  c.value = value;
  return c;
}

std::optional<uint16_t> direction_register(std::string_view dir) {
  if (dir == "forward") return rh::reg::kPhoneForward;
  if (dir == "reverse") return rh::reg::kPhoneReverse;
  if (dir == "left") return rh::reg::kPhoneLeft;
  if (dir == "right") return rh::reg::kPhoneRight;
  return std::nullopt;
}

bool is_posture(uint16_t a) {
  return a >= rh::reg::kStandSit && a <= rh::reg::kPlateTilt;
}

// A JSON value as the text profile::parse_value reads ("up", "2", "outdoor").
std::optional<std::string> value_text(const Json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_integer()) return std::to_string(v.get<int64_t>());
  return std::nullopt;
}

// A text field: `fallback` when absent, nullopt when of another type.
std::optional<std::string> text_field(const Json& m, const char* key, std::string fallback = {}) {
  if (!m.contains(key)) return fallback;
  if (!m[key].is_string()) return std::nullopt;
  return m[key].get<std::string>();
}

// A command row by its key, checked to be one of `allowed`.
rtukit::Outcome<const rh::Register*> command_row(const Json& m, bool (*allowed)(const rh::Register&)) {
  if (!m.contains("command") || !m["command"].is_string()) return bad("\"command\" must be a register key");
  const std::string key = m["command"].get<std::string>();
  const rh::Register* r = rh::find_register(key);
  if (!r || rh::table_of(*r) != rh::Table::command || !allowed(*r))
    return bad(fmt::format("'{}' is not a command this page may send", key));
  return r;
}

// "value" as `r` reads it (a name or a number).
rtukit::Outcome<uint16_t> row_value(const Json& m, const rh::Register& r) {
  const std::optional<std::string> v = m.contains("value") ? value_text(m["value"]) : std::nullopt;
  if (!v) return bad("\"value\" must be a name or a number");
  const Outcome<int64_t> raw = profile::parse_value(r, *v);
  if (!raw) return bad(std::string(raw.error().reason()));
  return static_cast<uint16_t>(*raw);
}

rtukit::Outcome<HostCommand> display_command(const std::string& op, const Json& m) {
  if (op == "hold" || op == "release") {
    auto row = command_row(m, [](const rh::Register& r) {
      return r.role == profile::Role::hold && (is_posture(r.address) || r.address == rh::reg::kAntiPinch);
    });
    if (!row) return row.error();
    const rh::Register& r = **row;
    if (op == "release") return command(Kind::release, r.address);
    const rtukit::Outcome<uint16_t> value = row_value(m, r);
    if (!value) return value.error();
    return command(*value == 0 ? Kind::release : Kind::hold, r.address, *value);
  }
  if (op == "pulse") {
    auto row = command_row(m, [](const rh::Register& r) { return r.address == rh::reg::kLight; });
    if (!row) return row.error();
    return command(Kind::pulse, (*row)->address);
  }
  if (op == "set") {
    if (!m.contains("key") || !m["key"].is_string()) return bad("\"key\" must be drive_mode or speed_level");
    const std::string key = m["key"].get<std::string>();
    const rh::Register* r = rh::find_register(key);
    if (!r || (r->address != rh::reg::kDriveMode && r->address != rh::reg::kSpeedLevel))
      return bad(fmt::format("'{}' is not a setting (drive_mode, speed_level)", key));
    const rtukit::Outcome<uint16_t> value = row_value(m, *r);
    if (!value) return value.error();
    return command(Kind::set, r->address, *value);
  }
  if (op == "one_touch") {
    const std::optional<std::string> v = text_field(m, "value");
    if (v == "stop") return command(Kind::one_touch, rh::reg::kStandSit, 0);
    if (v != "stand" && v != "sit") return bad("\"value\" must be stand, sit or stop");
    return command(Kind::one_touch, rh::reg::kStandSit, v == "stand" ? 1 : 2);
  }
  if (op == "pair_start") return command(Kind::pair_start);
  if (op == "pair_cancel") return command(Kind::pair_cancel);
  if (op == "revoke") {
    if (!m.contains("client") || !m["client"].is_number_unsigned())
      return bad("\"client\" must be a client id");
    HostCommand c = command(Kind::revoke);
    c.client = m["client"].get<uint64_t>();
    return c;
  }
  return bad(fmt::format("unknown command '{}'", op));
}

rtukit::Outcome<HostCommand> phone_command(const std::string& op, const Json& m, bool paired) {
  if (op == "pair") {
    HostCommand c = command(Kind::pair);
    if (paired) return c;  // paired already: nothing to check, nothing to do
    const std::optional<std::string> code = text_field(m, "code");
    const std::optional<std::string> name = text_field(m, "name");
    if (!code) return bad("\"code\" must be the code the display shows");
    if (!name) return bad("\"name\" must be text");
    c.code = *code;
    c.name = *name;
    return c;
  }
  if (!paired) return refuse("not paired: enter the code the display shows");
  if (op == "drive") {
    const std::optional<std::string> dir = text_field(m, "dir");
    if (dir && (dir->empty() || *dir == "none")) return command(Kind::drive, 0);
    const std::optional<uint16_t> a = dir ? direction_register(*dir) : std::nullopt;
    if (!a) return bad("\"dir\" must be forward, reverse, left, right or none");
    return command(Kind::drive, *a);
  }
  if (op == "horn") {
    if (m.contains("on") && !m["on"].is_boolean()) return bad("\"on\" must be true or false");
    const bool on = m.contains("on") && m["on"].get<bool>();
    return command(Kind::horn, rh::reg::kPhoneHorn, on ? 1 : 0);
  }
  if (op == "pulse") {
    const std::string what = text_field(m, "command").value_or("");
    const uint16_t a = what == "light"          ? rh::reg::kPhoneLight
                       : what == "left_signal"  ? rh::reg::kPhoneLeftSignal
                       : what == "right_signal" ? rh::reg::kPhoneRightSignal
                                                : 0;
    if (!a) return bad("\"command\" must be light, left_signal or right_signal");
    return command(Kind::pulse, a);
  }
  return bad(fmt::format("unknown command '{}'", op));
}

}  // namespace

HostMessage parse_host_message(std::string_view text, HostRole role, bool paired) {
  HostMessage out;
  const Json m = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (m.is_discarded() || !m.is_object() || !m.contains("op") || !m["op"].is_string()) return out;
  out.envelope = true;
  out.op = m["op"].get<std::string>();
  if (m.contains("id")) out.id = m["id"];
  out.command = role == HostRole::display ? display_command(out.op, m) : phone_command(out.op, m, paired);
  return out;
}

}  // namespace rtukit::programs
