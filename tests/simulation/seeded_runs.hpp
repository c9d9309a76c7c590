// What every deterministic simulation's test does with its runs, once: a
// replay of one seed (RTUKIT_SIM_SEED, RTUKIT_SIM_STEPS, RTUKIT_SIM_FAULTS,
// RTUKIT_SIM_MS), or seeds one after another until a wall-clock budget
// (RTUKIT_SIM_SECONDS) is spent; a failing seed shrunk (the fewest steps
// that still fail, then each kind of fault switched off while it still
// fails) and printed as the one command that replays it.
//
// A simulation provides: Options {seed, duration_ms, max_steps, faults}
// whose Faults has bool members and text(); Result {ok, failure, steps};
// run(Options) and replay_command(Options).
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <initializer_list>
#include <string>

namespace rtukit::test::simulation {

inline uint64_t env(const char* name, uint64_t fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::strtoull(v, nullptr, 10) : fallback;
}

/// A kind of fault: its member of Faults and its name in RTUKIT_SIM_FAULTS.
template <class Faults>
struct Kind {
  bool Faults::*member;
  const char* name;
};

/// The smallest run that still fails.
template <class Options, class Result, class Faults>
Options shrink(Options o, const Result& failed, Result (*run)(const Options&),
               std::initializer_list<Kind<Faults>> kinds) {
  const auto fails = [&](const Options& x) { return !run(x).ok; };
  const auto fewest_steps = [&](Options x, uint64_t hi) {
    uint64_t lo = 1;
    while (lo < hi) {
      const uint64_t mid = lo + (hi - lo) / 2;
      x.max_steps = mid;
      if (fails(x))
        hi = mid;
      else
        lo = mid + 1;
    }
    x.max_steps = hi;
    return x;
  };
  o = fewest_steps(o, failed.steps + 1);
  for (const Kind<Faults>& kind : kinds) {
    if (!(o.faults.*kind.member)) continue;
    Options without = o;
    without.faults.*kind.member = false;
    without.max_steps = 0;
    if (const Result r = run(without); !r.ok) o = fewest_steps(without, r.steps + 1);
  }
  return o;
}

/// The test's body. `describe(result)` says what one run did (counts);
/// `add(result)` adds a run to the totals the caller keeps; it returns when
/// the budget is spent or a seed failed (a GoogleTest failure, with its replay).
/// Returns the number of seeds run (0 for a replay).
template <class Options, class Result, class Faults>
uint64_t seeded_runs(Result (*run)(const Options&), std::string (*replay)(const Options&),
                     std::initializer_list<Kind<Faults>> kinds, uint64_t default_ms, uint64_t default_seconds,
                     const std::function<std::string(const Result&)>& describe,
                     const std::function<void(const Result&)>& add) {
  if (const uint64_t seed = env("RTUKIT_SIM_SEED", 0)) {  // a replay
    Options o{.seed = seed, .duration_ms = env("RTUKIT_SIM_MS", default_ms), .max_steps = env("RTUKIT_SIM_STEPS", 0)};
    if (const char* f = std::getenv("RTUKIT_SIM_FAULTS")) {
      const std::string text = f;
      for (const Kind<Faults>& kind : kinds) o.faults.*kind.member = text.find(kind.name) != std::string::npos;
    }
    const Result r = run(o);
    std::printf("seed %llu: %s: %s\n", static_cast<unsigned long long>(seed), describe(r).c_str(),
                r.ok ? "ok" : r.failure.c_str());
    EXPECT_TRUE(r.ok) << r.failure;
    return 0;
  }
  const auto budget = std::chrono::seconds(env("RTUKIT_SIM_SECONDS", default_seconds));
  const uint64_t first = env("RTUKIT_SIM_FIRST_SEED", 1);
  const auto start = std::chrono::steady_clock::now();
  uint64_t seeds = 0;
  for (uint64_t seed = first; std::chrono::steady_clock::now() - start < budget; ++seed) {
    const Options o{.seed = seed};
    const Result r = run(o);
    ++seeds;
    add(r);
    if (!r.ok) {
      const Options small = shrink(o, r, run, kinds);
      const Result again = run(small);
      ADD_FAILURE() << "seed " << seed << ": " << r.failure << "\nshrunk to " << small.max_steps
                    << " steps, faults " << small.faults.text() << ": " << again.failure
                    << "\nreplay: " << replay(small);
      break;
    }
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%llu seeds (%llu..%llu), %.0f s of virtual time in %.1f s\n", static_cast<unsigned long long>(seeds),
              static_cast<unsigned long long>(first), static_cast<unsigned long long>(first + seeds - 1),
              static_cast<double>(seeds * default_ms) / 1000.0, s);
  ::testing::Test::RecordProperty("seeds", std::to_string(seeds));
  return seeds;
}

}  // namespace rtukit::test::simulation
