// rtukit device profiles: a device model over its register map.
//
// `Model` is the RegisterBank every simulated device is: the map does what is
// the same for every device (which addresses exist, which may be read or
// written, which values a row accepts: exceptions 02 and 03, a write
// validated whole), the stored registers live in an `Image`, and a device
// keeps only its behaviour in the hooks:
//  - `refresh()` puts live values (state, speed, temperatures) into the image
//    before a read;
//  - `apply_write()` runs a validated write: store it, start a motor, refuse
//    it with 04 for a device rule (and then change nothing);
//  - `advance_to()` moves the model's time (the simulator host passes device
//    time in; tests pass a virtual clock).
// A register-only device (a map file) is a Model with no hooks overridden.
//
// Pure: core and profile only, no heap, no OS. The simulator host
// (sim_host.hpp) serves a Model on a real link and keeps its persisted rows
// in a state file.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>

#include "rtukit/core/slave.hpp"
#include "rtukit/devices/profile/register_map.hpp"

namespace rtukit::profile {

/// The functions a register table needs: reads of every space it has, and
/// FC06/FC10 (FC05/FC0F) where it has writable holding registers (coils).
FunctionSet functions_for(std::span<const Row> rows) noexcept;
/// A profile's functions: its table's, the serial line diagnostics (07, 08,
/// 0B, 0C) and, when it names a vendor, identification (11, 2B/0E).
FunctionSet functions_for(const Profile& profile) noexcept;

/// A new unit address or baud rate a write asked for; the simulator host
/// applies it after the response to that write has gone out.
struct LinkChange {
  std::optional<uint8_t> address;
  std::optional<uint32_t> baud;
  explicit operator bool() const noexcept { return address || baud; }
};

/// Storage for a model's image, as a base class listed BEFORE Model so it is
/// constructed first (Model's constructor writes the defaults into it):
///   class Machine : private profile::ImageStorage<kMap.image_size()>, public profile::Model {
///     Machine() : Model(kProfile, words) {}
/// (A std::array data member would be zeroed after Model's constructor ran;
/// a model that keeps one must call image().reset() in its constructor body.)
template <size_t N>
struct ImageStorage {
  std::array<uint16_t, N> words{};
};

class Model : public RegisterBank {
 public:
  const Profile& profile() const noexcept { return *profile_; }
  const RegisterMap& map() const noexcept { return map_; }
  /// The stored registers. The host loads persisted rows into it before
  /// serving (then calls `restored()`) and saves them when they change.
  Image& image() noexcept { return image_; }
  const Image& image() const noexcept { return image_; }

  /// Runs the model up to device time `now_ms`. Earlier times are ignored.
  virtual void advance_to(uint64_t /*now_ms*/) noexcept {}
  /// The image's persisted rows were replaced from a state file.
  virtual void restored() noexcept {}
  /// A link change waiting since the last call (see LinkChange): a write
  /// that changed a link row (kLinkAddress, kLinkBaud).
  LinkChange take_link_change() noexcept { return std::exchange(link_change_, {}); }
  /// The unit address and baud rate the device keeps in its link rows (the
  /// Inverjet's 0x0000/0x0001); for a device without them, its
  /// `link_defaults()`.
  LinkDefaults stored_link() const noexcept;
  /// The simulator's --unit / --baud override what the link rows store.
  /// Errors (nothing changes then): invalid_argument, "unit outside the
  /// device's range" (its `unit_range()`) or "no such baud rate" (a link-baud
  /// row that cannot hold it). A device without a link row stores nothing.
  Error override_link(std::optional<uint8_t> unit, std::optional<uint32_t> baud) noexcept;

  // ---- RegisterBank, generic over the map ----
  FunctionSet functions() const noexcept override { return functions_; }
  FrameQuirks quirks() const noexcept override { return profile_->quirks; }
  Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    return read(Space::holding, address, out);
  }
  Errc read_input_registers(uint16_t address, std::span<uint16_t> out) override {
    return read(Space::input, address, out);
  }
  Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    return write(Space::holding, address, values);
  }
  Errc read_coils(uint16_t address, uint16_t count, std::span<uint8_t> packed_out) override {
    return read_bits(Space::coil, address, count, packed_out);
  }
  Errc read_discrete_inputs(uint16_t address, uint16_t count, std::span<uint8_t> packed_out) override {
    return read_bits(Space::discrete, address, count, packed_out);
  }
  Errc write_coils(uint16_t address, uint16_t count, std::span<const uint8_t> packed) override;
  /// Identification from the profile: 0 vendor, 1 product code, 2 revision,
  /// 4 product name (the title), 5 model name (the name). A device adds its
  /// own (0x80..) by overriding and calling this for the rest.
  std::string_view device_object(uint8_t id) override;

  /// A read as the bus sees it: check, refresh, copy. Errors: 02.
  Errc read(Space space, uint16_t address, std::span<uint16_t> out);
  /// A write as the bus sees it: check the whole request, then apply_write.
  /// Errors: 02, 03, or what apply_write refuses with.
  Errc write(Space space, uint16_t address, std::span<const uint16_t> values);

 protected:
  /// `storage` holds map.image_size() words and outlives the model; it is
  /// reset to the rows' defaults.
  Model(const Profile& profile, std::span<uint16_t> storage) noexcept;
  /// Not copied, not assigned: the image views the storage of the object
  /// that made it, so a copy would read and write another model's words
  /// (found by the Rehand simulation: a chair assigned over another after a
  /// simulated power cycle read freed memory).
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  /// Puts live values into the image before a read of `space`.
  virtual void refresh(Space /*space*/) noexcept {}
  /// Runs a write the map has validated. Default: store it. An override that
  /// refuses must change nothing and return the exception (04 for a device
  /// rule, 03 for a value that breaks a rule across registers).
  virtual Error apply_write(Space space, uint16_t address, std::span<const uint16_t> values) noexcept {
    image_.write(space, address, values);
    return Errc::ok;
  }

 private:
  Errc read_bits(Space space, uint16_t address, uint16_t count, std::span<uint8_t> packed_out);

  const Profile* profile_;
  RegisterMap map_;
  Image image_;
  FunctionSet functions_;
  const Row* address_row_;
  const Row* baud_row_;
  LinkChange link_change_;
};

}  // namespace rtukit::profile
