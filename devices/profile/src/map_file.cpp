// Register-map files. One document shape for YAML and JSON; every field of a
// Row has a name here, and a field left out takes the Row's default, so a
// small device is a small file.
#include "rtukit/devices/profile/map_file.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <bitset>
#include <charconv>
#include <cstring>
#include <nlohmann/json.hpp>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/io/atomic_file.hpp"

namespace rtukit::profile {
namespace {

// C0 controls and DEL, but for tab and line ends: neither YAML nor JSON
// allows them raw in a document, and yaml-cpp passes them through.
bool is_control(char c) {
  const auto b = static_cast<uint8_t>(c);
  return (b < 0x20 && c != '\t' && c != '\n' && c != '\r') || b == 0x7F;
}

constexpr size_t kMaxMapFile = 4 << 20;

constexpr Space kSpaces[] = {Space::holding, Space::input, Space::coil, Space::discrete};
constexpr Role kRoles[] = {Role::status, Role::setting, Role::control,
                           Role::hold,   Role::pulse,   Role::reserved};
constexpr Encoding kEncodings[] = {Encoding::u16,      Encoding::i16,     Encoding::u32,
                                   Encoding::i32,      Encoding::choice,  Encoding::bits,
                                   Encoding::duration, Encoding::version, Encoding::boolean};
constexpr Access kAccesses[] = {Access::by_role, Access::read_only, Access::write_only, Access::read_write};

std::string_view order_name(WordOrder o) {
  return o == WordOrder::high_first ? "high_first" : "low_first";
}

template <class E, size_t N, class NameOf>
std::string choices_of(const E (&all)[N], NameOf name_of) {
  std::string out;
  for (E e : all) out += (out.empty() ? "" : ", ") + std::string(name_of(e));
  return out;
}

// A parse failure at a node: "SOURCE:LINE: message".
struct Bad {
  std::string message;
};

class Reader {
 public:
  explicit Reader(std::string_view source) : source_(source) {}

  [[noreturn]] void fail(const YAML::Node& at, const std::string& what) const {
    // Every error names a line (the contract in map_file.hpp). A node without
    // a position is the document of an empty file (or one with only
    // comments): line 1. Found by fuzz_map_file; before, the message had none.
    const int line = at.IsDefined() && at.Mark().line >= 0 ? at.Mark().line + 1 : 1;
    throw Bad{fmt::format("{}:{}: {}", source_, line, what)};
  }

  int64_t integer(const YAML::Node& n, std::string_view field) const {
    if (!n.IsScalar()) fail(n, fmt::format("{} must be a whole number", field));
    const std::string s = n.Scalar();
    int64_t v = 0;
    std::string_view t = s;
    bool negative = false;
    if (!t.empty() && t[0] == '-') {
      negative = true;
      t.remove_prefix(1);
    }
    int base = 10;
    if (t.size() > 2 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X')) {
      base = 16;
      t.remove_prefix(2);
    }
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v, base);
    if (t.empty() || ec != std::errc{} || end != t.data() + t.size())
      fail(n, fmt::format("{}: '{}' is not a whole number", field, s));
    return negative ? -v : v;
  }

  std::string text(const YAML::Node& n, std::string_view field) const {
    if (!n.IsScalar()) fail(n, fmt::format("{} must be text", field));
    // Every text of a map is one line (a name, a title, a unit, a label). A
    // control character in it, raw or as an escape ("\0", "\r"), cut it short
    // or changed it when the map was exported again (found by fuzz_map_file).
    const std::string& s = n.Scalar();
    const auto bad = std::find_if(s.begin(), s.end(), [](char c) {
      return static_cast<uint8_t>(c) < 0x20 || static_cast<uint8_t>(c) == 0x7F;
    });
    if (bad != s.end())
      fail(n, fmt::format("{}: control character 0x{:02X} in the text", field, static_cast<uint8_t>(*bad)));
    return s;
  }

  template <class E, size_t N, class NameOf>
  E choice(const YAML::Node& n, std::string_view field, const E (&all)[N], NameOf name_of) const {
    const std::string s = fold_name(text(n, field));
    for (E e : all) {
      if (name_of(e) == s) return e;
    }
    fail(n, fmt::format("unknown {} '{}' ({})", field, n.Scalar(), choices_of(all, name_of)));
  }

  Range range(const YAML::Node& n, std::string_view field) const {
    if (!n.IsSequence() || n.size() != 2) fail(n, fmt::format("{} must be [min, max]", field));
    const Range r{integer(n[0], field), integer(n[1], field)};
    if (r.empty()) fail(n, fmt::format("{} [{}, {}]: min is greater than max", field, r.min, r.max));
    return r;
  }

 private:
  std::string source_;
};

void check_fields(const Reader& reader, const YAML::Node& node, std::initializer_list<std::string_view> known,
                  std::string_view what) {
  for (const auto& kv : node) {
    const std::string key = kv.first.Scalar();
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      std::string list;
      for (std::string_view k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      reader.fail(kv.first, fmt::format("unknown field '{}' in {} (fields: {})", key, what, list));
    }
  }
}

}  // namespace

std::string_view MapProfile::keep(std::string s) {
  strings_.push_back(std::move(s));
  return strings_.back();
}

Status check_profile(const Profile& profile) {
  const auto bad = [&](const Row& r, const std::string& what) {
    return Status(Errc::invalid_argument,
                  fmt::format("register '{}' (0x{:04X}): {}", r.key, r.address, what));
  };
  std::array<std::bitset<65536>, 4> used;
  for (const Row& r : profile.rows) {
    if (r.key.empty()) return bad(r, "no key");
    for (char c : r.key) {
      if (!(std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) ||
            c == '_'))
        return bad(r, "keys are snake_case: a-z, 0-9 and _");
    }
    for (const Row& other : profile.rows) {
      if (&other != &r && other.key == r.key) return bad(r, "the key is used twice");
    }
    const bool bit_space = r.space == Space::coil || r.space == Space::discrete;
    if (bit_space != (r.encoding == Encoding::boolean))
      return bad(r, "coils and discrete inputs are boolean, registers are not");
    if (r.repeat < 1) return bad(r, "repeat must be at least 1");
    if (r.step() < r.words())
      return bad(r, fmt::format("stride {} is less than the {} words of a value", r.step(), r.words()));
    if (uint32_t{r.address} + uint32_t{r.repeat - 1U} * r.step() + r.words() - 1 > 0xFFFF)
      return bad(r, "runs past address 0xFFFF");
    if (r.scale == 0) return bad(r, "scale must be at least 1");
    const Range natural = r.natural_range();
    for (const Range* range : {&r.range, &r.writable_range}) {
      if (range->empty()) continue;
      if (range->min < natural.min || range->max > natural.max)
        return bad(r, fmt::format("range {}..{} is outside what {} can hold ({}..{})", range->min, range->max,
                                  encoding_name(r.encoding), natural.min, natural.max));
    }
    if ((r.encoding == Encoding::choice || r.encoding == Encoding::bits) && r.names.empty())
      return bad(r, fmt::format("a {} needs values", encoding_name(r.encoding)));
    if (r.writable()) {
      for (unsigned i = 0; i < std::min<unsigned>(r.repeat, 2); ++i) {
        if (!r.valid_range().contains(r.default_of(i)))
          return bad(r, fmt::format("default {} is outside its range", r.default_of(i)));
      }
    }
    if (r.has(kLinkAddress) || r.has(kLinkBaud)) {
      const Flags flag = r.has(kLinkAddress) ? kLinkAddress : kLinkBaud;
      if (r.has(kLinkAddress) && r.has(kLinkBaud))
        return bad(r, "a row is link-address or link-baud, not both");
      if (row_with(profile, flag) != &r)
        return bad(r, fmt::format("a second {} row", flag == kLinkAddress ? "link-address" : "link-baud"));
      if (r.space != Space::holding || r.repeat != 1 || !r.writable())
        return bad(r, "a link row is one writable holding register");
      if (flag == kLinkAddress) {
        const Range v = r.valid_range();
        if (r.encoding != Encoding::u16 || r.scale != 1 || v.min < 1 || v.max > 255)
          return bad(r, "a link-address row is a u16 with a range inside 1..255");
      } else if (r.encoding == Encoding::choice) {
        for (const Named& n : r.names) {
          if (baud_of(r, n.value) == 0)
            return bad(r,
                       fmt::format("link-baud value {} is named '{}', not a rate (9600)", n.value, n.name));
        }
      } else if (r.encoding != Encoding::u16 && r.encoding != Encoding::u32) {
        return bad(r, "a link-baud row is a choice named by rates, or the rate as u16 or u32");
      }
    }
    auto& space = used[static_cast<size_t>(r.space)];
    for (unsigned i = 0; i < r.repeat; ++i) {
      for (unsigned w = 0; w < r.words(); ++w) {
        const size_t a = size_t{r.address} + size_t{i} * r.step() + w;
        if (space.test(a)) return bad(r, fmt::format("address 0x{:04X} is covered by another register", a));
        space.set(a);
      }
    }
  }
  return {};
}

// Reads a map file's parts into a MapProfile, one field reader each (a
// failure throws Bad with "SOURCE:LINE: what is wrong").
class MapFileReader {
 public:
  MapFileReader(const Reader& reader, MapProfile& map) : reader_(reader), map_(map) {}

  // device: name, title, vendor, product code, revision, unit, baud, parity, stop bits, quirks.
  void device(const YAML::Node& device) {
    Profile& p = map_.profile_;
    if (!device["name"]) reader_.fail(device, "device.name is missing");
    p.name = map_.keep(reader_.text(device["name"], "device.name"));
    if (device["title"]) p.title = map_.keep(reader_.text(device["title"], "device.title"));
    if (device["vendor"]) p.vendor = map_.keep(reader_.text(device["vendor"], "device.vendor"));
    if (device["product_code"])
      p.product_code = map_.keep(reader_.text(device["product_code"], "device.product_code"));
    if (device["revision"]) p.revision = map_.keep(reader_.text(device["revision"], "device.revision"));
    if (device["unit"]) {
      const int64_t u = reader_.integer(device["unit"], "device.unit");
      if (u < 1 || u > 255) reader_.fail(device["unit"], "device.unit must be 1..255");
      p.link.unit = static_cast<uint8_t>(u);
    }
    if (device["unit_max"]) {
      const int64_t u = reader_.integer(device["unit_max"], "device.unit_max");
      if (u < 1 || u > 255) reader_.fail(device["unit_max"], "device.unit_max must be 1..255");
      p.link.unit_max = static_cast<uint8_t>(u);
    }
    if (device["baud"]) {
      const int64_t b = reader_.integer(device["baud"], "device.baud");
      if (b < 300 || b > 4000000) reader_.fail(device["baud"], "device.baud must be 300..4000000");
      p.link.baud = static_cast<uint32_t>(b);
    }
    if (device["parity"]) {
      const std::string parity = fold_name(reader_.text(device["parity"], "device.parity"));
      if (parity == "n" || parity == "none")
        p.link.parity = 'N';
      else if (parity == "e" || parity == "even")
        p.link.parity = 'E';
      else if (parity == "o" || parity == "odd")
        p.link.parity = 'O';
      else
        reader_.fail(device["parity"], "device.parity is N, E or O (none, even, odd)");
    }
    if (device["stop_bits"]) {
      const int64_t s = reader_.integer(device["stop_bits"], "device.stop_bits");
      if (s != 1 && s != 2) reader_.fail(device["stop_bits"], "device.stop_bits is 1 or 2");
      p.link.stop_bits = static_cast<uint8_t>(s);
    }
    if (const YAML::Node q = device["quirks"]) {
      if (!q.IsSequence()) reader_.fail(q, "device.quirks is a list");
      for (const YAML::Node& item : q) {
        const std::string name = fold_name(reader_.text(item, "quirk"));
        if (name == "fc10_without_byte_count")
          p.quirks.fc10_without_byte_count = true;
        else if (name == "fc03_two_byte_count")
          p.quirks.fc03_two_byte_count = true;
        else
          reader_.fail(item, "unknown quirk (fc10_without_byte_count, fc03_two_byte_count)");
      }
    }
  }

  // flags: the file's own, in order (bits 1..29), after the kit's.
  void flags(const YAML::Node& doc) {
    // The kit's flags (persisted, link-address, link-baud) need no
    // declaring; the file names its own in order: bits 1..29.
    for (const FlagName& kit : kKitFlags) map_.flag_names_.push_back(kit);
    if (const YAML::Node flags = doc["flags"]) {
      if (!flags.IsSequence()) reader_.fail(flags, "flags is a list of names");
      unsigned bit = 1;
      for (const YAML::Node& f : flags) {
        const std::string name = reader_.text(f, "flag");
        if (std::any_of(std::begin(kKitFlags), std::end(kKitFlags),
                        [&](const FlagName& kit) { return kit.name == name; }))
          continue;
        if (bit > 29) reader_.fail(f, "at most 29 device flags");
        map_.flag_names_.push_back({Flags{1} << bit++, map_.keep(name)});
      }
    }
  }

  // One entry of registers, checked against the rows before it.
  void row(const YAML::Node& n) {
    if (!n.IsMap()) reader_.fail(n, "a register is a mapping (key, space, address...)");
    check_fields(
        reader_, n,
        {"key", "title", "space", "address", "role", "encoding", "unit", "scale", "order", "access", "range",
         "writable_range", "default", "default_first", "flags", "values", "notes", "repeat", "stride"},
        "a register");
    Row r;
    if (!n["key"]) reader_.fail(n, "a register needs a key");
    r.key = map_.keep(reader_.text(n["key"], "key"));
    if (!n["address"]) reader_.fail(n, fmt::format("register '{}' needs an address", r.key));
    const int64_t address = reader_.integer(n["address"], "address");
    if (address < 0 || address > 0xFFFF) reader_.fail(n["address"], "address must be 0..0xFFFF");
    r.address = static_cast<uint16_t>(address);
    r.title = n["title"] ? map_.keep(reader_.text(n["title"], "title")) : r.key;
    if (n["space"]) r.space = reader_.choice(n["space"], "space", kSpaces, space_name);
    r.role = r.space == Space::input || r.space == Space::discrete ? Role::status : Role::setting;
    if (n["role"]) r.role = reader_.choice(n["role"], "role", kRoles, role_name);
    r.encoding = r.space == Space::coil || r.space == Space::discrete ? Encoding::boolean : Encoding::u16;
    if (n["encoding"]) r.encoding = reader_.choice(n["encoding"], "encoding", kEncodings, encoding_name);
    if (n["unit"]) r.unit = map_.keep(reader_.text(n["unit"], "unit"));
    if (n["scale"]) {
      const int64_t s = reader_.integer(n["scale"], "scale");
      if (s < 1 || s > 10000) reader_.fail(n["scale"], "scale must be 1..10000");
      r.scale = static_cast<uint16_t>(s);
    }
    if (n["order"]) {
      const std::string o = fold_name(reader_.text(n["order"], "order"));
      if (o == "high_first")
        r.order = WordOrder::high_first;
      else if (o == "low_first")
        r.order = WordOrder::low_first;
      else
        reader_.fail(n["order"], "order is high_first or low_first");
    }
    if (n["access"]) r.access = reader_.choice(n["access"], "access", kAccesses, access_name);
    if (n["range"]) r.range = reader_.range(n["range"], "range");
    if (n["writable_range"]) r.writable_range = reader_.range(n["writable_range"], "writable_range");
    if (n["default"]) r.default_value = reader_.integer(n["default"], "default");
    if (n["default_first"]) r.default_first = reader_.integer(n["default_first"], "default_first");
    if (n["repeat"]) {
      const int64_t v = reader_.integer(n["repeat"], "repeat");
      if (v < 1 || v > 0xFFFF) reader_.fail(n["repeat"], "repeat must be 1..65535");
      r.repeat = static_cast<uint16_t>(v);
    }
    if (n["stride"]) {
      const int64_t v = reader_.integer(n["stride"], "stride");
      if (v < 1 || v > 0xFFFF) reader_.fail(n["stride"], "stride must be 1..65535");
      r.stride = static_cast<uint16_t>(v);
    }
    if (n["notes"]) r.notes = map_.keep(reader_.text(n["notes"], "notes"));
    if (const YAML::Node flags = n["flags"]) {
      if (!flags.IsSequence()) reader_.fail(flags, "flags is a list of names");
      for (const YAML::Node& f : flags) {
        const std::string name = reader_.text(f, "flag");
        const auto it = std::find_if(map_.flag_names_.begin(), map_.flag_names_.end(),
                                     [&](const FlagName& fn) { return fn.name == name; });
        if (it == map_.flag_names_.end())
          reader_.fail(f, fmt::format("unknown flag '{}' (declare it under 'flags' at the top)", name));
        r.flags |= it->flag;
      }
    }
    if (const YAML::Node values = n["values"]) {
      if (!values.IsMap()) reader_.fail(values, "values is a mapping of number: name");
      std::vector<Named> named;
      for (const auto& kv : values) {
        const int64_t v = reader_.integer(kv.first, "value");
        if (v < 0 || v > 0xFFFF) reader_.fail(kv.first, "a value must be 0..65535");
        named.push_back({static_cast<uint16_t>(v), map_.keep(reader_.text(kv.second, "value name"))});
      }
      map_.names_.push_back(std::move(named));
      r.names = map_.names_.back();
    }
    map_.rows_.push_back(r);
    // The node of each row, for the line of a table-level error below.
    if (const Status s = check_profile(Profile{.rows = std::span<const Row>(map_.rows_)}); !s.ok())
      reader_.fail(n, std::string(s.reason()));
  }

  // After the rows: a device field beside a link row must agree with it.
  void link_rows_agree(const YAML::Node& device) {
    const Profile& p = map_.profile_;
    // A link row decides the unit or the rate; a device field beside it
    // must agree (an exported built-in has both), or the file says two things.
    const Profile rows_only{.rows = std::span<const Row>(map_.rows_)};
    if (const Row* r = row_with(rows_only, kLinkAddress);
        r && device["unit"] && p.link.unit != r->default_value)
      reader_.fail(device["unit"],
                   fmt::format("device.unit {} disagrees with the default {} of the link-address "
                               "row '{}': the row decides, drop device.unit",
                               p.link.unit, r->default_value, r->key));
    if (const Row* r = row_with(rows_only, kLinkBaud);
        r && device["baud"] && p.link.baud != baud_of(*r, r->default_value))
      reader_.fail(device["baud"],
                   fmt::format("device.baud {} disagrees with the default {} of the link-baud row "
                               "'{}': the row decides, drop device.baud",
                               p.link.baud, baud_of(*r, r->default_value), r->key));
  }

 private:
  const Reader& reader_;
  MapProfile& map_;
};

Outcome<std::unique_ptr<MapProfile>> parse_map(std::string_view text, std::string_view source) {
  Reader reader(source);
  auto map = std::make_unique<MapProfile>();
  // YAML and JSON are Unicode text, and every string of a map ends up in JSON
  // (`registers --json`, `--json` values), where nlohmann::json::dump() throws
  // on invalid UTF-8. yaml-cpp does not check; found by fuzz_map_file.
  if (const size_t valid = valid_utf8_prefix(text); valid != text.size()) {
    const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(valid), '\n');
    return Status(Errc::invalid_argument, fmt::format("{}:{}: not UTF-8 text (byte 0x{:02X})", source, line,
                                                      static_cast<uint8_t>(text[valid])));
  }
  if (const auto bad = std::find_if(text.begin(), text.end(), is_control); bad != text.end()) {
    const auto line = 1 + std::count(text.begin(), bad, '\n');
    return Status(Errc::invalid_argument,
                  fmt::format("{}:{}: control character 0x{:02X}", source, line, static_cast<uint8_t>(*bad)));
  }
  try {
    YAML::Node doc;
    try {
      doc = YAML::Load(std::string(text));
    } catch (const YAML::ParserException& e) {
      return Status(Errc::invalid_argument,
                    fmt::format("{}:{}: not valid YAML or JSON: {}", source, e.mark.line + 1, e.msg));
    }
    if (!doc.IsMap()) reader.fail(doc, "a register map is a mapping with 'device' and 'registers'");
    check_fields(reader, doc, {"format", "device", "flags", "registers"}, "the map");
    if (doc["format"] && reader.text(doc["format"], "format") != "rtukit-map")
      reader.fail(doc["format"], "format must be 'rtukit-map'");
    const YAML::Node device = doc["device"];
    if (!device || !device.IsMap()) reader.fail(doc, "'device' (name, title...) is missing");
    check_fields(reader, device,
                 {"name", "title", "vendor", "product_code", "revision", "unit", "unit_max", "baud", "parity",
                  "stop_bits", "quirks"},
                 "device");
    MapFileReader parts(reader, *map);
    parts.device(device);
    parts.flags(doc);
    const YAML::Node regs = doc["registers"];
    if (!regs || !regs.IsSequence() || regs.size() == 0)
      reader.fail(doc, "'registers' must be a list of at least one register");
    for (const YAML::Node& n : regs) parts.row(n);
    parts.link_rows_agree(device);
  } catch (const Bad& bad) {
    return Status(Errc::invalid_argument, bad.message);
  } catch (const YAML::Exception& e) {
    return Status(Errc::invalid_argument, fmt::format("{}:{}: {}", source, e.mark.line + 1, e.msg));
  }
  map->profile_.rows = map->rows_;
  map->profile_.flag_names = map->flag_names_;
  return map;
}

Outcome<std::unique_ptr<MapProfile>> load_map(const std::string& path) {
  Outcome<std::string> text = io::read_regular_file(path, kMaxMapFile);
  if (!text.ok()) {
    const Status& e = text.error();
    return Status(
        e.code() == Errc::io_error ? e.error() : Error(Errc::invalid_argument),
        fmt::format("{}: {}", path, e.code() == Errc::io_error ? std::strerror(e.os_error()) : e.reason()));
  }
  return parse_map(*text, path);
}

namespace {

// The document shape shared by YAML and JSON export: only what differs from
// a Row's defaults, in the order a person reads a row.
nlohmann::ordered_json row_document(const Profile& p, const Row& r) {
  nlohmann::ordered_json j;
  j["key"] = r.key;
  j["title"] = r.title;
  j["space"] = space_name(r.space);
  j["address"] = fmt::format("0x{:04X}", r.address);
  j["role"] = role_name(r.role);
  j["encoding"] = encoding_name(r.encoding);
  if (!r.unit.empty()) j["unit"] = r.unit;
  if (r.scale != 1) j["scale"] = r.scale;
  if (r.order != WordOrder::high_first) j["order"] = order_name(r.order);
  if (r.access != Access::by_role) j["access"] = access_name(r.access);
  if (!r.range.empty()) j["range"] = {r.range.min, r.range.max};
  if (!r.writable_range.empty()) j["writable_range"] = {r.writable_range.min, r.writable_range.max};
  if (r.default_value != 0) j["default"] = r.default_value;
  if (r.default_first != -1) j["default_first"] = r.default_first;
  if (r.repeat != 1) j["repeat"] = r.repeat;
  if (r.stride != 0) j["stride"] = r.stride;
  if (r.flags) {
    nlohmann::ordered_json flags = nlohmann::ordered_json::array();
    for (const std::string_view name : flag_names(p, r)) flags.push_back(name);
    j["flags"] = flags;
  }
  if (!r.names.empty()) {
    nlohmann::ordered_json values = nlohmann::ordered_json::object();
    for (const Named& n : r.names) values[std::to_string(n.value)] = n.name;
    j["values"] = values;
  }
  if (!r.notes.empty()) j["notes"] = r.notes;
  return j;
}

nlohmann::ordered_json map_document(const Profile& p) {
  nlohmann::ordered_json doc;
  doc["format"] = "rtukit-map";
  nlohmann::ordered_json device;
  device["name"] = p.name;
  if (!p.title.empty()) device["title"] = p.title;
  if (!p.vendor.empty()) device["vendor"] = p.vendor;
  if (!p.product_code.empty()) device["product_code"] = p.product_code;
  if (!p.revision.empty()) device["revision"] = p.revision;
  const LinkDefaults link = link_defaults(p);
  device["unit"] = link.unit;
  if (link.unit_max != 247) device["unit_max"] = link.unit_max;
  device["baud"] = link.baud;
  device["parity"] = std::string(1, link.parity);
  device["stop_bits"] = link.stop_bits;
  nlohmann::ordered_json quirks = nlohmann::ordered_json::array();
  if (p.quirks.fc10_without_byte_count) quirks.push_back("fc10_without_byte_count");
  if (p.quirks.fc03_two_byte_count) quirks.push_back("fc03_two_byte_count");
  if (!quirks.empty()) device["quirks"] = quirks;
  doc["device"] = device;
  // Device flags in bit order (bit 0, persisted, is implicit).
  nlohmann::ordered_json flags = nlohmann::ordered_json::array();
  for (unsigned bit = 1; bit < 30; ++bit) {
    for (const FlagName& f : p.flag_names) {
      if (f.flag == (Flags{1} << bit)) flags.push_back(f.name);
    }
  }
  if (!flags.empty()) doc["flags"] = flags;
  nlohmann::ordered_json regs = nlohmann::ordered_json::array();
  for (const Row& r : p.rows) regs.push_back(row_document(p, r));
  doc["registers"] = regs;
  return doc;
}

void emit(YAML::Emitter& out, const nlohmann::ordered_json& j) {
  if (j.is_object()) {
    out << YAML::BeginMap;
    for (const auto& [k, v] : j.items()) {
      out << YAML::Key << k << YAML::Value;
      emit(out, v);
    }
    out << YAML::EndMap;
  } else if (j.is_array()) {
    const bool flow = std::all_of(j.begin(), j.end(), [](const auto& e) { return e.is_primitive(); });
    if (flow) out << YAML::Flow;
    out << YAML::BeginSeq;
    for (const auto& v : j) emit(out, v);
    out << YAML::EndSeq;
  } else if (j.is_string()) {
    const std::string s = j.get<std::string>();
    // Hex addresses stay unquoted (we read them as hex text). Text another
    // YAML reader would take for a number, a boolean or null is quoted.
    static const char* const kTyped[] = {"y", "n", "yes", "no", "true", "false", "on", "off", "null", "~"};
    const std::string folded = fold_name(s);
    bool typed = s.empty() || std::isdigit(static_cast<unsigned char>(s[0])) || s[0] == '-' || s[0] == '+' ||
                 s[0] == '.';
    for (const char* t : kTyped) typed = typed || folded == t;
    if (s.starts_with("0x") || !typed)
      out << s;
    else
      out << YAML::DoubleQuoted << s;
  } else if (j.is_number_integer()) {
    out << j.get<int64_t>();
  } else if (j.is_number_unsigned()) {
    out << j.get<uint64_t>();
  } else if (j.is_boolean()) {
    out << j.get<bool>();
  } else {
    out << j.dump();
  }
}

}  // namespace

namespace {
// The storage comes first (a base constructed before Model), so the Model
// can reset the image to its defaults in its constructor.
struct Words {
  std::vector<uint16_t> words;
};
class RegisterDevice final : private Words, public Model {
 public:
  explicit RegisterDevice(const Profile& p)
      : Words{std::vector<uint16_t>(RegisterMap(p.rows).image_size())}, Model(p, Words::words) {}
};
}  // namespace

std::unique_ptr<Model> make_register_device(const Profile& profile) {
  return std::make_unique<RegisterDevice>(profile);
}

std::string map_to_yaml(const Profile& profile) {
  YAML::Emitter out;
  out << YAML::Comment(
      fmt::format("rtukit register map: {} (exported by rtukit; see docs/register-maps.md)", profile.name));
  out << YAML::Newline;
  emit(out, map_document(profile));
  return std::string(out.c_str()) + "\n";
}

std::string map_to_json(const Profile& profile) {
  return map_document(profile).dump(2) + "\n";
}

}  // namespace rtukit::profile
