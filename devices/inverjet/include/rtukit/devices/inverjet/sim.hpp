// The simulated Inverjet: the behaviour model plus its console verbs, for
// the one simulator host (profile/sim_host.hpp), which does the rest: time
// scale, link changes after the response, the state file, help and status.
#pragma once

#include "rtukit/devices/profile/sim_host.hpp"

namespace rtukit::inverjet {

/// The machine at power-on, with the console verbs
///   fault NAME|BIT|0xMASK [on|off], fault clear, temp mosfet|motor C, mains V.
profile::SimDevice make_sim_device();

}  // namespace rtukit::inverjet
