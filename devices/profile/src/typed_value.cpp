#include "rtukit/devices/profile/typed_value.hpp"

#include <fmt/format.h>

#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

namespace rtukit::profile {

Outcome<int64_t> parse_number(std::string_view text, std::string_view what, int64_t min, int64_t max) {
  std::string_view digits = text;
  bool negative = false;
  if (digits.starts_with('-')) {
    negative = true;
    digits.remove_prefix(1);
  }
  int base = 10;
  if (digits.starts_with("0x") || digits.starts_with("0X")) {
    base = 16;
    digits.remove_prefix(2);
  }
  uint64_t value = 0;
  const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value, base);
  if (digits.empty() || ec != std::errc() || ptr != digits.data() + digits.size() ||
      value > (uint64_t{1} << 62)) {
    return Status(Errc::invalid_argument,
                  fmt::format("{} '{}' is not a number (decimal, or hex as 0x21)", what, text));
  }
  const int64_t v = negative ? -static_cast<int64_t>(value) : static_cast<int64_t>(value);
  if (v < min || v > max)
    return Status(Errc::invalid_argument, fmt::format("{} {} is out of range {}..{}", what, text, min, max));
  return v;
}

Outcome<uint8_t> device_unit(const Profile& p, std::string_view text) {
  const UnitRange units = unit_range(p);
  if (text.empty()) return units.fallback;
  const Outcome<int64_t> n = parse_number(text, fmt::format("{} unit", p.name), units.min, units.max);
  if (!n) return n.error();
  return static_cast<uint8_t>(*n);
}

Outcome<std::pair<std::string, std::string>> split_at_unit(std::string_view text) {
  const size_t at = text.rfind('@');
  if (at == std::string_view::npos || at == 0 || at + 1 == text.size())
    return Status(Errc::invalid_argument, fmt::format("'{}': write NAME@UNIT (inverjet@21)", text));
  return std::pair{std::string(text.substr(0, at)), std::string(text.substr(at + 1))};
}

std::optional<ValueType> value_type(std::string_view name) noexcept {
  if (name == "u16") return ValueType::u16;
  if (name == "i16") return ValueType::i16;
  if (name == "u32") return ValueType::u32;
  if (name == "i32") return ValueType::i32;
  if (name == "f32") return ValueType::f32;
  return std::nullopt;
}

nlohmann::json decode_typed(ValueType type, std::span<const uint16_t> words, WordOrder order) {
  if (type == ValueType::u16) return words[0];
  if (type == ValueType::i16) return static_cast<int16_t>(words[0]);
  const bool low_first = order == WordOrder::low_first;
  const uint32_t hi = low_first ? words[1] : words[0];
  const uint32_t lo = low_first ? words[0] : words[1];
  const uint32_t v = (hi << 16) | lo;
  if (type == ValueType::u32) return v;
  if (type == ValueType::i32) return static_cast<int32_t>(v);
  return std::bit_cast<float>(v);
}

Status encode_typed(ValueType type, std::string_view text_view, WordOrder order, std::vector<uint16_t>& out) {
  const std::string text(text_view);
  const auto invalid = [](std::string reason) { return Status(Errc::invalid_argument, std::move(reason)); };
  uint32_t bits = 0;
  if (type == ValueType::f32) {
    char* end = nullptr;
    errno = 0;
    const double d = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0') return invalid(fmt::format("value '{}' is not a number", text));
    if (std::isnan(d) || (std::isinf(d) && errno != ERANGE))
      return invalid(fmt::format("f32 value {} is not a finite number", text));
    if (std::fabs(d) > std::numeric_limits<float>::max())
      return invalid(fmt::format("f32 value {} is out of range (at most {} either side of 0)", text,
                                 std::numeric_limits<float>::max()));
    if (d != 0 && static_cast<float>(d) == 0)
      return invalid(fmt::format("f32 value {} is too small for f32: it would be written as 0", text));
    bits = std::bit_cast<uint32_t>(static_cast<float>(d));
  } else {
    const bool wide = type == ValueType::u32 || type == ValueType::i32;
    const bool is_unsigned = type == ValueType::u16 || type == ValueType::u32;
    const int64_t all_bits = wide ? 0xFFFFFFFFLL : 0xFFFF;
    const bool hex = text.starts_with("0x") || text.starts_with("0X");
    const std::string what = fmt::format("{}{} value", is_unsigned ? 'u' : 'i', wide ? 32 : 16);
    int64_t v = 0;
    if (is_unsigned || hex) {
      const Outcome<int64_t> n = parse_number(text, what, 0, all_bits);
      if (!n.ok()) return n.error();
      v = *n;
    } else {
      const int64_t lo = wide ? INT32_MIN : INT16_MIN;
      const int64_t hi = wide ? INT32_MAX : INT16_MAX;
      const Outcome<int64_t> n = parse_number(text, what, INT64_MIN / 4, INT64_MAX / 4);
      if (!n.ok()) return n.error();
      if (*n < lo || *n > hi)
        return invalid(fmt::format("{} {} is out of range {}..{} (or 0x{:0{}X}..0x{:X} in hex, the raw bits)",
                                   what, text, lo, hi, 0, wide ? 8 : 4, all_bits));
      v = *n;
    }
    if (!wide) {
      out.push_back(static_cast<uint16_t>(v));
      return {};
    }
    bits = static_cast<uint32_t>(v);
  }
  const auto hi = static_cast<uint16_t>(bits >> 16);
  const auto lo = static_cast<uint16_t>(bits & 0xFFFF);
  const bool low_first = order == WordOrder::low_first;
  out.push_back(low_first ? lo : hi);
  out.push_back(low_first ? hi : lo);
  return {};
}

}  // namespace rtukit::profile
