// Values as people read and type them. Every unit, scale and name comes
// from the row; nothing here knows a device.
#include "rtukit/devices/profile/text.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

namespace rtukit::profile {
namespace {

unsigned decimals_of(uint16_t scale) {
  unsigned d = 0;
  for (unsigned s = scale; s >= 10; s /= 10) ++d;
  return d;
}

std::string number_text(const Row& row, int64_t raw) {
  if (row.scale > 1) return fmt::format("{:.{}f}", RegisterMap::to_number(row, raw), decimals_of(row.scale));
  return fmt::format("{}", raw);
}

std::string with_unit(std::string text, std::string_view unit) {
  if (unit.empty()) return text;
  return text + " " + std::string(unit);
}

std::string trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

// A whole number, decimal or 0x hex, possibly negative.
std::optional<int64_t> parse_integer(std::string_view t) {
  bool negative = false;
  if (!t.empty() && (t[0] == '-' || t[0] == '+')) {
    negative = t[0] == '-';
    t.remove_prefix(1);
  }
  int base = 10;
  if (t.size() > 2 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X')) {
    base = 16;
    t.remove_prefix(2);
  }
  int64_t v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v, base);
  if (t.empty() || ec != std::errc{} || end != t.data() + t.size()) return std::nullopt;
  return negative ? -v : v;
}

std::optional<double> parse_decimal(std::string_view t) {
  double v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc{} || end != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string range_text(const Row& row, Range r) {
  if (row.encoding == Encoding::duration)
    return fmt::format("{}..{}", format_mm_ss(static_cast<unsigned>(r.min)),
                       format_mm_ss(static_cast<unsigned>(r.max)));
  return with_unit(fmt::format("{}..{}", number_text(row, r.min), number_text(row, r.max)), row.unit);
}

std::string names_list(const Row& row) {
  std::string out;
  for (const Named& n : row.names) {
    if (!out.empty()) out += ", ";
    out += fold_name(n.name);
  }
  return out;
}

// The names a write may give: those inside the row's write range (every
// name when none is: a row nobody writes lists what it reads).
std::string writable_names(const Row& row) {
  std::string out;
  for (const Named& n : row.names) {
    if (RegisterMap::check_value(row, n.value)) continue;
    if (!out.empty()) out += ", ";
    out += fold_name(n.name);
  }
  return out.empty() ? names_list(row) : out;
}

Outcome<int64_t> checked(const Row& row, int64_t raw, std::string_view typed) {
  if (RegisterMap::check_value(row, raw)) {
    // A name the row reads but a write may not give (the Inverjet's
    // fault_screen, 17: the machine enters it itself): said so, not "not
    // one of" a list that holds it.
    if (row.encoding == Encoding::choice && !name_of(row, raw).empty())
      return Status(
          Errc::illegal_data_value,
          fmt::format("{}: {} ({}) is read only: the device sets it itself; a write takes {}", row.key, typed,
                      fold_name(typed) == fold_name(name_of(row, raw)) ? std::to_string(raw)
                                                                       : fold_name(name_of(row, raw)),
                      writable_names(row)));
    if (row.encoding == Encoding::choice)
      return Status(Errc::illegal_data_value,
                    fmt::format("{}: {} is not one of {}", row.key, typed, writable_names(row)));
    return Status(Errc::illegal_data_value,
                  fmt::format("{}: {} is outside {}", row.key, typed, range_text(row, row.write_range())));
  }
  return raw;
}

}  // namespace

std::vector<std::string_view> flag_names(const Profile& profile, const Row& row) {
  std::vector<std::string_view> out;
  if (row.has(kPersisted)) out.push_back("persisted");
  for (const FlagName& f : profile.flag_names) {
    if ((f.flag & kDeviceFlagBits) && row.has(f.flag)) out.push_back(f.name);
  }
  for (const FlagName& kit : kKitFlags) {
    if (kit.flag != kPersisted && row.has(kit.flag)) out.push_back(kit.name);
  }
  return out;
}

std::string_view name_of(const Row& row, int64_t value) noexcept {
  for (const Named& n : row.names) {
    if (n.value == value) return n.name;
  }
  return {};
}

std::string fold_name(std::string_view name) {
  std::string out;
  for (char c : name) {
    const auto u = static_cast<unsigned char>(c);
    out += c == ' ' || c == '-' ? '_' : static_cast<char>(std::tolower(u));
  }
  return out;
}

std::string canonical_key(std::string_view typed) {
  return fold_name(typed);
}

const Row* find_row(const RegisterMap& map, std::string_view typed) {
  const std::string key = canonical_key(typed);
  for (const Row& r : map.rows()) {
    if (fold_name(r.key) == key) return &r;
  }
  return nullptr;
}

namespace {
// Levenshtein distance, two rows; keys are short.
size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}
}  // namespace

const Row* nearest_row(const RegisterMap& map, std::string_view typed) {
  const std::string key = canonical_key(typed);
  const Row* best = nullptr;
  size_t best_distance = SIZE_MAX;
  bool tie = false;
  for (const Row& r : map.rows()) {
    const size_t d = edit_distance(key, fold_name(r.key));
    if (d < best_distance) {
      best = &r;
      best_distance = d;
      tie = false;
    } else if (d == best_distance) {
      tie = true;
    }
  }
  // Near enough to be the same word mistyped, and only one such.
  if (!best || tie || best_distance > 2 || best_distance * 3 >= std::max<size_t>(key.size(), 1))
    return nullptr;
  return best;
}

std::string excerpt(std::string_view s, size_t max) {
  std::string out;
  while (!s.empty() && out.size() < max) {
    const size_t valid = valid_utf8_prefix(s);
    if (valid == 0) {
      out += '?';
      s.remove_prefix(1);
      continue;
    }
    std::string_view piece = s.substr(0, std::min(valid, max - out.size()));
    piece = piece.substr(0, valid_utf8_prefix(piece));  // never half a character
    if (piece.empty()) break;
    out += piece;
    s.remove_prefix(piece.size());
  }
  return out;
}

size_t valid_utf8_prefix(std::string_view s) noexcept {
  constexpr uint32_t kMin[] = {0, 0, 0x80, 0x800, 0x10000};  // shortest form of each length
  size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<uint8_t>(s[i]);
    const size_t n = c < 0x80             ? 1
                     : (c & 0xE0) == 0xC0 ? 2
                     : (c & 0xF0) == 0xE0 ? 3
                     : (c & 0xF8) == 0xF0 ? 4
                                          : 0;
    if (n == 0 || n > s.size() - i) return i;
    uint32_t cp = n == 1 ? c : c & (0x7Fu >> n);
    for (size_t k = 1; k < n; ++k) {
      const auto d = static_cast<uint8_t>(s[i + k]);
      if ((d & 0xC0) != 0x80) return i;
      cp = cp << 6 | (d & 0x3Fu);
    }
    if (cp < kMin[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return i;
    i += n;
  }
  return i;
}

std::string format_mm_ss(unsigned seconds) {
  return fmt::format("{:02}:{:02}", seconds / 60, seconds % 60);
}

Result<uint32_t> parse_duration(std::string_view text) noexcept {
  // At most 5 digits a number: no overflow, and more is no duration anyway.
  const auto number = [](std::string_view t, uint32_t* out) {
    if (t.empty() || t.size() > 5) return false;
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), *out);
    return ec == std::errc{} && end == t.data() + t.size();
  };
  const char* const form = "write mm:ss or a number with a unit, for example 30:00, 30m, 90s or 1m30s";
  uint32_t a = 0, b = 0;
  if (const size_t colon = text.find(':'); colon != std::string_view::npos) {
    const std::string_view sec = text.substr(colon + 1);
    if (!number(text.substr(0, colon), &a) || sec.size() != 2 || !number(sec, &b) || b > 59)
      return Error(Errc::invalid_argument, form);
    return a * 60 + b;
  }
  if (number(text, &a))
    return Error(Errc::invalid_argument, "a bare number has no unit: write 30:00 (mm:ss), 30m or 90s");
  // "30m", "90s", "1m30s".
  if (const size_t m = text.find('m'); m != std::string_view::npos) {
    if (!number(text.substr(0, m), &a)) return Error(Errc::invalid_argument, form);
    const std::string_view rest = text.substr(m + 1);
    if (rest.empty()) return a * 60;
    if (rest.back() != 's' || !number(rest.substr(0, rest.size() - 1), &b) || b > 59)
      return Error(Errc::invalid_argument, form);
    return a * 60 + b;
  }
  if (!text.empty() && text.back() == 's' && number(text.substr(0, text.size() - 1), &a)) return a;
  return Error(Errc::invalid_argument, form);
}

std::string format_value(const Row& row, int64_t raw) {
  switch (row.encoding) {
    case Encoding::u16:
    case Encoding::i16:
    case Encoding::u32:
    case Encoding::i32:
      return with_unit(number_text(row, raw), row.unit);
    case Encoding::duration:
      return format_mm_ss(static_cast<unsigned>(raw < 0 ? 0 : raw));
    case Encoding::choice: {
      const std::string_view name = name_of(row, raw);
      return name.empty() ? fmt::format("unknown ({})", raw) : fmt::format("{} ({})", name, raw);
    }
    case Encoding::bits: {
      if (raw == 0) return "none";
      std::string out;
      for (unsigned bit = 0; bit < 32; ++bit) {
        if (!(raw & (int64_t{1} << bit))) continue;
        const std::string_view name = name_of(row, bit);
        if (!out.empty()) out += ", ";
        out += name.empty() ? fmt::format("bit {}", bit) : std::string(name);
      }
      return out;
    }
    case Encoding::version:
      return fmt::format("V{}.{}", raw >> 16, raw & 0xFFFF);
    case Encoding::boolean:
      return raw ? "on" : "off";
  }
  return fmt::format("{}", raw);
}

Outcome<int64_t> parse_value(const Row& row, std::string_view typed_view) {
  const std::string typed = trim(typed_view);
  const auto not_a = [&](std::string_view what) {
    return Status(Errc::invalid_argument, fmt::format("'{}' is not {} for {}", typed, what, row.key));
  };
  if (typed.empty()) return not_a("a value");
  switch (row.encoding) {
    case Encoding::choice: {
      const std::string folded = fold_name(typed);
      for (const Named& n : row.names) {
        if (fold_name(n.name) == folded) return checked(row, n.value, typed);
      }
      if (const auto v = parse_integer(typed)) return checked(row, *v, typed);
      return Status(Errc::invalid_argument,
                    fmt::format("'{}' is not a {} ({})", typed, row.key, writable_names(row)));
    }
    case Encoding::bits: {
      if (const auto v = parse_integer(typed)) return checked(row, *v, typed);
      int64_t bits = 0;
      size_t start = 0;
      while (start <= typed.size()) {
        size_t end = typed.find_first_of(",|", start);
        if (end == std::string::npos) end = typed.size();
        const std::string word = fold_name(trim(std::string_view(typed).substr(start, end - start)));
        bool found = false;
        for (const Named& n : row.names) {
          if (fold_name(n.name) == word) {
            bits |= int64_t{1} << n.value;
            found = true;
          }
        }
        if (!found && word != "none")
          return Status(Errc::invalid_argument,
                        fmt::format("'{}' is not a bit of {} ({})", word, row.key, names_list(row)));
        start = end + 1;
      }
      return checked(row, bits, typed);
    }
    case Encoding::duration: {
      const Result<uint32_t> s = parse_duration(typed);
      if (!s.ok()) return not_a("a duration: mm:ss (30:00) or a number with a unit (30m, 90s)");
      return checked(row, *s, typed);
    }
    case Encoding::boolean: {
      const std::string f = fold_name(typed);
      if (f == "on" || f == "true" || f == "1") return int64_t{1};
      if (f == "off" || f == "false" || f == "0") return int64_t{0};
      return not_a("on/off");
    }
    case Encoding::version: {
      const size_t dot = typed.find('.');
      const std::string_view t = typed;
      const auto major = parse_integer(t.substr(t[0] == 'V' || t[0] == 'v' ? 1 : 0, dot));
      const auto minor =
          dot == std::string::npos ? std::optional<int64_t>(0) : parse_integer(t.substr(dot + 1));
      if (!major || !minor || *major < 0 || *major > 0xFFFF || *minor < 0 || *minor > 0xFFFF)
        return not_a("a version (1.2)");
      return checked(row, (*major << 16) | *minor, typed);
    }
    case Encoding::u16:
    case Encoding::i16:
    case Encoding::u32:
    case Encoding::i32: {
      std::string_view number = typed;
      // An optional unit after the number: "80%", "80 %", "31.5 degC".
      if (!row.unit.empty() && number.ends_with(row.unit)) {
        number.remove_suffix(row.unit.size());
        while (!number.empty() && number.back() == ' ') number.remove_suffix(1);
      }
      if (row.scale <= 1) {
        const auto v = parse_integer(number);
        if (!v)
          return not_a(row.unit.empty() ? "a whole number" : fmt::format("a whole number of {}", row.unit));
        return checked(row, *v, typed);
      }
      const auto v = parse_decimal(number);
      if (!v) return not_a("a number");
      const Result<int64_t> raw = RegisterMap::from_number(row, *v);
      if (!raw.ok())
        return Status(Errc::illegal_data_value, fmt::format("{}: {} is outside {}", row.key, typed,
                                                            range_text(row, row.write_range())));
      return checked(row, *raw, typed);
    }
  }
  return not_a("a value");
}

Status check_argument(const Row& row, int64_t raw) {
  const std::string typed = row.encoding == Encoding::duration
                                ? format_mm_ss(static_cast<unsigned>(raw < 0 ? 0 : raw))
                            : row.scale > 1 ? number_text(row, raw)
                                            : std::to_string(raw);
  Outcome<int64_t> r = checked(row, raw, typed);
  if (r.ok()) return {};
  return Status(Errc::invalid_argument, std::string(r.error().reason()));
}

nlohmann::json value_json(const Row& row, int64_t raw) {
  switch (row.encoding) {
    case Encoding::choice: {
      const std::string_view name = name_of(row, raw);
      return name.empty() ? nlohmann::json(raw) : nlohmann::json(std::string(name));
    }
    case Encoding::bits: {
      nlohmann::json names = nlohmann::json::array();
      for (unsigned bit = 0; bit < 32; ++bit) {
        if (!(raw & (int64_t{1} << bit))) continue;
        const std::string_view name = name_of(row, bit);
        names.push_back(name.empty() ? fmt::format("bit {}", bit) : std::string(name));
      }
      return names;
    }
    case Encoding::version:
      return fmt::format("{}.{}", raw >> 16, raw & 0xFFFF);
    case Encoding::boolean:
      return raw != 0;
    default:
      if (row.scale > 1) return RegisterMap::to_number(row, raw);
      return raw;
  }
}

nlohmann::ordered_json quantity_json(nlohmann::ordered_json value, std::string_view unit, std::string text) {
  nlohmann::ordered_json q;
  q["value"] = std::move(value);
  if (!unit.empty()) q["unit"] = unit;
  q["text"] = std::move(text);
  return q;
}

nlohmann::ordered_json entry_json(const Row& row, int64_t raw) {
  nlohmann::ordered_json out;
  out["value"] = value_json(row, raw);
  if (row.encoding == Encoding::duration)
    out["unit"] = "s";
  else if (!row.unit.empty() && row.encoding != Encoding::choice && row.encoding != Encoding::bits)
    out["unit"] = row.unit;
  out["text"] = format_value(row, raw);
  out["raw"] = raw;
  return out;
}

std::string hex(std::span<const uint8_t> bytes) {
  std::string s;
  for (uint8_t b : bytes) s += fmt::format("{}{:02X}", s.empty() ? "" : " ", b);
  return s;
}

std::string_view space_name(Space s) noexcept {
  switch (s) {
    case Space::holding:
      return "holding";
    case Space::input:
      return "input";
    case Space::coil:
      return "coil";
    case Space::discrete:
      return "discrete";
  }
  return "?";
}

std::string_view role_name(Role r) noexcept {
  switch (r) {
    case Role::status:
      return "status";
    case Role::setting:
      return "setting";
    case Role::control:
      return "control";
    case Role::hold:
      return "hold";
    case Role::pulse:
      return "pulse";
    case Role::reserved:
      return "reserved";
  }
  return "?";
}

std::string_view encoding_name(Encoding e) noexcept {
  switch (e) {
    case Encoding::u16:
      return "u16";
    case Encoding::i16:
      return "i16";
    case Encoding::u32:
      return "u32";
    case Encoding::i32:
      return "i32";
    case Encoding::choice:
      return "choice";
    case Encoding::bits:
      return "bits";
    case Encoding::duration:
      return "duration";
    case Encoding::version:
      return "version";
    case Encoding::boolean:
      return "boolean";
  }
  return "?";
}

std::string_view access_name(Access a) noexcept {
  switch (a) {
    case Access::by_role:
      return "by_role";
    case Access::read_only:
      return "read_only";
    case Access::write_only:
      return "write_only";
    case Access::read_write:
      return "read_write";
  }
  return "?";
}

std::string registers_markdown(const Profile& profile) {
  std::string out;
  for (const Space space : {Space::holding, Space::input, Space::coil, Space::discrete}) {
    bool any = false;
    for (const Row& r : profile.rows) any = any || r.space == space;
    if (!any) continue;
    out += fmt::format("### {} ({})\n\n", space_name(space),
                       space == Space::holding ? "FC03 read, FC06/FC10 write"
                       : space == Space::input ? "FC04, read only"
                       : space == Space::coil  ? "FC01 read, FC05/FC0F write"
                                               : "FC02, read only");
    out += "| address | key | name | access | type | unit | range | default | values / notes |\n";
    out += "|---|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : profile.rows) {
      if (r.space != space) continue;
      std::string address = fmt::format("0x{:04X}", r.address);
      if (r.repeat > 1)
        address = fmt::format("0x{:04X} + {}k (k = 0..{})", r.address, r.step(), r.repeat - 1);
      else if (r.words() > 1)
        address = fmt::format("0x{:04X}..0x{:04X}", r.address, r.last_address());
      const char* access = r.writable() ? (r.readable() ? "RW" : "W") : "R";
      std::string notes;
      for (const Named& n : r.names) {
        if (!notes.empty()) notes += ", ";
        notes += r.encoding == Encoding::bits ? fmt::format("bit{} {}", n.value, n.name)
                                              : fmt::format("{} {}", n.value, n.name);
      }
      for (const std::string_view flag : flag_names(profile, r)) {
        if (flag != "persisted") notes += (notes.empty() ? "" : "; ") + std::string(flag);
      }
      if (r.has(kPersisted)) notes += notes.empty() ? "persisted" : "; persisted";
      if (!r.notes.empty()) notes += (notes.empty() ? "" : "; ") + std::string(r.notes);
      std::string type(encoding_name(r.encoding));
      if (r.scale > 1) type += fmt::format(" /{}", r.scale);
      out += fmt::format("| {} | `{}` | {} | {} | {} | {} | {} | {} | {} |\n", address, r.key, r.title,
                         access, type, r.unit.empty() ? "-" : std::string(r.unit),
                         r.range.empty() ? std::string("-") : range_text(r, r.range),
                         r.writable() ? format_value(r, r.default_value) : std::string("-"),
                         notes.empty() ? "-" : notes);
    }
    out += "\n";
  }
  out += "Every address not listed is reserved: a request touching it gets exception 02.\n";
  return out;
}

}  // namespace rtukit::profile
