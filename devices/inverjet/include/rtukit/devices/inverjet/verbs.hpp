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

#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/io/status.hpp"

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

/// The flat state document (docs/inverjet.md, "MQTT"): mode ("free",
/// "timer", "plan N"), state by name, running, speed, time, remaining_s or
/// elapsed_s (both null when the time's meaning is unknown), faults by name,
/// temperatures, current, rpm, bus voltage, versions.
nlohmann::json state_document(const MachineStatus& s, Family remembered = Family::none);

// ---- the verbs ----

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

}  // namespace rtukit::inverjet
