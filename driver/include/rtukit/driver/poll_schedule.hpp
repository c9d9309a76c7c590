// rtukit driver: when a program polls a device next. Pure: time is passed in.
//
// One schedule and one back-off for every program that keeps a device's
// state fresh (the MQTT bridge, the pool panel): a poll every `period`,
// counted from the start of the last one; an extra poll on request (to show
// a command's effect) that leaves the schedule where it was (unless it is the
// first answer after failures: the period resumes from it); after a failed
// poll, the next one waits period x 2^failures, at most `max_backoff`, so an
// absent device costs the others one response timeout per back-off at most.
// It also keeps the figures the programs report: polls, late polls (a gap
// more than 1.5 periods between two polls of a device that answers) and the
// worst gap.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>

#include "rtukit/base/clock.hpp"

namespace rtukit {

struct PollPolicy {
  Clock::duration period = std::chrono::milliseconds(500);
  /// Consecutive failed polls after which the device counts as offline.
  unsigned failures_to_offline = 2;
  Clock::duration max_backoff = std::chrono::seconds(5);

  /// The policy for `hz` polls a second (> 0).
  static PollPolicy at_hz(double hz) {
    PollPolicy p;
    p.period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / hz));
    return p;
  }
};

class PollSchedule {
 public:
  using TimePoint = rtukit::TimePoint;

  /// The first poll is due at `start`.
  explicit PollSchedule(PollPolicy policy, TimePoint start) noexcept : policy_(policy), next_(start) {}

  /// Whether a poll is due at `now` (scheduled, or asked for with poll_soon()).
  bool due(TimePoint now) const noexcept { return extra_ || now >= next_; }
  /// When the next scheduled poll is due (a wait ends here at the latest).
  TimePoint next() const noexcept { return next_; }
  /// An extra poll at the next chance; the schedule stays where it was.
  void poll_soon() noexcept { extra_ = true; }

  /// Records a poll that started at `started` and answered (`ok`) or not.
  void polled(TimePoint started, bool ok) noexcept {
    const bool scheduled = started >= next_;
    const bool recovered = failures_ > 0;  // back on the period, not the back-off
    extra_ = false;
    if (ok && failures_ == 0 && polls_ > 0) {
      const auto gap = started - last_started_;
      worst_gap_ = std::max(worst_gap_, gap);
      if (gap > policy_.period + policy_.period / 2) ++late_polls_;
    }
    ++polls_;
    last_started_ = started;
    if (!ok) {
      ++failures_;
      next_ = started + backoff(failures_);
      return;
    }
    failures_ = 0;
    if (scheduled || recovered) next_ = started + policy_.period;
  }

  /// The wait after `failures` failed polls in a row: period x 2^failures,
  /// at most max_backoff.
  Clock::duration backoff(unsigned failures) const noexcept {
    const unsigned doublings = std::min(failures, 16u);
    return std::min<Clock::duration>(policy_.period * (int64_t{1} << doublings), policy_.max_backoff);
  }

  unsigned failures() const noexcept { return failures_; }
  bool offline() const noexcept { return failures_ >= policy_.failures_to_offline; }
  uint64_t polls() const noexcept { return polls_; }
  uint64_t late_polls() const noexcept { return late_polls_; }
  Clock::duration worst_gap() const noexcept { return worst_gap_; }
  const PollPolicy& policy() const noexcept { return policy_; }

 private:
  PollPolicy policy_;
  TimePoint next_;
  TimePoint last_started_{};
  bool extra_ = false;
  unsigned failures_ = 0;
  uint64_t polls_ = 0, late_polls_ = 0;
  Clock::duration worst_gap_{};
};

}  // namespace rtukit
