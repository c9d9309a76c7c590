// rtukit device profile kit: a device's verbs as a table. A verb is what a
// person asks of the device by name ("start --timer 30:00 --speed 80",
// "config baud 19200", "errors 10C3"): its arguments with their meaning,
// range and unit, what it writes, and the code that checks and runs it.
// The device layer owns all of that; a front-end (the CLI) only turns the
// table into its own syntax, hands back the texts it was given, opens the
// link when the verb asks for it, and prints the result.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/driver/master.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::profile {

/// One argument of a verb.
struct VerbArg {
  enum class Form : uint8_t {
    positional,  ///< a word in order: `speed 75`
    option,      ///< a named value: `--timer 30:00`
    flag,        ///< a named switch: `--free`
  };
  std::string_view name;  ///< "speed", "timer", "free"; a positional's name is shown upper case
  Form form = Form::option;
  std::string help;  ///< with its range and unit, from the rows: "0..100 %"
  bool required = false;
  std::string_view fallback = {};  ///< the value when absent (shown in the help); empty: none
};

/// A verb of a device: `rtukit <device> <name> ARGS`.
struct Verb {
  std::string_view name;  ///< "start"; a group and its verb: "plan show"
  std::string help;
  std::vector<VerbArg> args;
  /// What follows `rtukit <device> <name>` in the help's examples, `{port}`
  /// standing for the device's usual port ("{port} --timer 30:00 --speed 80").
  std::vector<std::string_view> examples;
  /// Whether the verb talks to the device (then it takes the link options
  /// and --unit); false: it prints from the tables (`errors`, `stopping`).
  bool uses_link = true;
  /// Whether the verb's result is a reading (its --json prints the values).
  bool reads = false;
};

/// The arguments a front-end collected: the text of each given argument by
/// name; a flag given is "true". Absent: not in the map.
using VerbArgs = std::map<std::string, std::string, std::less<>>;

/// What a verb did, for people and for machines.
struct VerbResult {
  /// What was done ("start", "config baud"), for the document's "action";
  /// empty: a reading (the document carries only its values).
  std::string action;
  std::string text;  ///< a line (or a panel of lines) for people, without the final '\n'
  /// The document's "values" (decoded entries by key, profile::entry_json);
  /// null: none.
  nlohmann::ordered_json values;
  /// Further fields of the document ("plan", "segments"); null: none.
  nlohmann::ordered_json extra;
};

/// Where a verb runs: the unit it talks to, and the link opened when the verb
/// asks for it (after its arguments are checked: an argument refused never
/// opens the port, so nothing half-valid is sent).
struct VerbContext {
  UnitId unit{0};
  /// Opens the link (a front-end's transport); the Master lives as long as
  /// the context. A port that cannot be opened ends the verb in the front-end.
  std::function<Master&()> open;
  /// The link alone, for a verb that runs a controller of its own over it
  /// (the Rehand 6600's host controller owns its port); same rules as `open`.
  std::function<std::unique_ptr<io::Link>()> open_link;
  /// For such a controller: the front-end's answer timeout and frame trace.
  std::chrono::milliseconds response_timeout{1000};
  std::function<void(const TraceEvent&)> trace;
  /// How the front-end marks what needs attention (a fault) in a text; nullptr: as it is.
  std::function<std::string(std::string_view)> alert;
};

/// Runs `verb` with `args`. Errors: invalid_argument (an argument, with the
/// rule it breaks: the front-end's usage error), refused (the device is not
/// the one expected, or a device rule refused), a Modbus exception (its
/// Error kept, the reason in words), or the link's (timeout, io_error). The
/// reason names what was being done; the front-end adds where.
using RunVerb =
    std::function<Outcome<VerbResult>(const Verb& verb, const VerbArgs& args, VerbContext& context)>;

/// The text of `name` in `args`, or `fallback`.
std::string_view arg(const VerbArgs& args, std::string_view name, std::string_view fallback = {});
/// Whether flag or argument `name` was given.
bool given(const VerbArgs& args, std::string_view name);

/// The verb named `name` in `verbs`, or nullptr.
const Verb* find_verb(std::span<const Verb> verbs, std::string_view name);

/// The verbs as a Markdown table (name, arguments, what it does), for a
/// device's doc.
std::string verbs_markdown(std::string_view device, std::span<const Verb> verbs);

}  // namespace rtukit::profile
