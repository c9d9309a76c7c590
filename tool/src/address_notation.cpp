#include "rtukit/tool/address_notation.hpp"

#include <fmt/format.h>

#include <string>

#include "rtukit/devices/profile/typed_value.hpp"

namespace rtukit::tool {

using profile::parse_number;

std::string space_noun(Space space, bool plural) {
  const char* noun = space == Space::holding ? "holding register"
                     : space == Space::input ? "input register"
                     : space == Space::coil  ? "coil"
                                             : "discrete input";
  return plural ? std::string(noun) + "s" : noun;
}

std::string AddressNotation::text(size_t pdu) const {
  if (kind == Kind::zero_based) return std::to_string(pdu);
  if (kind == Kind::one_based) return std::to_string(pdu + 1);
  // Five digits reach 9999; past it, six.
  if (!six_digits && pdu + 1 <= 9999) return fmt::format("{}{:04}", prefix, pdu + 1);
  return fmt::format("{}{:05}", prefix, pdu + 1);
}

std::string AddressNotation::where(size_t pdu) const {
  return fmt::format("{} (0x{:04X})", text(pdu), pdu);
}

std::string AddressNotation::span(size_t first, size_t count) const {
  if (count <= 1) return where(first);
  const size_t last = first + count - 1;
  return fmt::format("{}..{} (0x{:04X}..0x{:04X})", text(first), text(last), first, last);
}

Outcome<TypedAddress> parse_address(std::string_view typed, bool one_based) {
  const std::string text(typed);
  const bool reference = (text.size() == 5 || text.size() == 6) &&
                         text.find_first_not_of("0123456789") == std::string::npos &&
                         (text[0] == '0' || text[0] == '1' || text[0] == '3' || text[0] == '4');
  if (reference) {
    const char prefix = text[0];
    const bool six = text.size() == 6;
    const long n = std::stol(text.substr(1));
    const Space space = prefix == '4'   ? Space::holding
                        : prefix == '3' ? Space::input
                        : prefix == '1' ? Space::discrete
                                        : Space::coil;
    // The same digits as a plain address, when they are one: what to type to mean it.
    const long plain = std::stol(text);
    const bool is_plain = one_based ? plain >= 1 && plain <= 0x10000 : plain <= 0xFFFF;
    const std::string as_plain = is_plain ? fmt::format("for address {} write 0x{:04X}", plain, plain) : "";
    if (n < 1 || n > (six ? 65536 : 9999)) {
      const std::string five_range = fmt::format("{0}0001..{0}9999", prefix);
      const std::string six_range = fmt::format("{0}00001..{0}65536", prefix);
      return Status(Errc::invalid_argument,
                    fmt::format("{} is not a reference: {} are {} ({} digits: {}){}", text,
                                space_noun(space, true), six ? six_range : five_range, six ? "five" : "six",
                                six ? five_range : six_range, as_plain.empty() ? "" : "; " + as_plain));
    }
    return TypedAddress{
        .address = static_cast<uint16_t>(n - 1),
        .space = space,
        .notation = AddressNotation{AddressNotation::Kind::reference, prefix, six},
        .note = fmt::format("{} is taken as a reference: {} {} (0-based {}{})", text,
                            space_noun(space, false), n, n - 1, as_plain.empty() ? "" : "; " + as_plain)};
  }
  if (one_based) {
    const Outcome<int64_t> n = parse_number(text, "address (1-based)", 1, 0x10000);
    if (!n.ok()) return n.error();
    return TypedAddress{.address = static_cast<uint16_t>(*n - 1),
                        .notation = AddressNotation{AddressNotation::Kind::one_based}};
  }
  const Outcome<int64_t> n = parse_number(text, "address", 0, 0xFFFF);
  if (!n.ok()) return n.error();
  return TypedAddress{.address = static_cast<uint16_t>(*n)};
}

}  // namespace rtukit::tool
