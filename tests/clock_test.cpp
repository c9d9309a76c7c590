// One clock (issue 27): the injectable DriverClock's calendar time, and what
// runs on it: the poll schedule the bridge and the panel share, and a
// simulator's device time. All on a ManualClock: no test here sleeps.
#include "rtukit/base/clock.hpp"

#include <gtest/gtest.h>

#include "rtukit/driver/poll_schedule.hpp"
#include "rtukit/driver/simulation.hpp"

namespace rtukit {
namespace {

using namespace std::chrono_literals;

TEST(ManualClockTest, CalendarTimeMovesWithTheMonotonicTime) {
  ManualClock clock;
  EXPECT_EQ(clock.unix_seconds(), 1'767'225'600);  // 2026-01-01T00:00:00Z
  const auto t0 = clock.now();
  clock.advance(std::chrono::hours(24 * 31));
  EXPECT_EQ(clock.now() - t0, std::chrono::hours(24 * 31));
  EXPECT_EQ(clock.unix_seconds(), 1'767'225'600 + 31 * 86'400);
  clock.sleep_for(1500ms);
  EXPECT_EQ(clock.unix_seconds(), 1'767'225'600 + 31 * 86'400 + 1);
  ManualClock later(WallClock::time_point(std::chrono::seconds(2'000'000'000)));
  EXPECT_EQ(later.unix_seconds(), 2'000'000'000);
}

TEST(ManualClockTest, TheRealClockIsTheDefault) {
  EXPECT_EQ(&clock_or_steady(nullptr), &SteadyClock::instance());
  ManualClock manual;
  EXPECT_EQ(&clock_or_steady(&manual), &manual);
}

TEST(DeviceClockTest, ScalesTheClockItIsGiven) {
  ManualClock clock;
  DeviceClock device(60, clock);  // a device minute per second
  EXPECT_EQ(device.now_ms(), 0u);
  clock.advance(1s);
  EXPECT_EQ(device.now_ms(), 60'000u);
  clock.advance(2500ms);
  EXPECT_EQ(device.now_ms(), 210'000u);
}

class PollScheduleTest : public ::testing::Test {
 protected:
  ManualClock clock;
  PollSchedule schedule{PollPolicy::at_hz(2), clock.now()};  // every 500 ms
};

TEST_F(PollScheduleTest, EveryPeriodFromTheStartOfThePoll) {
  EXPECT_TRUE(schedule.due(clock.now()));
  const auto t0 = clock.now();
  schedule.polled(t0, true);
  EXPECT_FALSE(schedule.due(t0 + 499ms));
  EXPECT_TRUE(schedule.due(t0 + 500ms));
  EXPECT_EQ(schedule.next(), t0 + 500ms);
  schedule.polled(t0 + 520ms, true);  // 20 ms late: counted from its start
  EXPECT_EQ(schedule.next(), t0 + 1020ms);
  EXPECT_EQ(schedule.polls(), 2u);
  EXPECT_EQ(schedule.late_polls(), 0u);
  EXPECT_EQ(schedule.worst_gap(), 520ms);
}

TEST_F(PollScheduleTest, AnExtraPollLeavesTheScheduleWhereItWas) {
  const auto t0 = clock.now();
  schedule.polled(t0, true);
  schedule.poll_soon();
  EXPECT_TRUE(schedule.due(t0 + 100ms));
  schedule.polled(t0 + 100ms, true);
  EXPECT_FALSE(schedule.due(t0 + 200ms));
  EXPECT_EQ(schedule.next(), t0 + 500ms);
}

TEST_F(PollScheduleTest, BackOffDoublesToItsCeiling_OneAnswerEndsIt) {
  auto t = clock.now();
  schedule.polled(t, false);
  EXPECT_FALSE(schedule.offline());  // one miss is not a lost machine
  EXPECT_EQ(schedule.next() - t, 1000ms);
  std::vector<std::chrono::milliseconds> waits;
  for (int i = 0; i < 5; ++i) {
    t = schedule.next();
    schedule.polled(t, false);
    waits.push_back(std::chrono::duration_cast<std::chrono::milliseconds>(schedule.next() - t));
  }
  EXPECT_TRUE(schedule.offline());
  EXPECT_EQ(waits, (std::vector<std::chrono::milliseconds>{2000ms, 4000ms, 5000ms, 5000ms, 5000ms}));
  t = schedule.next();
  schedule.polled(t, true);
  EXPECT_FALSE(schedule.offline());
  EXPECT_EQ(schedule.failures(), 0u);
  EXPECT_EQ(schedule.next() - t, 500ms);
  EXPECT_EQ(schedule.late_polls(), 0u);  // the gaps of a silent machine are not late polls
}

// A machine back through an extra poll (a command answered) is polled on
// the period again from that answer, not after the rest of its back-off.
TEST_F(PollScheduleTest, AnExtraPollThatAnswersEndsTheBackOff) {
  auto t = clock.now();
  schedule.polled(t, false);
  schedule.polled(schedule.next(), false);
  schedule.polled(schedule.next(), false);
  t = schedule.next() - 3s;  // a command ran in the middle of a 4-s back-off
  schedule.poll_soon();
  ASSERT_TRUE(schedule.due(t));
  schedule.polled(t, true);
  EXPECT_FALSE(schedule.offline());
  EXPECT_EQ(schedule.next(), t + 500ms);
  schedule.polled(t + 500ms, true);
  EXPECT_EQ(schedule.late_polls(), 0u);
}

TEST_F(PollScheduleTest, AGapOfMoreThanOneAndAHalfPeriodsIsALatePoll) {
  const auto t0 = clock.now();
  schedule.polled(t0, true);
  schedule.polled(t0 + 750ms, true);  // exactly 1.5 periods: on time
  schedule.polled(t0 + 1501ms, true);
  EXPECT_EQ(schedule.late_polls(), 1u);
  EXPECT_EQ(schedule.worst_gap(), 751ms);
}

}  // namespace
}  // namespace rtukit
