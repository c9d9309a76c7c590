// rtukit devices: the registry, every device this build knows (one
// rtukit_add_device() line each, see cmake/rtukit_add_device.cmake). The
// front-ends read it and nothing else to learn which devices exist.
#pragma once

#include <span>
#include <string_view>

#include "rtukit/devices/profile/device.hpp"

namespace rtukit::devices {

/// Every registered device, in the order their lines ran (built-ins first).
std::span<const profile::DeviceEntry* const> registered();

/// The registered device named `name` (its profile's name), or nullptr.
const profile::DeviceEntry* find(std::string_view name);

/// A registered device at a unit, as a sniffer names it ("inverjet@21").
struct DeviceAt {
  const profile::DeviceEntry* entry = nullptr;
  UnitId unit{0};
};
/// Errors: invalid_argument: profile::split_at_unit's, "no such device
/// 'fly' (rehand6600, inverjet)", profile::device_unit's ("inverjet unit 300
/// is out of range 1..254").
Outcome<DeviceAt> find_at(std::string_view text);

}  // namespace rtukit::devices
