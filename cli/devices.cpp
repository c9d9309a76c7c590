// The built-in devices. Adding a device adds one entry here.
#include "registry.hpp"
#include "rtukit/devices/inverjet/reference.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/inverjet/sim.hpp"

namespace rtukit::cli {

std::span<const DeviceEntry> builtin_devices() {
  static const std::vector<DeviceEntry> entries = {
      {.profile = &inverjet::kProfile,
       .make_sim = [] { return inverjet::make_sim_device(); },
       .markdown = [] { return inverjet::registers_markdown(); }},
  };
  return entries;
}

}  // namespace rtukit::cli
