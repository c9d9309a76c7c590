// The Inverjet under deterministic simulation (inverjet_simulation.hpp):
// seeds run one after another for RTUKIT_SIM_SECONDS (20 by default here;
// the long runs in docs/reliability.md set more); a failing seed is shrunk
// and printed as the command that replays it (seeded_runs.hpp).
#include "inverjet_simulation.hpp"

#include <fmt/core.h>
#include <gtest/gtest.h>

#include "seeded_runs.hpp"

namespace rtukit::inverjet::simulation {
namespace {

TEST(InverjetSimulation, SeededRunsKeepEveryInvariant) {
  uint64_t steps = 0, commands = 0, starts = 0, faults = 0;
  const uint64_t seeds = test::simulation::seeded_runs<RunOptions, RunResult, Faults>(
      run, replay_command,
      {{&Faults::frames, "frames"}, {&Faults::outages, "outages"}, {&Faults::power, "power"},
       {&Faults::machine, "machine"}},
      RunOptions{}.duration_ms, 20,
      [](const RunResult& r) {
        return fmt::format("{} requests, {} commands, {} starts, {} faults", r.steps, r.commands, r.starts,
                           r.faults_injected);
      },
      [&](const RunResult& r) {
        steps += r.steps;
        commands += r.commands;
        starts += r.starts;
        faults += r.faults_injected;
      });
  if (seeds == 0) return;  // a replay
  // Not vacuous: the runs started the machine and injected faults.
  EXPECT_GT(starts, seeds);
  EXPECT_GT(faults, seeds);
  fmt::print("{} requests, {} client operations, {} starts, {} faults injected\n", steps, commands, starts, faults);
  RecordProperty("steps", std::to_string(steps));
}

}  // namespace
}  // namespace rtukit::inverjet::simulation
