// rtukit driver: the clock a master waits on, injectable.
//
// A Master reads the time for its deadlines, the inter-request delay and the
// broadcast turnaround, and waits on it. Production uses the steady clock;
// tests pass a ManualClock, so a retry after a 1-second timeout, a 500-ms
// inter-request gap or a 100-ms turnaround take no real time at all.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "rtukit/io/link.hpp"

namespace rtukit {

class DriverClock {
 public:
  virtual ~DriverClock() = default;
  virtual io::Clock::time_point now() const = 0;
  /// Returns at or after `t` (at once when `t` has passed).
  virtual void sleep_until(io::Clock::time_point t) = 0;
  void sleep_for(std::chrono::microseconds d) { sleep_until(now() + d); }
};

/// The real, steady clock.
class SteadyClock final : public DriverClock {
 public:
  io::Clock::time_point now() const override { return io::Clock::now(); }
  void sleep_until(io::Clock::time_point t) override { std::this_thread::sleep_until(t); }
  /// The process-wide instance (what a Master uses unless told otherwise).
  static SteadyClock& instance() {
    static SteadyClock clock;
    return clock;
  }
};

/// Virtual time for tests: sleeping moves the clock instead of waiting.
/// Thread-safe; starts at an arbitrary fixed point.
class ManualClock final : public DriverClock {
 public:
  io::Clock::time_point now() const override {
    return io::Clock::time_point(io::Clock::duration(now_.load()));
  }
  void sleep_until(io::Clock::time_point t) override {
    auto want = t.time_since_epoch().count();
    auto cur = now_.load();
    while (cur < want && !now_.compare_exchange_weak(cur, want)) {
    }
  }
  void advance(std::chrono::microseconds d) { sleep_until(now() + d); }

 private:
  std::atomic<io::Clock::rep> now_{
      std::chrono::duration_cast<io::Clock::duration>(std::chrono::hours(1)).count()};
};

}  // namespace rtukit
