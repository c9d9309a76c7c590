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

#include "rtukit/base/status.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/link.hpp"

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
  /// Non-zero: a live view (`watch`), refreshed this often by default until
  /// the person stops it; the front-end takes the interval and a count.
  unsigned live_interval_ms = 0;
  /// The verb lasts (a hold): the front-end catches a stop request (Ctrl-C)
  /// from the start and hands it over through VerbContext::wait, so the verb
  /// ends the way it must (a hold released), never killed half-way.
  bool lasting = false;
};

/// The arguments a front-end collected: the text of each given argument by
/// name; a flag given is "true". Absent: not in the map.
using VerbArgs = std::map<std::string, std::string, std::less<>>;

/// One refresh of a live verb (Verb::live_interval_ms).
struct LiveFrame {
  bool ok = true;                    ///< false: no fresh reading (the link is down): `why` says so
  std::string why;                   ///< "no response", "1010 Master Error: ..."
  std::string kind = "no_response";  ///< the error's kind in the document
  std::string panel;                 ///< the panel, for a terminal (without the final '\n')
  std::string line;                  ///< one line, for a pipe (the front-end puts the time first)
  nlohmann::ordered_json values;     ///< the document's "values"; null: none
};

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
  /// For people only, after the text (the chair's panel after a hold); not in the document.
  std::string more;
  /// A lasting verb ended early because the person asked (VerbContext::wait
  /// said so); the front-end's exit code says it was cut short.
  bool interrupted = false;
  /// A live verb's refresh, called for n = 0, 1, ... each interval while the
  /// result lives (destroying it ends the view: a controller stopped). An
  /// error ends the view (nothing there at the first refresh); a frame that
  /// is not ok keeps it going, marked stale. Empty for other verbs.
  std::function<Outcome<LiveFrame>(unsigned n)> refresh;
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
  /// The clock a lasting verb measures its length on; nullptr: the steady clock.
  DriverClock* clock = nullptr;
  /// For a lasting verb: waits `d`; false when the person asked to stop
  /// (then the verb ends safely at once). nullptr: waits on `clock`.
  std::function<bool(std::chrono::milliseconds d)> wait;
  /// Shows how far a lasting verb is ("holding seat_lift up (1): 1.2 s
  /// left"); "" removes it. nullptr: nothing shown.
  std::function<void(std::string_view text)> progress;
};

/// `context.wait(d)`, or a sleep of `d` on its clock when the front-end gives none.
bool wait(VerbContext& context, std::chrono::milliseconds d);
/// `context.progress(text)` when the front-end shows progress.
void progress(VerbContext& context, std::string_view text);

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
