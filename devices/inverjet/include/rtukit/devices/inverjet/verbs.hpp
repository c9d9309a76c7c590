// rtukit Inverjet: the machine's verbs and its status view, once, for every
// front-end (the CLI, the MQTT bridge, the pool panel).
//
//  - The verbs: one command vocabulary (start, pause, resume, stop, speed,
//    plan), each taking one JSON object, checked against the register table
//    (speed and time ranges, plan count) before the typed client runs it.
//  - The status view: what a status means, decided once: whether the run
//    time counts up or down (and when nothing tells), which plan runs, and the
//    two documents built from it: `status_values` (every register as a
//    decoded entry: `rtukit inverjet status --json`) and `state_document`
//    (the flat state the bridge publishes and the panel shows).
// Front-ends only parse, print and transport these.
#pragma once

#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/devices/profile/verb.hpp"
#include "rtukit/driver/master.hpp"

namespace rtukit::inverjet {

// ---- the status view ----

/// How the run-time register counts: up (free runs and plans), down (timer
/// runs), or unknown (the fault screen after a run nobody saw start).
enum class TimeCounts : uint8_t { elapsed, remaining, unknown };
/// "elapsed", "remaining", "at the fault".
std::string_view time_counts_name(TimeCounts t) noexcept;

/// The run family the time belongs to. In the fault screen (state 17) the
/// state no longer tells whether a free or a timer run was going:
/// `remembered` is the last family a watcher saw (Family::none: nobody saw).
Family time_family(const MachineStatus& s, Family remembered) noexcept;
TimeCounts time_counts(const MachineStatus& s, Family remembered = Family::none) noexcept;
/// What a watcher remembers after seeing `s`: the run family while one
/// shows, kept through the fault screen, forgotten when the machine is off.
Family remember_family(const MachineStatus& s, Family remembered) noexcept;

/// The plan the work mode selects (1..kPlanCount), or nullopt for free & timer.
std::optional<unsigned> plan_of(const MachineStatus& s) noexcept;

/// Every status register as `profile::entry_json` (raw values from the
/// status through the rows' scales), plus "phase", "family",
/// "run_time_counts" and "rpm": the "values" of `rtukit inverjet status --json`.
nlohmann::json status_values(const MachineStatus& s, Family remembered = Family::none);

/// The speed the water moves at, as a screen shows it big: the set speed
/// while the run is starting or running, 0 when the jet stands (off, paused,
/// ended, the menu, the fault screen), whatever the speed register holds.
uint16_t jet_speed(const MachineStatus& s) noexcept;

/// What to do about fault bit `bit` (registers.hpp, kFaultAdvice): "call
/// service" for a bit the table does not name.
std::string_view fault_advice(unsigned bit) noexcept;

/// Which commands the machine takes in this state (the model's rules, D-10,
/// B-3): start anywhere but the fault screen (a start over a run replaces
/// it), pause while starting or running, resume while paused, stop unless
/// off, speed during a run (starting, running, paused).
struct Actions {
  bool start = false, pause = false, resume = false, stop = false, speed = false;
};
Actions allowed_actions(const MachineStatus& s) noexcept;

/// The flat state document (docs/inverjet.md, "MQTT"): mode ("free",
/// "timer", "plan N"; "off" when the machine is off), state by name,
/// running, speed (the set speed), jet_speed (jet_speed()), time,
/// remaining_s or elapsed_s (both null when the time's meaning is unknown),
/// faults by name, fault_advice ([{fault, advice}]), allowed ({start, pause,
/// resume, stop, speed}), temperatures, current, rpm, bus voltage, versions.
nlohmann::json state_document(const MachineStatus& s, Family remembered = Family::none);

/// The machine's limits as screens need them, from the table: plans (count),
/// segments (per plan), speed {min, max}, time_max_s and time_max ("99:59"),
/// fast_speed (kFastSpeed).
nlohmann::json limits_document();

/// What kind of failure a command met, for programs that act on it (the
/// panel's advice, an automation's retry). Never decided from message text
/// above the device layer.
enum class Failure : uint8_t {
  invalid,      ///< the command's values or shape (nothing sent; or exception 01/02/03)
  fault,        ///< exception 04: the machine shows a fault
  masked,       ///< exception 04: Modbus control is masked (control mask bit 1)
  wrong_state,  ///< exception 04: not possible in this state (nothing to pause, ...)
  refused,      ///< another refusal (exception 04 of unknown cause, another device)
  no_answer,    ///< no valid answer: timeout, CRC, the port
  busy,         ///< the machine (exception 06) or the program has too much waiting
};
/// "invalid", "fault", "masked", "wrong_state", "refused", "no_answer", "busy".
std::string_view failure_code(Failure f) noexcept;
Failure classify_failure(const rtukit::Status& e) noexcept;
/// What the swimmer does about it, one sentence; never empty.
std::string_view failure_advice(Failure f) noexcept;
/// Puts a failed command's "ok": false, "error" (one line: "Modbus exception
/// 04 (server device failure): the machine shows a fault (voltage)" or the
/// rule's text), "code" (failure_code) and "advice" into `result`.
void describe_failure(const rtukit::Status& e, nlohmann::json& result);
/// The same for a program's own refusal when too many commands wait.
void describe_busy(std::string_view why, nlohmann::json& result);

// ---- the identity ----

/// Is the slave at `unit` an Inverjet? Its motor pole count (holding 0x0004)
/// is fixed (D-7: 5, the only value a write may carry), so an Inverjet always
/// reads that; another value, or an exception for a register every Inverjet
/// has, is another device: refused, "not an Inverjet: its motor pole count
/// (holding 0x0004) reads 0 where an Inverjet's always reads 5". No answer,
/// or the port, comes back as the Error it is. Nothing is written.
rtukit::Status identify(Master& master, UnitId unit);

/// Why the machine answered a Modbus exception, as people read it: the
/// client's reason (04 has three causes: control masked, the fault screen,
/// nothing to pause), else what 02 and 03 mean on this machine ("a reserved
/// register", "a value out of range"); empty when nothing more is known.
std::string exception_reason(const rtukit::Status& e);

// ---- the verbs ----

/// A start, as every front-end asks for it (`run_command`'s "start", the
/// CLI's `start`).
enum class StartMode : uint8_t { free, timer, plan };
struct StartRequest {
  StartMode mode = StartMode::free;
  /// free: nullopt = the speed and time in the machine's memory; timer:
  /// required; plan: none (the plan sets its speed).
  std::optional<uint16_t> speed;
  uint16_t duration_s = 0;  ///< timer: within timer_range()
  unsigned plan = 0;        ///< plan: 1..kPlanCount
  uint16_t from_s = 0;      ///< plan: within from_range()
  bool remember = false;    ///< free at a speed, or timer: start after 3 s and save as the mode's memory
};
/// The durations a start takes, in seconds: a timer 1..99:59 (the timer
/// row's range, without 0), a plan's starting point 0..99:59.
profile::Range timer_range() noexcept;
profile::Range from_range() noexcept;
/// The rules of a start: a timer needs a speed, a plan takes no speed and
/// no remember, the durations and the plan within their ranges.
/// invalid_argument naming the rule.
rtukit::Status check_start(const StartRequest& r);
/// check_start, then the client's call for the mode. invalid_argument also
/// when a plan has nothing to run from `from_s` (Client::start_plan).
rtukit::Status start(Client& client, const StartRequest& r);
/// What the start does, in words: "free mode (speed and time from memory)",
/// "free mode at 60 %", "timer mode, 30:00 at 80 %", "plan P1 from 12:00".
std::string start_text(const StartRequest& r);

/// A start's options as a command line gives them (`rtukit inverjet start
/// --free | --timer D | --plan N, --speed, --from, --remember`): the rules
/// between them, before any value is read: exactly one mode ("choose one of
/// --free, --timer DURATION, --plan N"), no speed or remember with a plan,
/// --from only with a plan, a timer with a speed. invalid_argument.
struct StartOptions {
  bool free = false;
  bool timer = false, plan = false, speed = false, from = false;
  bool remember = false;
};
rtukit::Status check_start_options(const StartOptions& o);
/// A run duration from text ("30:00", "30m", "90s": profile::parse_duration)
/// within `range`; refusals name `what` and the text ("timer 100m (6000 s)
/// is out of range 1..5999 s (99:59)").
Outcome<uint16_t> parse_run_duration(std::string_view text, std::string_view what, profile::Range range);

// ---- the settings ----

/// How a front-end reads a whole number from text, with its own words for a
/// refusal (the CLI's parse_number): the number, or invalid_argument.
using ReadNumber =
    std::function<Outcome<int64_t>(std::string_view text, std::string_view what, int64_t min, int64_t max)>;

/// A setting to write, by key.
struct ConfigChange {
  std::string_view key;  ///< "address", "baud", "mask", "pairing"
  const Row* row;        ///< the register written
  int64_t raw;           ///< its raw value (for the baud rate: the rate's code)
  uint32_t value;        ///< what was asked: the address, the rate in bit/s, the mask, the pairing mode
};
/// `key` at `text`, checked before anything is sent: address (within the
/// address row's unit range), baud (one of the machine's rates), mask (the
/// control mask bits), pairing (the row's value names or numbers).
/// invalid_argument: "config fly: expected show, address, baud, mask or
/// pairing", "baud 115200: the Inverjet runs at 1200, 2400, 4800, 9600 or
/// 19200", or `read`'s refusal.
Outcome<ConfigChange> parse_config(std::string_view key, std::string_view text, const ReadNumber& read);
/// Writes it: Client::set_address, set_baud, set_control_mask or set_pairing.
rtukit::Status write_config(Client& client, const ConfigChange& c);

/// Runs one command from a JSON object (the panel's message, or an MQTT
/// payload the bridge accepted; other fields such as "ts", "id", "op" are
/// ignored):
///   start {"mode": "free", "speed"?: 0..100}      (no speed: the machine's remembered one)
///   start {"mode": "timer", "speed": 0..100, "duration": "30:00" | "30m" | "90s"}
///   start {"mode": "plan", "plan": 1..4, "from"?: duration}
///   pause {}, resume {}, stop {}
///   speed {"speed": 0..100}
///   plan  {"plan": 1..4, "segments": [{"speed": 0..100, "end": duration}, ...]}
/// Numbers are JSON integers, durations JSON strings (profile::parse_duration:
/// a bare number has no unit and is refused). The ranges are the rows'.
/// Never applied halfway. Errors: invalid_argument with the rule, or the
/// machine's answer (Modbus exception with its reason), timeouts.
rtukit::Status run_command(Client& client, std::string_view name, const nlohmann::json& body,
                           nlohmann::json& result);

/// A command's documented body with a "ts", as an example for refusals and
/// the docs; empty for an unknown command.
std::string command_example(std::string_view name);

// ---- the verb table ----

/// The Inverjet's verbs as a command line takes them (profile/verb.hpp):
/// status, start, pause, resume, stop, speed, plan show|set|clear, config;
/// the help's ranges, limits and value names come from the rows.
const std::vector<profile::Verb>& verb_table();
/// Runs one: its arguments checked first (invalid_argument, nothing opened),
/// then the machine identified (refused: another device), then the verb
/// (start, run_command, the plan and config calls). profile::RunVerb.
Outcome<profile::VerbResult> run_verb(const profile::Verb& verb, const profile::VerbArgs& args,
                                      profile::VerbContext& context);

}  // namespace rtukit::inverjet
