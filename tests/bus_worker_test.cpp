// The runtime every program shares (driver/bus_worker.hpp): steps at the
// times the logic asks for, jobs in order before the next step, a flood cut
// at the limit, and a stop that ends the thread. Without the thread on a
// ManualClock (no real time), and with it on the real clock where the test
// waits for events, never for a duration.
#include "rtukit/driver/bus_worker.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <vector>

namespace rtukit {
namespace {

using namespace std::chrono_literals;

TEST(BusWorker, RunOnce_RunsTheJobsInOrderThenOneStepAtTheClocksNow) {
  ManualClock clock;
  std::vector<std::string> log;
  BusWorker::TimePoint seen{};
  BusWorker w(
      [&](BusWorker::TimePoint now) {
        log.push_back("step");
        seen = now;
        return now + 500ms;
      },
      {.clock = &clock});
  ASSERT_TRUE(w.post([&] { log.push_back("a"); }));
  ASSERT_TRUE(w.post([&] { log.push_back("b"); }));
  EXPECT_EQ(w.pending(), 2u);
  clock.advance(3s);
  const auto next = w.run_once();
  EXPECT_EQ(log, (std::vector<std::string>{"a", "b", "step"}));
  EXPECT_EQ(seen, clock.now());
  EXPECT_EQ(next, clock.now() + 500ms);
  EXPECT_EQ(w.pending(), 0u);
}

TEST(BusWorker, AFloodIsCutAtTheLimit_NotQueued) {
  BusWorker w([](BusWorker::TimePoint now) { return now; }, {.job_limit = 3});
  int ran = 0;
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(w.post([&] { ++ran; }));
  EXPECT_FALSE(w.post([&] { ++ran; }));
  w.run_once();
  EXPECT_EQ(ran, 3);
  EXPECT_TRUE(w.post([&] { ++ran; }));  // room again once they ran
}

TEST(BusWorker, AfterStop_NothingIsTakenAndWaitingJobsAreDropped_UntilStartedAgain) {
  BusWorker w([](BusWorker::TimePoint now) { return now + 1h; });
  std::atomic<int> ran{0};
  EXPECT_TRUE(w.post([&] { ++ran; }));
  w.stop();
  EXPECT_TRUE(w.stopped());
  EXPECT_FALSE(w.post([&] { ++ran; }));
  w.stop();  // idempotent
  EXPECT_EQ(ran, 0);
  w.start();  // a new thread: takes jobs again
  EXPECT_FALSE(w.stopped());
  std::promise<void> done;
  ASSERT_TRUE(w.post([&] {
    ++ran;
    done.set_value();
  }));
  ASSERT_EQ(done.get_future().wait_for(60s), std::future_status::ready);
  w.stop();
  EXPECT_EQ(ran, 1);
}

TEST(BusWorker, OnItsThread_APostedJobRunsWithoutWaitingForTheNextStep) {
  std::atomic<int> steps{0};
  // The logic is due again in an hour: only the job can make it run sooner.
  BusWorker w(
      [&](BusWorker::TimePoint now) {
        ++steps;
        return now + 1h;
      },
      {.longest_wait = std::chrono::milliseconds(3'600'000)});
  w.start();
  std::promise<std::thread::id> ran;
  ASSERT_TRUE(w.post([&] { ran.set_value(std::this_thread::get_id()); }));
  auto f = ran.get_future();
  ASSERT_EQ(f.wait_for(60s), std::future_status::ready);  // a deadline on the event
  EXPECT_NE(f.get(), std::this_thread::get_id());         // on the worker's thread
  w.stop();
}

TEST(BusWorker, OnItsThread_WakeRunsAStepAndStopJoins) {
  std::mutex m;
  std::condition_variable cv;
  int steps = 0;
  BusWorker w(
      [&](BusWorker::TimePoint now) {
        {
          std::lock_guard lock(m);
          ++steps;
        }
        cv.notify_all();
        return now + 1h;
      },
      {.longest_wait = std::chrono::milliseconds(3'600'000)});
  w.start();
  std::unique_lock lock(m);
  ASSERT_TRUE(cv.wait_for(lock, 60s, [&] { return steps >= 1; }));  // the first step at start
  const int before = steps;
  lock.unlock();
  w.wake();
  lock.lock();
  ASSERT_TRUE(cv.wait_for(lock, 60s, [&] { return steps > before; }));
  lock.unlock();
  w.stop();  // returns: the thread ended though its step was due in an hour
  EXPECT_TRUE(w.stopped());
}

}  // namespace
}  // namespace rtukit
