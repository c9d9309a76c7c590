// The Rehand 6600's entry in the device registry (devices/registry): its
// table, its simulator (with the D-5 watchdog option) and its register
// reference.
#pragma once

#include "rtukit/devices/profile/device.hpp"

namespace rtukit::rehand6600 {

const profile::DeviceEntry& device_entry();

}  // namespace rtukit::rehand6600
