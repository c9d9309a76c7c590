// The Rehand 6600's host under deterministic simulation: one seed decides a
// whole run. The real HostCore (HostLogic + Session), the real chair model
// and the real message parsers (the web page's JSON, the Bluetooth bytes)
// run on virtual time over a link that loses, corrupts and delays frames,
// drops out, restarts the controller; a display and phones press, renew,
// release, lapse, vanish, STOP and lift it; the person in the chair uses the
// joystick and the buttons; the chair meets obstacles, chargers and faults.
// After every step the invariants of the safety rules are checked
// (docs/rehand6600.md, "How the host writes"; docs/reliability.md,
// "Deterministic simulation"). As FoundationDB's simulation and
// TigerBeetle's VOPR do: everything random comes from the seed, nothing
// from the machine, so a failing seed replays exactly.
#pragma once

#include <cstdint>
#include <string>

namespace rtukit::rehand6600::simulation {

/// What kinds of trouble a run may contain: a failing run is shrunk by
/// switching kinds off while it still fails.
struct Faults {
  bool frames = true;    ///< lost, corrupted, late frames (each request, its answer)
  bool outages = true;   ///< the line dead (both ways, or answers only) for a while
  bool restarts = true;  ///< the controller restarts (power cycle)
  bool stalls = true;    ///< the host's bus thread stalls
  bool chair = true;     ///< joystick, buttons, obstacles, charger, clutch, faults
  bool clients = true;   ///< phones and the display misbehave (lapses, vanishing, late renewals)
  std::string text() const;
};

struct RunOptions {
  uint64_t seed = 1;
  /// Virtual time simulated.
  uint64_t duration_ms = 120'000;
  /// Stop after this many host requests (shrinking); 0: no limit.
  uint64_t max_steps = 0;
  Faults faults;
};

struct RunResult {
  bool ok = true;
  std::string failure;   ///< the invariant broken, with the virtual time and what led there
  uint64_t steps = 0;    ///< host requests executed
  uint64_t presses = 0;  ///< presses the session accepted
  uint64_t stops = 0;    ///< emergency stops (0x006A) started
  uint64_t faults_injected = 0;
};

/// One run, deterministic in `options`.
RunResult run(const RunOptions& options);

/// The command that replays a run: "RTUKIT_SIM_SEED=... RTUKIT_SIM_STEPS=... rehand_simulation_tests".
std::string replay_command(const RunOptions& options);

}  // namespace rtukit::rehand6600::simulation
