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
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/devices/profile/sim_host.hpp"
#include "rtukit/devices/profile/verb.hpp"

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

/// A generated section of a device's doc: the text between the lines
/// `<!-- BEGIN GENERATED: rtukit <device> <name> -->` and
/// `<!-- END GENERATED: rtukit <device> <name> -->`, made from the tables.
struct DocSection {
  std::string_view name;  ///< "registers", "errors"; also the CLI verb that prints it
  std::function<std::string()> markdown;
};

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
  /// The device's doc, from the top of the source tree ("docs/inverjet.md");
  /// empty: none (the example device). `scripts/gen-docs.sh` rewrites its
  /// generated sections, and a test fails when one is stale.
  std::string_view doc;
  /// Generated sections besides "registers" (which every device has).
  std::vector<DocSection> doc_sections;
  /// The device's own verbs (verb.hpp) besides the ones every device has
  /// (get, set, watch, status, registers), and how they run. A verb of the
  /// same name as a common one replaces it.
  std::vector<Verb> verbs;
  RunVerb run_verb;
  /// How messages name the device ("Inverjet" in "Inverjet unit 21 on
  /// /dev/ttyUSB0"); empty: the profile's name.
  std::string_view label;
  /// How the device words a request nobody answered (timeout, CRC, a wrong
  /// answer), given the verb's failure, in place of a front-end's generic
  /// advice (the Rehand 6600's "1010 Master Error" with what to check);
  /// empty: the front-end's.
  std::function<std::string(const rtukit::Status&)> no_answer;
  /// Who answers at the unit, checked before the verbs every device has
  /// (get, set, watch, status) read or write anything: the device's
  /// handshake (the Rehand 6600 reads its device ID, 0x68), so a generic
  /// slave at the address is never read as the device. Returns ok, or the
  /// failure worded as the device's own verbs word it: refused (another
  /// device answered), a timeout (nobody did), io_error. Empty: no check.
  std::function<rtukit::Status(Master&, UnitId)> identify;
  /// The port its examples show, and the answer timeout its verbs start from.
  std::string_view example_port = "/dev/ttyUSB0";
  unsigned answer_timeout_ms = 1000;
};

/// Every generated section of `entry`'s doc: "registers" (`markdown`, or the
/// kit's generic reference) first, "commands" (its verb table, when it has
/// verbs), then the device's own.
std::vector<DocSection> doc_sections(const DeviceEntry& entry);

/// `text` (the device's doc) with every generated section rewritten from the
/// tables. Errors: invalid_argument naming the markers of a section the doc lacks.
Outcome<std::string> regenerate_doc(const DeviceEntry& entry, std::string_view text);

}  // namespace rtukit::profile
