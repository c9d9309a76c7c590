#include "rtukit/devices/inverjet/device.hpp"

#include "rtukit/devices/inverjet/reference.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/inverjet/sim.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"

namespace rtukit::inverjet {

const profile::DeviceEntry& device_entry() {
  static const profile::DeviceEntry entry{
      .profile = &kProfile,
      .make_sim = [](const profile::SimSettings&) -> Outcome<profile::SimDevice> {
        return make_sim_device();
      },
      .markdown = [] { return registers_markdown(); },
      .doc = "docs/inverjet.md",
      .verbs = verb_table(),
      .run_verb = run_verb,
      .label = "Inverjet"};
  return entry;
}

}  // namespace rtukit::inverjet
