// The lookup over the generated list (registered.cpp in the build tree).
#include "rtukit/devices/registry.hpp"

#include <fmt/core.h>

#include "rtukit/devices/profile/typed_value.hpp"

namespace rtukit::devices {

const profile::DeviceEntry* find(std::string_view name) {
  for (const profile::DeviceEntry* e : registered())
    if (e->profile->name == name) return e;
  return nullptr;
}

Outcome<DeviceAt> find_at(std::string_view text) {
  const auto split = profile::split_at_unit(text);
  if (!split) return split.error();
  const auto& [name, unit] = *split;
  const profile::DeviceEntry* entry = find(name);
  if (!entry) {
    std::string known;
    for (const profile::DeviceEntry* e : registered())
      known += (known.empty() ? "" : ", ") + std::string(e->profile->name);
    return rtukit::Status(Errc::invalid_argument, fmt::format("no such device '{}' ({})", name, known));
  }
  const Outcome<uint8_t> u = profile::device_unit(*entry->profile, unit);
  if (!u) return u.error();
  return DeviceAt{entry, UnitId{*u}};
}

}  // namespace rtukit::devices
