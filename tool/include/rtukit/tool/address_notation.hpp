// rtukit device profiles, host side: a register address as people type and
// read it. Three ways are in use (Modbus Application Protocol 4.4 and the
// "Modicon" convention of vendors' manuals, mbpoll, Modbus Poll):
//
//   0-based     "33", "0x21": the address on the wire (the PDU's)
//   1-based     "34": the wire address + 1 (mbpoll -r, Modbus Poll)
//   reference   "40034": the space's digit, then the 1-based address in four
//               digits (40001 = holding register 1, wire address 0; 30001
//               input register, 10001 discrete input, 00001 coil); six
//               digits past 9999 or when typed so ("400034")
//
// An address is shown back the way it was typed, with the wire address in
// hex beside it: "40034 (0x0021)".
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/schema.hpp"

namespace rtukit::tool {

// The profile kit's value types, which the generic commands share with the devices.
using profile::Space;

/// "holding register", "input register", "coil", "discrete input"; with an
/// "s" when `plural`.
std::string space_noun(Space space, bool plural);

/// How an address was typed: how to show addresses back.
struct AddressNotation {
  enum class Kind : uint8_t { zero_based, one_based, reference } kind = Kind::zero_based;
  char prefix = '4';        ///< reference: 0 coils, 1 discrete inputs, 3 input, 4 holding registers
  bool six_digits = false;  ///< reference: typed as 400001 rather than 40001

  /// The wire address `pdu` as the user writes it: "33", "34", "40034".
  std::string text(size_t pdu) const;
  /// "40003 (0x0002)".
  std::string where(size_t pdu) const;
  /// "40003..40004 (0x0002..0x0003)", or where(first) for one.
  std::string span(size_t first, size_t count) const;
};

struct TypedAddress {
  uint16_t address = 0;        ///< on the wire (0-based)
  std::optional<Space> space;  ///< named by a reference's digit
  AddressNotation notation;
  /// A reference is never taken silently (its digits may also be a plain
  /// address): "40034 is taken as a reference: holding register 34
  /// (0-based 33; for address 40034 write 0x9C62)". Empty otherwise.
  std::string note;
};

/// An address as typed: a reference (5 or 6 digits starting 0, 1, 3 or 4),
/// else 1-based when `one_based`, else 0-based. Errors: invalid_argument,
/// the reason says why ("40000 is not a reference: holding registers are
/// 40001..49999 (six digits: 400001..465536); for address 40000 write
/// 0x9C40", "address 70000 is out of range 0..65535").
Outcome<TypedAddress> parse_address(std::string_view text, bool one_based);

}  // namespace rtukit::tool
