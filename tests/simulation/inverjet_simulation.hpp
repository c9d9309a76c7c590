// The Inverjet under deterministic simulation: one seed decides a whole run.
// The real typed client (inverjet::Client) drives the real machine model
// (inverjet::Machine) through the real master and slave engine, on virtual
// time (ManualClock) over a link that loses, corrupts and delays frames and
// goes dead for a while; the machine meets faults (injected bits, an
// overheated MOSFET, a mains dip) and power cuts. An integrator's program
// starts free, timer and plan runs, pauses, resumes, stops, changes the
// speed and writes plans, as pool automation does.
//
// After every exchange and every step of time the invariants are checked on
// the machine itself (docs/reliability.md, "Deterministic simulation"):
//   - the machine never starts by itself: it goes from not running to
//     running only inside an accepted write of its control registers (never
//     after a fault clears, a power-on, a pause, or as time passes);
//   - a timer never counts below 0 or up, and no time passes 99:59;
//   - a plan ends where it was written: a training run ends exactly at its
//     last segment's end, never runs a segment past the plan's length;
//   - an acknowledged stop leaves the machine not running, and an
//     acknowledged plan is stored as written.
// As FoundationDB's simulation and TigerBeetle's VOPR: everything random
// comes from the seed, so a failing seed replays exactly.
#pragma once

#include <cstdint>
#include <string>

namespace rtukit::inverjet::simulation {

/// The kinds of trouble a run may contain; a failing run is shrunk by
/// switching kinds off while it still fails.
struct Faults {
  bool frames = true;    ///< lost requests, lost, corrupted and late answers
  bool outages = true;   ///< the line dead for a while
  bool power = true;     ///< power cuts (the machine restarts from its flash)
  bool machine = true;   ///< fault bits, overheating, mains dips
  std::string text() const;
};

struct RunOptions {
  uint64_t seed = 1;
  /// Virtual time simulated.
  uint64_t duration_ms = 1'800'000;
  /// Stop after this many requests (shrinking); 0: no limit.
  uint64_t max_steps = 0;
  Faults faults;
};

struct RunResult {
  bool ok = true;
  std::string failure;        ///< the invariant broken, with the virtual time and the last operations
  uint64_t steps = 0;         ///< requests the master sent
  uint64_t commands = 0;      ///< client operations tried
  uint64_t starts = 0;        ///< runs the machine started
  uint64_t faults_injected = 0;
};

/// One run, deterministic in `options`.
RunResult run(const RunOptions& options);

/// The command that replays a run: "RTUKIT_SIM_SEED=... inverjet_simulation_tests".
std::string replay_command(const RunOptions& options);

}  // namespace rtukit::inverjet::simulation
