// The Rehand 6600 host under deterministic simulation (rehand_simulation.hpp):
// seeds run one after another for RTUKIT_SIM_SECONDS (60 by default; the
// long runs in docs/reliability.md set more); a failing seed is shrunk (fewer
// steps, fewer kinds of fault while it still fails) and printed as one
// command that replays it; RTUKIT_SIM_SEED (with RTUKIT_SIM_STEPS,
// RTUKIT_SIM_FAULTS, RTUKIT_SIM_MS) replays one run (seeded_runs.hpp).
#include "rehand_simulation.hpp"

#include <fmt/core.h>
#include <gtest/gtest.h>

#include "seeded_runs.hpp"

namespace rtukit::rehand6600::simulation {
namespace {

TEST(RehandSimulation, SeededRunsKeepEveryInvariant) {
  uint64_t steps = 0, presses = 0, stops = 0, faults = 0;
  const uint64_t seeds = test::simulation::seeded_runs<RunOptions, RunResult, Faults>(
      run, replay_command,
      {{&Faults::frames, "frames"}, {&Faults::outages, "outages"}, {&Faults::restarts, "restarts"},
       {&Faults::stalls, "stalls"}, {&Faults::chair, "chair"}, {&Faults::clients, "clients"}},
      RunOptions{}.duration_ms, 60,
      [](const RunResult& r) {
        return fmt::format("{} steps, {} presses, {} stops, {} faults", r.steps, r.presses, r.stops,
                           r.faults_injected);
      },
      [&](const RunResult& r) {
        steps += r.steps;
        presses += r.presses;
        stops += r.stops;
        faults += r.faults_injected;
      });
  if (seeds == 0) return;  // a replay
  fmt::print("{} host requests, {} presses, {} emergency stops, {} faults injected\n", steps, presses, stops, faults);
  RecordProperty("steps", std::to_string(steps));
}

}  // namespace
}  // namespace rtukit::rehand6600::simulation
