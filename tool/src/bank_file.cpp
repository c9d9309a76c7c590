#include "rtukit/tool/bank_file.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <type_traits>

#include "rtukit/core/pdu.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/io/atomic_file.hpp"
#include "rtukit/tool/protocol_text.hpp"

namespace rtukit::tool {

using profile::parse_number;

Status load_bank_file(const std::string& path, MemoryBank& bank) {
  Outcome<std::string> text = io::read_regular_file(path, 16 << 20);  // 4 tables of 64 K values, written out
  if (!text.ok())
    return Status(text.error().error(), fmt::format("cannot read {}: {}", path, text.error().reason()));
  return load_bank_text(path, *text, bank);
}

Status load_bank_text(std::string_view source, std::string_view text, MemoryBank& bank) {
  const auto invalid = [](std::string reason) { return Status(Errc::invalid_argument, std::move(reason)); };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    return invalid(fmt::format("{}: not valid JSON: {}", source, e.what()));
  }
  if (!j.is_object()) return invalid(fmt::format("{}: expected an object of tables", source));
  for (const auto& item : j.items()) {
    const std::string table = item.key();
    const nlohmann::json& entries = item.value();
    if (table == "identification") {
      // {"vendor": "...", "product_code": "...", "revision": "...", "0x80": "..."} (FC11, FC2B/0E)
      if (!entries.is_object())
        return invalid(fmt::format("{}: 'identification' must map objects to text", source));
      for (const auto& [key, value] : entries.items()) {
        std::optional<uint8_t> id;
        for (uint8_t o = 0; device_object_key(o); ++o)
          if (key == device_object_key(o)) id = o;
        if (!id) {
          const Outcome<int64_t> n = parse_number(key, "object id", 0, 255);
          if (!n.ok()) return n.error();
          id = static_cast<uint8_t>(*n);
        }
        if (!value.is_string() || value.get<std::string>().empty() || value.get<std::string>().size() > 244)
          return invalid(
              fmt::format("{}: identification '{}' must be text of 1..244 characters", source, key));
        bank.objects[*id] = value.get<std::string>();
      }
      continue;
    }
    if (!entries.is_object())
      return invalid(fmt::format("{}: '{}' must map addresses to values", source, table));
    for (const auto& [key, value] : entries.items()) {
      const Outcome<int64_t> first = parse_number(key, "address", 0, 0xFFFF);
      if (!first.ok()) return first.error();
      const auto start = static_cast<size_t>(*first);
      const nlohmann::json list = value.is_array() ? value : nlohmann::json::array({value});
      for (size_t i = 0; i < list.size(); ++i) {
        if (!list[i].is_number_integer())
          return invalid(fmt::format("{}: {}[{}] is not an integer", source, table, key));
        const auto v = list[i].get<int64_t>();
        const size_t at = start + i;
        const auto put = [&](auto& vec, int64_t lo, int64_t hi) -> Status {
          if (at >= vec.size())
            return invalid(fmt::format("{}: {} address {} past --registers", source, table, at));
          if (v < lo || v > hi) return invalid(fmt::format("{}: {} value {} out of range", source, table, v));
          vec[at] = static_cast<std::remove_reference_t<decltype(vec[0])>>(v);
          return {};
        };
        Status e;
        if (table == "holding")
          e = put(bank.holding, -32768, 0xFFFF);
        else if (table == "input")
          e = put(bank.input, -32768, 0xFFFF);
        else if (table == "coils")
          e = put(bank.coils, 0, 1);
        else if (table == "discrete")
          e = put(bank.discrete, 0, 1);
        else
          return invalid(
              fmt::format("{}: unknown table '{}' (holding, input, coils, discrete)", source, table));
        if (!e.ok()) return e;
      }
    }
  }
  return {};
}

}  // namespace rtukit::tool
