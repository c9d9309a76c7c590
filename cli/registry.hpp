// rtukit CLI: the device profiles the binary knows. Each built-in device is
// one entry; every generic command (registers, get, set, watch, sim) is
// built from these entries, and only verbs that need a device's typed client
// or host controller are registered by the device's own file.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "commands.hpp"
#include "rtukit/devices/profile/sim_host.hpp"

namespace rtukit::cli {

struct DeviceEntry {
  const profile::Profile* profile;
  /// The device's simulator: model + console verbs. `sim` is the `sim <device>`
  /// subcommand, for device-specific options (read them when make_sim runs).
  std::function<void(CLI::App& sim)> add_sim_options;
  std::function<profile::SimDevice()> make_sim;
  /// The register reference as docs/<device>.md embeds it.
  std::function<std::string()> markdown;
  /// Typed verbs (start, hold, ...) on the device's subcommand; may be empty.
  std::function<void(CLI::App& device, Action& action)> add_commands;
};

/// Every built-in device, in the order `rtukit devices` lists them.
std::span<const DeviceEntry> builtin_devices();

/// rtukit devices; rtukit <device> registers|get|set (+ the device's own verbs);
/// rtukit map check|export.
void add_profile_commands(CLI::App& app, Action& action);

}  // namespace rtukit::cli
