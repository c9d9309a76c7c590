// The built-in devices. Adding a device adds one entry here.
#include "registry.hpp"
#include "rtukit/devices/inverjet/reference.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/inverjet/sim.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/sim.hpp"

namespace rtukit::cli {
namespace {
// `sim rehand6600 --watchdog-ms`: read when the simulator starts.
rehand6600::SimConfig& rehand_sim_config() {
  static rehand6600::SimConfig config;
  return config;
}
}  // namespace

std::span<const DeviceEntry> builtin_devices() {
  static const std::vector<DeviceEntry> entries = {
      {.profile = &inverjet::kProfile,
       .make_sim = [] { return inverjet::make_sim_device(); },
       .markdown = [] { return inverjet::registers_markdown(); }},
      {.profile = &rehand6600::kProfile,
       .add_sim_options =
           [](CLI::App& sim) {
             sim.add_option("--watchdog-ms", rehand_sim_config().watchdog_ms,
                            "communication watchdog (D-5); 0 disables")
                 ->capture_default_str();
           },
       .make_sim = [] { return rehand6600::make_sim_device(rehand_sim_config()); },
       .markdown = [] { return rehand6600::registers_markdown(); }},
  };
  return entries;
}

}  // namespace rtukit::cli
