// The Inverjet's entry in the device registry (devices/registry): its table,
// its simulator and its register reference.
#pragma once

#include "rtukit/devices/profile/device.hpp"

namespace rtukit::inverjet {

const profile::DeviceEntry& device_entry();

}  // namespace rtukit::inverjet
