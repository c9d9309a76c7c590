// rtukit device profiles, host side: registers with no row behind them, as
// the generic `read`/`write --type` and any program that polls a device it
// has no profile for read and write them. Modbus carries 16-bit words; the
// conventions for more are a type and, for 32 bits, a word order:
//
//   u16, i16   one register, unsigned or two's complement
//   u32, i32   two registers, unsigned or two's complement
//   f32        two registers holding an IEEE 754 single (float)
//
// plus the one number syntax every front-end takes: decimal, or hex as 0x21.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/schema.hpp"

namespace rtukit::profile {

/// "33", "-5" or "0x21" within min..max. Errors: invalid_argument, the
/// reason naming `what`: "address 'x' is not a number (decimal, or hex as
/// 0x21)", "count 300 is out of range 1..125".
Outcome<int64_t> parse_number(std::string_view text, std::string_view what, int64_t min, int64_t max);

/// A device's unit address as typed: empty is its factory address, else one
/// of the addresses its link-address row (or Profile::link) allows. Errors:
/// invalid_argument, "inverjet unit 300 is out of range 1..254".
Outcome<uint8_t> device_unit(const Profile& p, std::string_view text);

/// "inverjet@21", "meter.yaml@5" -> {"inverjet", "21"}: a device (or a map
/// file) and the unit it answers at, as a sniffer names them. Errors:
/// invalid_argument, "'inverjet': write NAME@UNIT (inverjet@21)".
Outcome<std::pair<std::string, std::string>> split_at_unit(std::string_view text);

enum class ValueType : uint8_t { u16, i16, u32, i32, f32 };

/// "u16", "i16", "u32", "i32", "f32" -> the type; nullopt for any other name.
std::optional<ValueType> value_type(std::string_view name) noexcept;
/// Registers one value takes: 1 for u16 and i16, 2 otherwise.
constexpr unsigned words_of(ValueType t) noexcept {
  return t == ValueType::u16 || t == ValueType::i16 ? 1 : 2;
}

/// The value in `words` (words_of(type) of them) as a JSON number: an
/// unsigned or signed integer, or a float (f32). `order` is the word order
/// of the 32-bit types.
nlohmann::json decode_typed(ValueType type, std::span<const uint16_t> words, WordOrder order);

/// A value as typed -> its registers, appended to `out`. Integers in decimal
/// must fit the type's range (hex gives the raw bits: 0xFFFF is an i16's -1);
/// an f32 must be finite, within f32's range and not so small it would be
/// written as 0. Errors: invalid_argument, the reason says why ("i16 value
/// 40000 is out of range -32768..32767 (or 0x0000..0xFFFF in hex, the raw
/// bits)", "f32 value nan is not a finite number"); `out` is unchanged.
Status encode_typed(ValueType type, std::string_view text, WordOrder order, std::vector<uint16_t>& out);

}  // namespace rtukit::profile
