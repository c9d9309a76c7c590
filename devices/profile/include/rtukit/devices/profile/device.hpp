// rtukit device profile kit: what a device brings to the registry, so every
// front-end (the CLI's device verbs, the simulator, the sniffer, the docs
// generator) finds it without knowing it. No front-end library here: a
// simulator option is a name, a help text and a default; the front-end
// shows it and hands back the text it was given.
#pragma once

#include <functional>
#include <map>
#include <span>
#include <string>
#include <string_view>

#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/devices/profile/sim_host.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::profile {

/// A simulator option of one device: `rtukit sim <device> --<name> VALUE`.
struct SimOption {
  std::string_view name;  ///< without the dashes: "watchdog-ms"
  std::string_view help;
  std::string_view default_value;  ///< as text, shown in the help
};

/// The text of every option of the device, by name (absent: its default).
using SimSettings = std::map<std::string, std::string, std::less<>>;

/// The text of option `name` in `settings`, or its default from `options`.
std::string_view setting(const SimSettings& settings, std::span<const SimOption> options,
                         std::string_view name);

struct DeviceEntry {
  /// The register table: the unit range, the link, every register (schema.hpp).
  const Profile* profile = nullptr;
  std::span<const SimOption> sim_options;
  /// The device's simulator: its model and console verbs. Errors:
  /// invalid_argument naming the option whose text does not parse.
  std::function<Outcome<SimDevice>(const SimSettings&)> make_sim;
  /// The register reference as the device's doc embeds it; empty: the
  /// kit's generic one (registers_markdown in text.hpp).
  std::function<std::string()> markdown;
};

}  // namespace rtukit::profile
