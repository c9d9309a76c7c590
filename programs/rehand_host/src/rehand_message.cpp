// The host daemon's messages, checked: see rehand_message.hpp. Every field is
// read with its type checked first (nlohmann::json::value() throws on a
// field of another type, and an exception here would end the web thread).
#include "rtukit/programs/rehand_message.hpp"

#include <fmt/core.h>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/session.hpp"
#include "rtukit/web/webcrypto.hpp"

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

// The session's client kind of a role: which commands a role may name is
// the Session's rule (rh::may_press, rh::may_send), not restated here.
rh::ClientKind kind_of(HostRole role) {
  return role == HostRole::display ? rh::ClientKind::display : rh::ClientKind::phone;
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

// A command row by its key, checked to be one `role` may press (a hold row)
// or pulse (a pulse row), as the Session rules.
rtukit::Outcome<const rh::Register*> command_row(const Json& m, HostRole role, rh::Role row_role) {
  if (!m.contains("command") || !m["command"].is_string()) return bad("\"command\" must be a register key");
  const std::string key = m["command"].get<std::string>();
  const rh::Register* r = rh::find_register(key);
  const bool allowed =
      r && (row_role == rh::Role::hold ? rh::may_press(kind_of(role), r->address)
                                       : r->role == row_role && rh::may_send(kind_of(role), r->address));
  if (!r || rh::table_of(*r) != rh::Table::command || !allowed)
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

// "press": a press id, a positive integer.
rtukit::Outcome<uint64_t> press_id(const Json& m) {
  if (!m.contains("press") || !m["press"].is_number_unsigned() || m["press"].get<uint64_t>() == 0 ||
      m["press"].get<uint64_t>() > (uint64_t{1} << 53))
    return bad("\"press\" must be a press id (a positive integer, new for each press)");
  return m["press"].get<uint64_t>();
}

rtukit::Outcome<HostCommand> press_command(const std::string& op, const Json& m, HostRole role) {
  const rtukit::Outcome<uint64_t> id = press_id(m);
  if (!id) return id.error();
  if (op != "press") {
    HostCommand c = command(op == "renew" ? Kind::renew : Kind::release);
    c.press = *id;
    return c;
  }
  auto row = command_row(m, role, rh::Role::hold);
  if (!row) return row.error();
  const rtukit::Outcome<uint16_t> value = row_value(m, **row);
  if (!value) return value.error();
  if (*value == 0) return bad("\"value\" must not be 0 (off): a press holds a command; lift with release");
  HostCommand c = command(Kind::press, (*row)->address, *value);
  c.press = *id;
  return c;
}

rtukit::Outcome<HostCommand> display_command(const std::string& op, const Json& m) {
  if (op == "press" || op == "renew" || op == "release") return press_command(op, m, HostRole::display);
  if (op == "stop") return command(Kind::stop);
  if (op == "lift_stop") return command(Kind::lift_stop);
  if (op == "pulse") {
    auto row = command_row(m, HostRole::display, rh::Role::pulse);
    if (!row) return row.error();
    return command(Kind::pulse, (*row)->address);
  }
  if (op == "set") {
    if (!m.contains("key") || !m["key"].is_string()) return bad("\"key\" must be drive_mode or speed_level");
    const std::string key = m["key"].get<std::string>();
    const rh::Register* r = rh::find_register(key);
    if (!r || r->role != rh::Role::setting || !rh::may_send(rh::ClientKind::display, r->address))
      return bad(fmt::format("'{}' is not a setting (drive_mode, speed_level)", key));
    const rtukit::Outcome<uint16_t> value = row_value(m, *r);
    if (!value) return value.error();
    return command(Kind::set, r->address, *value);
  }
  if (op == "pair_start") return command(Kind::pair_start);
  if (op == "pair_cancel") return command(Kind::pair_cancel);
  if (op == "forget" || op == "confirm") {
    const std::optional<std::string> phone = text_field(m, "phone");
    if (!phone || phone->empty() || phone->size() > 64) return bad("\"phone\" must be a phone id");
    HostCommand c = command(op == "forget" ? Kind::forget : Kind::confirm);
    c.phone = *phone;
    return c;
  }
  if (op == "forget_all") return command(Kind::forget_all);
  return bad(fmt::format("unknown command '{}'", op));
}

rtukit::Outcome<HostCommand> phone_command(const std::string& op, const Json& m, bool authenticated) {
  if (op == "auth" || op == "pair") {
    if (authenticated) return bad("this connection is authenticated already");
    // What a connection proves it holds: the key's signature of the
    // challenge in the hello (docs/rehand6600-remote.md).
    const std::optional<std::string> signature_text = text_field(m, "signature");
    const std::optional<std::string> signature =
        signature_text && signature_text->size() <= 128 ? web::from_base64url(*signature_text) : std::nullopt;
    if (!signature || signature->size() != 64)
      return bad("\"signature\" must be this phone's signature of the challenge (ECDSA P-256, base64url)");
    if (op == "auth") {
      const std::optional<std::string> phone = text_field(m, "phone");
      if (!phone || phone->empty() || phone->size() > 64) return bad("\"phone\" must be this phone's id");
      HostCommand c = command(Kind::auth);
      c.phone = *phone;
      c.signature = *signature;
      return c;
    }
    const std::optional<std::string> code = text_field(m, "code");
    const std::optional<std::string> name = text_field(m, "name");
    const std::optional<std::string> key_text = text_field(m, "key");
    const std::optional<std::string> key =
        key_text && key_text->size() <= 128 ? web::from_base64url(*key_text) : std::nullopt;
    if (!code || code->size() > 16) return bad("\"code\" must be the code the display shows");
    if (!name || name->size() > 200) return bad("\"name\" must be text");
    if (!key || !web::valid_p256_key(*key))
      return bad("\"key\" must be this phone's public key (ECDSA P-256, raw, base64url)");
    HostCommand c = command(Kind::pair);
    c.code = *code;
    c.name = phone_name(*name);
    c.public_key = *key;
    c.signature = *signature;
    return c;
  }
  if (!authenticated)
    return refuse("not paired: authenticate first, or pair with the code the display shows");
  if (op == "press" || op == "renew" || op == "release") return press_command(op, m, HostRole::phone);
  if (op == "pulse") {
    auto row = command_row(m, HostRole::phone, rh::Role::pulse);
    if (!row) return row.error();
    return command(Kind::pulse, (*row)->address);
  }
  return bad(fmt::format("unknown command '{}'", op));
}

}  // namespace

std::string phone_name(std::string_view raw, std::string_view fallback) {
  constexpr size_t kMaxChars = 40;
  std::string out;
  size_t chars = 0;
  bool space = false;
  auto put = [&](uint32_t cp) {
    if (cp == ' ' || cp == '\t' || cp == 0xA0) {
      space = !out.empty();  // leading spaces dropped, a run becomes one
      return;
    }
    const bool control = cp < 0x20 || (cp >= 0x7F && cp <= 0x9F);
    const bool bidi = cp == 0x061C || cp == 0x200E || cp == 0x200F || (cp >= 0x202A && cp <= 0x202E) ||
                      (cp >= 0x2066 && cp <= 0x2069);
    const bool invisible = cp == 0x200B || cp == 0xFEFF || cp == 0x2028 || cp == 0x2029;
    if (control || bidi || invisible || chars >= kMaxChars) return;
    if (space && chars + 1 < kMaxChars) {
      out += ' ';
      ++chars;
    }
    space = false;
    // UTF-8 encoding of cp (a valid scalar value here)
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
    ++chars;
  };
  for (size_t i = 0; i < raw.size();) {
    const auto b = static_cast<unsigned char>(raw[i]);
    const size_t len = b < 0x80 ? 1 : (b >> 5) == 0x6 ? 2 : (b >> 4) == 0xE ? 3 : (b >> 3) == 0x1E ? 4 : 0;
    uint32_t cp = len == 1 ? b : len == 2 ? b & 0x1F : len == 3 ? b & 0x0F : b & 0x07;
    bool valid = len != 0 && i + len <= raw.size();
    for (size_t k = 1; valid && k < len; ++k) {
      const auto c = static_cast<unsigned char>(raw[i + k]);
      valid = (c & 0xC0) == 0x80;
      cp = (cp << 6) | (c & 0x3F);
    }
    // Overlong forms, surrogates and values past U+10FFFF are not UTF-8 either.
    valid = valid && !(len == 2 && cp < 0x80) && !(len == 3 && cp < 0x800) && !(len == 4 && cp < 0x10000) &&
            !(cp >= 0xD800 && cp <= 0xDFFF) && cp <= 0x10FFFF;
    if (!valid) {
      put(0xFFFD);
      i += 1;  // resynchronise at the next byte
      continue;
    }
    put(cp);
    i += len;
  }
  return out.empty() ? std::string(fallback) : out;
}

HostMessage parse_host_message(std::string_view text, HostRole role, bool authenticated) {
  HostMessage out;
  const Json m = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (m.is_discarded() || !m.is_object() || !m.contains("op") || !m["op"].is_string()) return out;
  out.envelope = true;
  out.op = m["op"].get<std::string>();
  if (m.contains("id")) out.id = m["id"];
  out.command =
      role == HostRole::display ? display_command(out.op, m) : phone_command(out.op, m, authenticated);
  return out;
}

}  // namespace rtukit::programs
