// rtukit driver: the runtime every program shares.
//
// A program (the Rehand host daemon, the MQTT bridge, the pool panel) is a
// bus worker running a logic object, plus front-end listeners (a web server,
// MQTT callbacks) that hand it work. The worker is the only thread that talks
// on the bus: a listener never waits for a device, and a slow or flooding
// client cannot hold the bus.
//
// The worker calls the program's `step(now)`: do what is due at `now` (a
// poll, a queued write, a state to publish) and say when the next thing is
// due. It sleeps until then, or until a listener calls `wake()` or `post()`.
// Jobs posted run on the worker's thread, in order, before the next step.
//
// Tests drive the same logic without a thread: `run_once()` runs the posted
// jobs and one step at the clock's now, so a program's logic is tested on a
// ManualClock and a MemoryLink, step by step, in no real time.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>

#include "rtukit/base/clock.hpp"

namespace rtukit {

class BusWorker {
 public:
  using TimePoint = rtukit::TimePoint;
  /// One step of the program's logic, on the worker's thread, at `now` (the
  /// clock's). Returns when it is next due; a time not after `now` means
  /// "again at once" (more work is waiting).
  using Step = std::function<TimePoint(TimePoint now)>;

  struct Options {
    /// The time steps are given and waits are measured on; nullptr: the real
    /// clock. A ManualClock does not advance while the thread waits: with
    /// one, drive the worker with run_once().
    DriverClock* clock = nullptr;
    /// Jobs that may wait; post() refuses more (a flood is cut, not queued).
    size_t job_limit = 256;
    /// The longest the thread sleeps between steps, even when nothing is due
    /// (a bound on how late a step sees a change nobody woke it for).
    std::chrono::milliseconds longest_wait{1000};
  };

  explicit BusWorker(Step step) : BusWorker(std::move(step), Options{}) {}
  BusWorker(Step step, Options options);
  /// Stops the thread (stop()).
  ~BusWorker();
  BusWorker(const BusWorker&) = delete;
  BusWorker& operator=(const BusWorker&) = delete;

  /// Starts the worker's thread; does nothing while it runs. After stop()
  /// it starts a new one (with no job waiting).
  void start();

  /// Runs `job` on the worker's thread before its next step (in the order
  /// posted) and wakes it. Thread-safe. Returns false, and drops the job,
  /// when `job_limit` jobs are waiting or the worker has stopped.
  bool post(std::function<void()> job);

  /// Makes the worker run its step now (a listener queued work of its own).
  /// Thread-safe; cheap.
  void wake();

  /// Ends the thread after the job or step it is in, and joins it. Jobs not
  /// yet run are dropped, and post() refuses until the next start().
  /// Idempotent. Not from the worker's own thread.
  void stop();

  /// Without the thread: runs the waiting jobs, then one step at the clock's
  /// now; returns when the next step is due. For tests, and for a caller
  /// that runs its own loop. Precondition: the thread is not running.
  TimePoint run_once();

  /// Jobs waiting.
  size_t pending() const;
  bool stopped() const;
  /// The thread runs (started, not stopped).
  bool running() const;
  DriverClock& clock() const noexcept { return clock_; }

 private:
  void run();
  std::deque<std::function<void()>> take_jobs();

  Step step_;
  Options options_;
  DriverClock& clock_;
  std::mutex lifecycle_;      ///< start() and stop(): the thread handle is theirs
  mutable std::mutex mutex_;  ///< the rest
  std::condition_variable cv_;
  std::deque<std::function<void()>> jobs_;
  bool woken_ = false;
  bool stopping_ = false;
  bool running_ = false;
  std::thread thread_;
};

}  // namespace rtukit
