#include "rtukit/devices/thermostat/device.hpp"

#include <memory>

#include "rtukit/devices/thermostat/model.hpp"

namespace rtukit::thermostat {

const profile::DeviceEntry& device_entry() {
  static const profile::DeviceEntry entry{
      .profile = &kProfile, .make_sim = [](const profile::SimSettings&) -> Outcome<profile::SimDevice> {
        return profile::SimDevice{.model = std::make_unique<Thermostat>()};
      }};
  return entry;
}

}  // namespace rtukit::thermostat
