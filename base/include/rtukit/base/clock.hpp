// rtukit base: the one time type and the one place that reads the time.
//
// Everything below a program's main() reads the time through a DriverClock
// it is given: a Master's deadlines, a server's turnaround, a simulator's
// device time, a scheduler's next poll, a rate limiter, a pairing code's
// lifetime. Production passes SteadyClock::instance(); tests pass a
// ManualClock, so a 1-second timeout, a 30-day expiry or a one-touch stand
// take no real time at all. The lint test `Lint.OneClock` fails on a
// `::now()` anywhere else in the library code. Pure rules (a session's
// leases, a pairing window, a token bucket) spell their time `TimePoint`.
//
// The transports (io) stamp received characters with io::now_us()
// (rtukit/io/now.hpp): that is the OS's time of arrival, which the RTU
// framer's silences are measured in.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

namespace rtukit {

/// The monotonic clock of the transports and of every deadline.
using Clock = std::chrono::steady_clock;
/// A moment on it: what every deadline, lease and expiry is.
using TimePoint = Clock::time_point;
/// Calendar time: log stamps, "no contact since hh:mm:ss", stored expiries.
using WallClock = std::chrono::system_clock;

/// The injectable clock: a monotonic time for deadlines and a calendar time
/// for what people read and what is stored across restarts.
class DriverClock {
 public:
  virtual ~DriverClock() = default;
  /// Monotonic time, for deadlines and intervals.
  virtual Clock::time_point now() const = 0;
  /// Calendar time. Moves with now() on a ManualClock.
  virtual WallClock::time_point wall() const = 0;
  /// Returns at or after `t` (at once when `t` has passed).
  virtual void sleep_until(Clock::time_point t) = 0;
  void sleep_for(std::chrono::microseconds d) { sleep_until(now() + d); }
  /// Whole seconds since the Unix epoch on the calendar clock.
  int64_t unix_seconds() const {
    return std::chrono::duration_cast<std::chrono::seconds>(wall().time_since_epoch()).count();
  }
};

/// The real clocks.
class SteadyClock final : public DriverClock {
 public:
  Clock::time_point now() const override { return Clock::now(); }
  WallClock::time_point wall() const override { return WallClock::now(); }
  void sleep_until(Clock::time_point t) override { std::this_thread::sleep_until(t); }
  /// The process-wide instance (what everything uses unless told otherwise).
  static SteadyClock& instance() {
    static SteadyClock clock;
    return clock;
  }
};

/// Virtual time for tests: sleeping moves the clock instead of waiting.
/// Thread-safe; starts at an arbitrary fixed point, and its calendar time at
/// 2026-01-01T00:00:00Z (or `wall_start`). Give it to what schedules (a
/// model's device time, a poll schedule, leases, expiries) or to a Master on
/// a MemoryLink; a Master on a real port waits for real bytes, so its
/// deadlines need the real clock.
class ManualClock final : public DriverClock {
 public:
  ManualClock() = default;
  explicit ManualClock(WallClock::time_point wall_start)
      : wall_start_(std::chrono::duration_cast<std::chrono::microseconds>(wall_start.time_since_epoch())) {}
  Clock::time_point now() const override { return Clock::time_point(Clock::duration(now_.load())); }
  WallClock::time_point wall() const override {
    return WallClock::time_point(std::chrono::duration_cast<WallClock::duration>(
        wall_start_ + std::chrono::duration_cast<std::chrono::microseconds>(now() - start())));
  }
  void sleep_until(Clock::time_point t) override {
    auto want = t.time_since_epoch().count();
    auto cur = now_.load();
    while (cur < want && !now_.compare_exchange_weak(cur, want)) {
    }
  }
  void advance(std::chrono::microseconds d) { sleep_until(now() + d); }

 private:
  static Clock::time_point start() {
    return Clock::time_point(std::chrono::duration_cast<Clock::duration>(std::chrono::hours(1)));
  }
  std::atomic<Clock::rep> now_{start().time_since_epoch().count()};
  std::chrono::microseconds wall_start_{std::chrono::seconds(1'767'225'600)};  // 2026-01-01
};

/// The clock to use: `clock` when given, else the real one.
inline DriverClock& clock_or_steady(DriverClock* clock) {
  return clock ? *clock : SteadyClock::instance();
}

}  // namespace rtukit
