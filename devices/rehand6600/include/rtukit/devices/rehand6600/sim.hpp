// The simulated Rehand 6600 controller: the chair model plus its console
// verbs (the user's side of the chair: joystick, buttons, charger, faults),
// for the one simulator host (profile/sim_host.hpp).
#pragma once

#include <cstdint>

#include "rtukit/devices/profile/sim_host.hpp"

namespace rtukit::rehand6600 {

struct SimConfig {
  uint32_t watchdog_ms = 500;  ///< D-5; 0 disables
};

/// The controller at power-on, with the console verbs joystick, button,
/// charger, clutch, distance, battery, error, overcurrent, horn, view, id.
profile::SimDevice make_sim_device(const SimConfig& config = {});

}  // namespace rtukit::rehand6600
