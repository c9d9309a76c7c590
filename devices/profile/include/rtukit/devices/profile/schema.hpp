// rtukit device profiles: the register schema every device is written in.
//
// A device is a table of `Row`s (data) plus a pure model (behaviour). One
// row describes one register, one 32-bit value or one repeated block (the
// Inverjet's 4 x 50 plan segments), with everything a program needs to
// validate, decode, store, print and document it. Rows are constexpr data
// with named fields, written like the device's manual:
//
//   {.space = Space::holding, .address = 0x0023, .key = "speed", .title = "current motor speed",
//    .role = Role::control, .unit = "%", .range = {0, 100}, .flags = kMasked},
//
// This header is part of the pure profile layer: no heap, no OS, no
// exceptions; it builds wherever the core builds.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "rtukit/core/pdu.hpp"

namespace rtukit::profile {

/// The four Modbus data spaces.
enum class Space : uint8_t {
  holding,   ///< FC03 read, FC06/FC10 write
  input,     ///< FC04, read only
  coil,      ///< FC01 read, FC05/FC0F write
  discrete,  ///< FC02, read only
};

/// The space a data function reads or writes: coils for 01, 05 and 0F,
/// discrete inputs for 02, input registers for 04, holding registers for
/// any other (03, 06, 10, 16, 17).
constexpr Space space_of_function(uint8_t function) noexcept {
  switch (function) {
    case 0x01:
    case 0x05:
    case 0x0F:
      return Space::coil;
    case 0x02:
      return Space::discrete;
    case 0x04:
      return Space::input;
    default:
      return Space::holding;
  }
}

/// What a register is for. Drives defaults (access) and how programs treat it.
enum class Role : uint8_t {
  status,    ///< the device reports it; read only
  setting,   ///< configuration, kept until written again (often persisted)
  control,   ///< commands the device's state machine (start, stop, speed)
  hold,      ///< active while non-zero; a host writes 0 to release (motion)
  pulse,     ///< acts on the rising edge 0 -> non-zero; a host writes 1 then 0
  reserved,  ///< documented, stored, no effect
};

/// Which way a request may touch a row.
enum class Access : uint8_t {
  by_role,     ///< input, discrete and Role::status: read only; otherwise read-write
  read_only,   ///< writes get exception 02
  write_only,  ///< reads get exception 02 (the Rehand 6600's table 2, D-3)
  read_write,
};

/// How the raw words read as a value.
enum class Encoding : uint8_t {
  u16,       ///< unsigned, 1 word (divided by `scale` when scale > 1: fixed point)
  i16,       ///< two's complement, 1 word (scaled likewise)
  u32,       ///< unsigned, 2 words in `order` (scaled likewise)
  i32,       ///< two's complement, 2 words in `order` (scaled likewise)
  choice,    ///< one of `names` (value -> name); values not listed are refused on write
  bits,      ///< bit set; `names` names the bits (value = bit number)
  duration,  ///< seconds, shown and typed as mm:ss
  version,   ///< 2 words: major, minor ("V1.2")
  boolean,   ///< a coil or discrete input: 0 or 1
};

enum class WordOrder : uint8_t {
  high_first,  ///< the Modbus convention (and D-9 of the Inverjet)
  low_first,
};

/// An inclusive range of raw values (before scaling). Empty when min > max.
struct Range {
  int64_t min = 0;
  int64_t max = -1;
  constexpr bool empty() const noexcept { return min > max; }
  constexpr bool contains(int64_t v) const noexcept { return v >= min && v <= max; }
  friend constexpr bool operator==(const Range&, const Range&) = default;
};

/// One named value (Encoding::choice) or bit (Encoding::bits, value = bit number).
struct Named {
  uint16_t value = 0;
  std::string_view name;
};

/// Device flags are a bitmask; bits 0, 30 and 31 are the kit's own (named
/// by `kKitFlags`), the others are named by each device (`Profile::flag_names`).
using Flags = uint32_t;
inline constexpr Flags kPersisted = 1U << 0;  ///< kept across power cycles (the state file)
/// The row holds the device's own unit address (a link row): a write takes
/// effect after the response to it, the row's range is the range of
/// addresses the device answers at, its default the factory address.
inline constexpr Flags kLinkAddress = 1U << 30;
/// The row holds the device's baud rate (a link row): a choice whose value
/// names are rates ("9600"), or the rate itself. A write takes effect after
/// the response to it; the default is the factory rate.
inline constexpr Flags kLinkBaud = 1U << 31;
/// The flags a device may use without naming them: bits 1..29.
inline constexpr Flags kDeviceFlagBits = ~(kPersisted | kLinkAddress | kLinkBaud);

struct FlagName {
  Flags flag = 0;
  std::string_view name;  ///< "persisted", "masked-by-control", "motion"
};

/// One row of a register table.
struct Row {
  Space space = Space::holding;
  uint16_t address = 0;  ///< first (lowest) address
  std::string_view key;  ///< stable identifier: JSON keys, CLI names, state files (snake_case)
  std::string_view title;
  Role role = Role::setting;
  Encoding encoding = Encoding::u16;
  std::string_view unit;  ///< "%", "s", "degC", "km/h" or empty
  uint16_t scale = 1;     ///< fixed point: value = raw / scale (10, 100, 1000)
  WordOrder order = WordOrder::high_first;
  Access access = Access::by_role;
  Range range;           ///< documented raw range; empty: the encoding's full range
  Range writable_range;  ///< what a write may carry; empty: `range`
  int64_t default_value = 0;
  int64_t default_first = -1;  ///< default of a repeated block's first entry; -1: `default_value`
  Flags flags = 0;
  std::span<const Named> names;  ///< choice values or bit names
  std::string_view notes;
  uint16_t repeat = 1;  ///< entries in a repeated block
  uint16_t stride = 0;  ///< registers from one entry to the next (>= words); 0: words()

  /// 2 for u32, i32 and version; else 1.
  constexpr uint16_t words() const noexcept {
    return encoding == Encoding::u32 || encoding == Encoding::i32 || encoding == Encoding::version ? 2 : 1;
  }
  /// Registers from one entry of a repeated block to the next.
  constexpr uint16_t step() const noexcept { return stride ? stride : words(); }
  constexpr bool is_signed() const noexcept { return encoding == Encoding::i16 || encoding == Encoding::i32; }
  constexpr bool readable() const noexcept { return access != Access::write_only; }
  constexpr bool writable() const noexcept {
    if (space == Space::input || space == Space::discrete) return false;
    if (access == Access::by_role) return role != Role::status;
    return access != Access::read_only;
  }
  constexpr bool has(Flags f) const noexcept { return (flags & f) == f; }
  /// The last address any entry of this row covers.
  constexpr uint16_t last_address() const noexcept {
    return static_cast<uint16_t>(address + (repeat - 1) * step() + words() - 1);
  }
  /// Address of entry `index` (0-based).
  constexpr uint16_t entry_address(unsigned index) const noexcept {
    return static_cast<uint16_t>(address + index * step());
  }
  /// The full raw range of the encoding.
  constexpr Range natural_range() const noexcept {
    switch (encoding) {
      case Encoding::i16:
        return {-32768, 32767};
      case Encoding::u32:
      case Encoding::version:
        return {0, 0xFFFFFFFFLL};
      case Encoding::i32:
        return {-2147483648LL, 2147483647LL};
      case Encoding::boolean:
        return {0, 1};
      default:
        return {0, 0xFFFF};
    }
  }
  /// `range`, or the encoding's full range when none is given.
  constexpr Range valid_range() const noexcept { return range.empty() ? natural_range() : range; }
  /// What a write may carry: `writable_range`, else `valid_range()`.
  constexpr Range write_range() const noexcept {
    return writable_range.empty() ? valid_range() : writable_range;
  }
  /// Default of entry `index`.
  constexpr int64_t default_of(unsigned index) const noexcept {
    return index == 0 && default_first >= 0 ? default_first : default_value;
  }
};

/// Link defaults of a device. For a device with link rows (kLinkAddress,
/// kLinkBaud) those rows decide the address, its range and the baud rate,
/// and these fields are not used for them: read them through
/// `link_defaults()` and `unit_range()`, never directly.
struct LinkDefaults {
  uint8_t unit = 1;
  uint8_t unit_max = 247;  ///< highest address the device accepts (Modbus serial line: 247)
  uint32_t baud = 9600;
  char parity = 'N';  ///< 'N', 'E', 'O'
  uint8_t stop_bits = 1;
};

/// A device profile: the table and everything a generic program needs to
/// talk to, serve, print and document the device.
struct Profile {
  std::string_view name;               ///< CLI name: "inverjet", "rehand6600"
  std::string_view title;              ///< "Inverjet counter-current swimming machine"
  std::string_view vendor;             ///< device identification object 0 (FC11, FC2B/0E); empty: none
  std::string_view product_code = {};  ///< object 1; empty: the name
  std::string_view revision = {};      ///< object 2 ("1.0"); empty: "1.0"
  std::span<const Row> rows;
  std::span<const FlagName> flag_names;  ///< names of the device's own flags (bit 0 is "persisted")
  LinkDefaults link;
  FrameQuirks quirks;  ///< opt-in frame quirks (RTU links only)
};

/// The kit's own flags by name, as map files and the docs write them.
inline constexpr FlagName kKitFlags[] = {
    {kPersisted, "persisted"}, {kLinkAddress, "link-address"}, {kLinkBaud, "link-baud"}};

/// The index of the first row carrying `flag`, or p.rows.size() when none
/// does. (Constant expressions use the index: GCC's -fsanitize=undefined
/// makes comparing a table row's address with nullptr non-constant.)
constexpr size_t row_index_with(const Profile& p, Flags flag) noexcept {
  for (size_t i = 0; i < p.rows.size(); ++i) {
    if (p.rows[i].has(flag)) return i;
  }
  return p.rows.size();
}
/// The first row carrying `flag`, or nullptr.
constexpr const Row* row_with(const Profile& p, Flags flag) noexcept {
  const size_t i = row_index_with(p, flag);
  return i < p.rows.size() ? &p.rows[i] : nullptr;
}

/// The unit addresses a device answers at, and the one it has from the factory.
struct UnitRange {
  uint8_t min = 1;
  uint8_t max = 247;
  uint8_t fallback = 1;  ///< the default address
  constexpr bool contains(int64_t unit) const noexcept { return unit >= min && unit <= max; }
};

/// From the link-address row (its range and default) when the device has
/// one, else from `Profile::link` (1..unit_max, unit).
constexpr UnitRange unit_range(const Profile& p) noexcept {
  if (const size_t i = row_index_with(p, kLinkAddress); i < p.rows.size()) {
    const Row& r = p.rows[i];
    const Range v = r.valid_range();
    const auto clip = [](int64_t x) { return static_cast<uint8_t>(x < 1 ? 1 : x > 255 ? 255 : x); };
    return {clip(v.min), clip(v.max), clip(r.default_value)};
  }
  return {1, p.link.unit_max, p.link.unit};
}

/// The rate a link-baud row's raw value stands for: a choice's name read as
/// a number, or the value itself; 0 when the value names no rate.
constexpr uint32_t baud_of(const Row& row, int64_t raw) noexcept {
  if (row.encoding != Encoding::choice) return raw > 0 && raw <= 0xFFFFFFFF ? static_cast<uint32_t>(raw) : 0;
  for (const Named& n : row.names) {
    if (n.value != raw) continue;
    uint64_t rate = 0;
    for (const char c : n.name) {
      if (c < '0' || c > '9' || rate > 100000000) return 0;
      rate = rate * 10 + static_cast<uint64_t>(c - '0');
    }
    return static_cast<uint32_t>(rate);
  }
  return 0;
}
/// The raw value a link-baud row stores for `baud`, or -1 when the device
/// has no such rate.
constexpr int64_t raw_of_baud(const Row& row, uint32_t baud) noexcept {
  if (baud == 0) return -1;
  if (row.encoding != Encoding::choice) return row.valid_range().contains(baud) ? int64_t{baud} : -1;
  for (const Named& n : row.names) {
    if (baud_of(row, n.value) == baud) return n.value;
  }
  return -1;
}

/// The device's factory link: `Profile::link` with the unit and baud rate
/// taken from its link rows' defaults where it has them.
constexpr LinkDefaults link_defaults(const Profile& p) noexcept {
  LinkDefaults link = p.link;
  link.unit = unit_range(p).fallback;
  link.unit_max = unit_range(p).max;
  if (const size_t i = row_index_with(p, kLinkBaud); i < p.rows.size()) {
    if (const uint32_t b = baud_of(p.rows[i], p.rows[i].default_value)) link.baud = b;
  }
  return link;
}

}  // namespace rtukit::profile
