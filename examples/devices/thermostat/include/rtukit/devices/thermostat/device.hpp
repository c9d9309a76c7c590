// The thermostat's entry in the device registry: one rtukit_add_device()
// line (this folder's CMakeLists.txt) makes every front-end know it.
#pragma once

#include "rtukit/devices/profile/device.hpp"

namespace rtukit::thermostat {

const profile::DeviceEntry& device_entry();

}  // namespace rtukit::thermostat
