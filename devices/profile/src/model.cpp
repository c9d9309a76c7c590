// The generic half of every device model: the map decides what exists and
// what a value may be; the device's hooks decide what happens.
#include "rtukit/devices/profile/model.hpp"

#include <array>

namespace rtukit::profile {

void unknown_register_key() noexcept {}

FunctionSet functions_for(std::span<const Row> rows) noexcept {
  FunctionSet set = 0;
  for (const Row& r : rows) {
    switch (r.space) {
      case Space::holding:
        // A write-only table still answers reads with 02, not 01: FC03 exists.
        set |= function_bit(Function::read_holding_registers);
        if (r.writable())
          set |= function_bit(Function::write_single_register) |
                 function_bit(Function::write_multiple_registers);
        break;
      case Space::input:
        set |= function_bit(Function::read_input_registers);
        break;
      case Space::coil:
        set |= function_bit(Function::read_coils);
        if (r.writable())
          set |= function_bit(Function::write_single_coil) | function_bit(Function::write_multiple_coils);
        break;
      case Space::discrete:
        set |= function_bit(Function::read_discrete_inputs);
        break;
    }
  }
  return set;
}

FunctionSet functions_for(const Profile& profile) noexcept {
  return functions_for(profile.rows) | kDiagnosticFunctions |
         (profile.vendor.empty() ? FunctionSet{0} : kIdentificationFunctions);
}

std::string_view Model::device_object(uint8_t id) {
  switch (id) {
    case 0:
      return profile_->vendor;
    case 1:
      return profile_->product_code.empty() ? profile_->name : profile_->product_code;
    case 2:
      return profile_->revision.empty() ? std::string_view("1.0") : profile_->revision;
    case 4:
      return profile_->title;
    case 5:
      return profile_->name;
    default:
      return {};
  }
}

Model::Model(const Profile& profile, std::span<uint16_t> storage) noexcept
    : profile_(&profile),
      map_(profile.rows),
      image_(map_, storage),
      functions_(functions_for(profile)),
      address_row_(row_with(profile, kLinkAddress)),
      baud_row_(row_with(profile, kLinkBaud)) {
  image_.reset();
}

LinkDefaults Model::stored_link() const noexcept {
  LinkDefaults link = link_defaults(*profile_);
  if (address_row_) link.unit = static_cast<uint8_t>(image_.get(*address_row_));
  if (baud_row_) {
    if (const uint32_t b = baud_of(*baud_row_, image_.get(*baud_row_))) link.baud = b;
  }
  return link;
}

Error Model::override_link(std::optional<uint8_t> unit, std::optional<uint32_t> baud) noexcept {
  if (unit && !unit_range(*profile_).contains(*unit))
    return Error(Errc::invalid_argument, "unit outside the device's range");
  const int64_t baud_raw = baud && baud_row_ ? raw_of_baud(*baud_row_, *baud) : 0;
  if (baud_raw < 0) return Error(Errc::invalid_argument, "no such baud rate");
  if (unit && address_row_) image_.set(*address_row_, *unit);
  if (baud && baud_row_) image_.set(*baud_row_, baud_raw);
  return Errc::ok;
}

Errc Model::read(Space space, uint16_t address, std::span<uint16_t> out) {
  if (const Error e = map_.check_read(space, address, out.size())) return e.code();
  refresh(space);
  image_.read(space, address, out);
  return Errc::ok;
}

Errc Model::write(Space space, uint16_t address, std::span<const uint16_t> values) {
  if (const Error e = map_.check_write(space, address, values)) return e.code();
  // A link row the write changed moves the device after the response (the
  // simulator host asks take_link_change()); a refused write changes nothing.
  const int64_t unit_before = address_row_ ? image_.get(*address_row_) : 0;
  const int64_t baud_before = baud_row_ ? image_.get(*baud_row_) : 0;
  if (const Error e = apply_write(space, address, values)) return e.code();
  if (address_row_ && image_.get(*address_row_) != unit_before)
    link_change_.address = static_cast<uint8_t>(image_.get(*address_row_));
  if (baud_row_ && image_.get(*baud_row_) != baud_before) {
    if (const uint32_t b = baud_of(*baud_row_, image_.get(*baud_row_))) link_change_.baud = b;
  }
  return Errc::ok;
}

Errc Model::read_bits(Space space, uint16_t address, uint16_t count, std::span<uint8_t> packed_out) {
  if (const Error e = map_.check_read(space, address, count)) return e.code();
  refresh(space);
  std::array<uint16_t, 1> one{};
  for (uint16_t i = 0; i < count; ++i) {
    image_.read(space, static_cast<uint16_t>(address + i), one);
    set_bit(packed_out, i, one[0] != 0);
  }
  return Errc::ok;
}

Errc Model::write_coils(uint16_t address, uint16_t count, std::span<const uint8_t> packed) {
  // Coils travel as bits; the map and the image see them as 0/1 words. The
  // engine bounds count by 1968, so this stack buffer always holds them.
  std::array<uint16_t, kMaxWriteBits> values{};
  for (uint16_t i = 0; i < count; ++i) values[i] = get_bit(packed, i) ? 1 : 0;
  return write(Space::coil, address, std::span<const uint16_t>(values.data(), count));
}

}  // namespace rtukit::profile
