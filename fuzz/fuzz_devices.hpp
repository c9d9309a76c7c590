// The devices the profile-kit targets serve: the Inverjet and the Rehand 6600
// exactly as their simulators build them (make_sim_device), and a
// register-map device from the example map (examples/maps/energy-meter.yaml,
// path set by fuzz/CMakeLists.txt), loaded once.
#pragma once

#include <cstdlib>
#include <memory>

#include "rtukit/devices/inverjet/sim.hpp"
#include "rtukit/devices/profile/map_file.hpp"
#include "rtukit/devices/rehand6600/sim.hpp"

namespace rtukit::fuzz {

inline constexpr unsigned kDeviceKinds = 3;

/// A fresh model of device `kind` (taken modulo kDeviceKinds): 0 the
/// Inverjet, 1 the Rehand 6600, 2 the example map's register-only device.
inline std::unique_ptr<profile::Model> make_device(unsigned kind) {
  switch (kind % kDeviceKinds) {
    case 0:
      return inverjet::make_sim_device().model;
    case 1:
      return rehand6600::make_sim_device().model;
    default: {
      static const auto map = [] {
        auto loaded = profile::load_map(RTUKIT_FUZZ_EXAMPLE_MAP);
        if (!loaded.ok()) std::abort();  // the build's own example must load
        return std::move(*loaded);
      }();
      return profile::make_register_device(map->profile());
    }
  }
}

/// The unit a simulator serves the model at (its stored address, else the
/// profile's default).
inline uint8_t device_unit(const profile::Model& m) {
  return m.stored_link().unit;
}

}  // namespace rtukit::fuzz
