// The built-in devices. Adding a device adds one entry here.
#include "registry.hpp"

namespace rtukit::cli {

std::span<const DeviceEntry> builtin_devices() {
  static const std::vector<DeviceEntry> entries = {};
  return entries;
}

}  // namespace rtukit::cli
