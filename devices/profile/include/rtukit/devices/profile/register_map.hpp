// rtukit device profiles: the register map over a table of rows.
//
// The map is the one place that knows where a register is, what a request
// may touch, and how raw words become a value:
//  - lookup by address (any space) and by key;
//  - `check_read` / `check_write`: the exceptions a strict device answers
//    (02 for any address no readable/writable row covers, 03 for a value a
//    row refuses), a multi-register write validated whole, so a model applies
//    all or nothing;
//  - `decode` / `encode`: words <-> raw value (sign, 32-bit word order); the
//    scale is applied only by `to_number` / `from_number` here and by the
//    text functions (text.hpp) built on them;
//  - `Image`: a device's stored registers, one word slot per register of
//    every row, addressed by compile-time `Handle`s.
//
// Everything is constexpr and heap-free: a device's map and handles are
// compile-time constants (`inline constexpr RegisterMap kMap{kRows};`), and a
// typo in a handle's key fails to compile.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/profile/schema.hpp"

namespace rtukit::profile {

/// A row of a map, by index; made at compile time by `RegisterMap::handle`.
struct Handle {
  uint16_t row = 0;
  friend constexpr bool operator==(Handle, Handle) noexcept = default;
};

/// Where an address lands: a row, the entry within a repeated block, the word
/// within a 32-bit value (0 = the first word on the wire). `row` is nullptr
/// for an address no row covers.
struct Slot {
  const Row* row = nullptr;
  uint16_t index = 0;
  uint8_t word = 0;
  explicit constexpr operator bool() const noexcept { return row != nullptr; }
};

// Called only when a compile-time lookup fails: not constexpr, so the
// compiler stops with this function's name in the message.
void unknown_register_key() noexcept;

class RegisterMap {
 public:
  constexpr explicit RegisterMap(std::span<const Row> rows) noexcept : rows_(rows) {}

  constexpr std::span<const Row> rows() const noexcept { return rows_; }
  constexpr const Row& row(Handle h) const noexcept { return rows_[h.row]; }
  constexpr Handle handle_of(const Row& r) const noexcept {
    return Handle{static_cast<uint16_t>(&r - rows_.data())};
  }

  /// The row named `key`, or nullptr.
  constexpr const Row* find(std::string_view key) const noexcept {
    for (const Row& r : rows_) {
      if (r.key == key) return &r;
    }
    return nullptr;
  }
  /// Compile-time handle of `key`; an unknown key does not compile.
  consteval Handle handle(std::string_view key) const noexcept {
    for (size_t i = 0; i < rows_.size(); ++i) {
      if (rows_[i].key == key) return Handle{static_cast<uint16_t>(i)};
    }
    unknown_register_key();
    return Handle{};
  }

  /// The row covering `address` in `space` (any access), or an empty slot.
  constexpr Slot at(Space space, uint16_t address) const noexcept {
    for (const Row& r : rows_) {
      if (r.space != space || address < r.address || address > r.last_address()) continue;
      const unsigned offset = address - r.address;
      if (offset % r.step() >= r.words()) continue;  // between repeated entries: maybe another row
      return Slot{&r, static_cast<uint16_t>(offset / r.step()), static_cast<uint8_t>(offset % r.step())};
    }
    return {};
  }

  /// Word slots an Image of this map needs.
  constexpr size_t image_size() const noexcept {
    size_t n = 0;
    for (const Row& r : rows_) n += size_t{r.repeat} * r.words();
    return n;
  }
  /// Image slot of entry `index`, word `word` of `row`.
  constexpr size_t slot_of(const Row& row, unsigned index = 0, unsigned word = 0) const noexcept {
    size_t n = 0;
    for (const Row& r : rows_) {
      if (&r == &row) break;
      n += size_t{r.repeat} * r.words();
    }
    return n + size_t{index} * row.words() + word;
  }

  // ---- validation (the exceptions a strict device answers) ----

  /// ok, or illegal_data_address when any address of the range has no
  /// readable row. Precondition: address + count <= 0x10000 (the engine checks).
  constexpr Error check_read(Space space, uint16_t address, size_t count) const noexcept {
    for (size_t i = 0; i < count; ++i) {
      const Slot s = at(space, static_cast<uint16_t>(address + i));
      if (!s || !s.row->readable()) return Error(Errc::illegal_data_address, "no readable register there");
    }
    return Errc::ok;
  }

  /// Validates a whole write before anything changes: illegal_data_address
  /// when an address has no writable row or a 32-bit value is written only in
  /// part; then illegal_data_value when a value is outside its row's
  /// writable range or not one of its named choices. Coil values are 0/1.
  constexpr Error check_write(Space space, uint16_t address,
                              std::span<const uint16_t> values) const noexcept {
    // Every address first (02), then every value (03), as Modbus orders them.
    for (size_t i = 0; i < values.size();) {
      const Slot s = at(space, static_cast<uint16_t>(address + i));
      if (!s || !s.row->writable()) return Error(Errc::illegal_data_address, "no writable register there");
      if (s.row->words() == 2 && (s.word != 0 || i + 1 >= values.size()))
        return Error(Errc::illegal_data_address, "a 32-bit value must be written whole");
      i += s.row->words();
    }
    for (size_t i = 0; i < values.size();) {
      const Row& r = *at(space, static_cast<uint16_t>(address + i)).row;
      if (Error e = check_value(r, decode(r, values.subspan(i, r.words())))) return e;
      i += r.words();
    }
    return Errc::ok;
  }

  /// ok, or illegal_data_value when `raw` may not be written to `row`.
  static constexpr Error check_value(const Row& row, int64_t raw) noexcept {
    if (!row.write_range().contains(raw)) return Error(Errc::illegal_data_value, "value out of range");
    if (row.encoding == Encoding::choice && !row.names.empty()) {
      for (const Named& n : row.names) {
        if (n.value == raw) return Errc::ok;
      }
      return Error(Errc::illegal_data_value, "not one of the listed values");
    }
    return Errc::ok;
  }

  // ---- words <-> raw values (the only place word order and sign are applied) ----

  /// The raw value of one entry from its words (`row.words()` of them).
  static constexpr int64_t decode(const Row& row, std::span<const uint16_t> words) noexcept {
    if (row.words() == 1) {
      return row.is_signed() ? int64_t{static_cast<int16_t>(words[0])} : int64_t{words[0]};
    }
    const uint32_t hi = row.order == WordOrder::high_first ? words[0] : words[1];
    const uint32_t lo = row.order == WordOrder::high_first ? words[1] : words[0];
    const uint32_t v = (hi << 16) | lo;
    return row.is_signed() ? int64_t{static_cast<int32_t>(v)} : int64_t{v};
  }
  /// The words of one entry for `raw` (truncated to the row's width).
  static constexpr void encode(const Row& row, int64_t raw, std::span<uint16_t> words) noexcept {
    const auto v = static_cast<uint32_t>(raw);
    if (row.words() == 1) {
      words[0] = static_cast<uint16_t>(v);
      return;
    }
    const auto hi = static_cast<uint16_t>(v >> 16);
    const auto lo = static_cast<uint16_t>(v & 0xFFFF);
    words[0] = row.order == WordOrder::high_first ? hi : lo;
    words[1] = row.order == WordOrder::high_first ? lo : hi;
  }

  /// The value in the row's unit (raw / scale).
  static constexpr double to_number(const Row& row, int64_t raw) noexcept {
    return static_cast<double>(raw) / static_cast<double>(row.scale ? row.scale : 1);
  }
  /// The raw value for `value` in the row's unit, rounded to the nearest
  /// step. Errors: illegal_data_value when it falls outside the row's raw range.
  static constexpr Result<int64_t> from_number(const Row& row, double value) noexcept {
    const double scaled = value * (row.scale ? row.scale : 1);
    const Range r = row.valid_range();
    if (!(scaled >= static_cast<double>(r.min) - 0.5 && scaled <= static_cast<double>(r.max) + 0.5))
      return Error(Errc::illegal_data_value, "value out of range");
    const auto raw = static_cast<int64_t>(scaled < 0 ? scaled - 0.5 : scaled + 0.5);
    return raw < r.min ? r.min : raw > r.max ? r.max : raw;
  }

 private:
  std::span<const Row> rows_;
};

/// A device's stored registers: one word per register of every row, in the
/// order of the map. The storage is the owner's (a std::array sized by
/// `map.image_size()`), so a model stays heap-free.
class Image {
 public:
  constexpr Image(const RegisterMap& map, std::span<uint16_t> words) noexcept : map_(&map), words_(words) {}

  const RegisterMap& map() const noexcept { return *map_; }
  std::span<const uint16_t> words() const noexcept { return words_; }
  std::span<uint16_t> words() noexcept { return words_; }

  /// Every entry of every row to its default.
  constexpr void reset() noexcept {
    for (const Row& r : map_->rows()) {
      for (unsigned i = 0; i < r.repeat; ++i) set(r, r.default_of(i), i);
    }
  }

  constexpr int64_t get(Handle h, unsigned index = 0) const noexcept { return get(map_->row(h), index); }
  constexpr int64_t get(const Row& r, unsigned index = 0) const noexcept {
    return RegisterMap::decode(r, words_.subspan(map_->slot_of(r, index), r.words()));
  }
  /// Stores `raw` without checking it (the model's own values; writes from
  /// the bus are checked with RegisterMap::check_write first).
  constexpr void set(Handle h, int64_t raw, unsigned index = 0) noexcept { set(map_->row(h), raw, index); }
  constexpr void set(const Row& r, int64_t raw, unsigned index = 0) noexcept {
    RegisterMap::encode(r, raw, words_.subspan(map_->slot_of(r, index), r.words()));
  }
  /// uint16_t convenience for 1-word rows.
  constexpr uint16_t u16(Handle h, unsigned index = 0) const noexcept {
    return static_cast<uint16_t>(get(h, index));
  }

  /// Copies stored words for a read. Precondition: check_read passed.
  constexpr void read(Space space, uint16_t address, std::span<uint16_t> out) const noexcept {
    for (size_t i = 0; i < out.size(); ++i) {
      const Slot s = map_->at(space, static_cast<uint16_t>(address + i));
      out[i] = s ? words_[map_->slot_of(*s.row, s.index, s.word)] : 0;
    }
  }
  /// Stores words of a write. Precondition: check_write passed.
  constexpr void write(Space space, uint16_t address, std::span<const uint16_t> values) noexcept {
    for (size_t i = 0; i < values.size(); ++i) {
      const Slot s = map_->at(space, static_cast<uint16_t>(address + i));
      if (s) words_[map_->slot_of(*s.row, s.index, s.word)] = values[i];
    }
  }

 private:
  const RegisterMap* map_;
  std::span<uint16_t> words_;
};

}  // namespace rtukit::profile
