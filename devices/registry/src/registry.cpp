// The lookup over the generated list (registered.cpp in the build tree).
#include "rtukit/devices/registry.hpp"

namespace rtukit::devices {

const profile::DeviceEntry* find(std::string_view name) {
  for (const profile::DeviceEntry* e : registered())
    if (e->profile->name == name) return e;
  return nullptr;
}

}  // namespace rtukit::devices
