// The Rehand 6600 host controller's decisions on virtual time: HostLogic is
// sans-IO, so the handshake retry (1 s), "1010 after 3 failed polls", lease
// expiry (300 ms) and recovery are checked to the millisecond without a
// thread, a link or a sleep. (rehand_sim_test.cpp keeps the real-time
// Host against the simulator.)
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "rtukit/devices/rehand6600/host.hpp"

namespace rtukit::rehand6600 {
namespace {

using namespace std::chrono_literals;
using Kind = HostLogic::Request::Kind;

struct Rig {
  HostLogic logic{HostOptions{}};
  HostLogic::TimePoint t{std::chrono::hours(1)};
  std::array<uint16_t, reg::kStatusCount> table1 = [] {
    std::array<uint16_t, reg::kStatusCount> r{};
    r[reg::kDeviceId] = kDeviceId;
    r[reg::kMotion] = 1;
    r[reg::kClutch] = 1;
    return r;
  }();

  // The request due at `t` (fails the test when there is none).
  HostLogic::Request due() {
    auto r = logic.next(t);
    EXPECT_TRUE(r.has_value());
    return r.value_or(HostLogic::Request{Kind::poll});
  }
  void answer(const HostLogic::Request& r, Error e = {}) {
    if (e) return logic.on_result(t, e);
    if (r.kind == Kind::read_device_id) return logic.on_result(t, e, std::span(table1.data(), 1));
    if (r.kind == Kind::poll) return logic.on_result(t, e, table1);
    logic.on_result(t, e);
  }
  void connect() {
    answer(due());  // device ID
    const auto ready = due();
    EXPECT_EQ(ready.kind, Kind::write);
    EXPECT_EQ(ready.address, reg::kHostReady);
    EXPECT_EQ(ready.value, 1);
    answer(ready);
    EXPECT_TRUE(logic.connected());
  }
  // Runs one poll cycle at the next wake-up; returns the writes it made.
  std::vector<HostLogic::Request> cycle(Error poll_error = {}) {
    t = logic.wake_at();
    const auto poll = due();
    EXPECT_EQ(poll.kind, Kind::poll);
    answer(poll, poll_error);
    std::vector<HostLogic::Request> writes;
    while (auto w = logic.next(t)) {
      writes.push_back(*w);
      answer(*w);
    }
    return writes;
  }
  // The writes due now (target changes, one-shots), answered.
  std::vector<HostLogic::Request> flush() {
    std::vector<HostLogic::Request> writes;
    while (auto w = logic.next(t)) {
      if (w->kind == Kind::write) writes.push_back(*w);
      answer(*w);
    }
    return writes;
  }
  bool has(Event::Type type, uint16_t code = 0) {
    for (const Event& e : logic.take_events())
      if (e.type == type && (code == 0 || e.code == code || e.address == code)) return true;
    return false;
  }
};

TEST(RehandHostLogic, HandshakeRetriesEverySecond_WrongDeviceIsRefused) {
  Rig rig;
  auto r = rig.due();
  EXPECT_EQ(r.kind, Kind::read_device_id);
  rig.answer(r, Errc::timeout);
  EXPECT_TRUE(rig.has(Event::Type::error_raised, kMasterCommunicationError));
  EXPECT_EQ(rig.logic.active_error(), kMasterCommunicationError);
  EXPECT_FALSE(rig.logic.next(rig.t + 999ms));  // nothing before the retry time
  rig.t += 1000ms;
  rig.table1[reg::kDeviceId] = 0x69;
  rig.answer(rig.due());
  EXPECT_FALSE(rig.logic.connected());
  EXPECT_EQ(rig.logic.last_failure().code(), Errc::refused);
  EXPECT_EQ(rig.logic.last_failure().reason(), "handshake: device ID 0x69, expected 0x68");
  EXPECT_FALSE(rig.has(Event::Type::error_raised));  // raised once, not again
  rig.t += 1000ms;
  rig.table1[reg::kDeviceId] = kDeviceId;
  rig.connect();
  const auto events = rig.logic.take_events();
  ASSERT_EQ(events.size(), 2U);
  EXPECT_EQ(events[0].type, Event::Type::error_cleared);
  EXPECT_EQ(events[1].type, Event::Type::connected);
  EXPECT_EQ(rig.logic.active_error(), 0);  // the link is up; the first poll tells the controller's own errors
  rig.table1[reg::kErrorCode] = 0x1091;
  rig.cycle();
  EXPECT_EQ(rig.logic.active_error(), 0x1091);
}

TEST(RehandHostLogic, ThreeFailedPollsRaise1010_ThenTheHandshakeRecovers) {
  Rig rig;
  rig.connect();
  rig.cycle();
  (void)rig.logic.take_events();
  rig.cycle(Errc::timeout);
  rig.cycle(Errc::timeout);
  EXPECT_TRUE(rig.logic.connected());  // two failures are a glitch
  EXPECT_FALSE(rig.has(Event::Type::error_raised));
  rig.cycle(Errc::timeout);
  EXPECT_FALSE(rig.logic.connected());
  EXPECT_TRUE(rig.has(Event::Type::error_raised, kMasterCommunicationError));
  EXPECT_EQ(rig.logic.last_failure().reason(), "3 consecutive polls failed (timeout)");
  // Back to the handshake one period later (50 ms at 20 Hz).
  const auto failed_at = rig.t;
  rig.t = rig.logic.wake_at();
  EXPECT_EQ(rig.t - failed_at, 50ms);
  rig.connect();
  EXPECT_TRUE(rig.has(Event::Type::error_cleared, kMasterCommunicationError));
}

// A target (what the session wants held) is written at once, before the
// next poll, then again after every poll; a target set to 0 is written once.
TEST(RehandHostLogic, ATargetIsWrittenAtOnce_ThenAfterEveryPoll_ZeroOnce) {
  Rig rig;
  rig.connect();
  rig.cycle();
  rig.logic.set_target(reg::kSeatLift, 1);
  rig.logic.set_target(reg::kSeatLift, 1);  // unchanged: nothing more
  EXPECT_LT(rig.logic.wake_at(), rig.t + 1ms) << "a change waits for no poll";
  auto now = rig.flush();
  ASSERT_EQ(now.size(), 1U);
  EXPECT_EQ(now[0].address, reg::kSeatLift);
  EXPECT_EQ(now[0].value, 1);
  for (int i = 0; i < 3; ++i) {
    auto writes = rig.cycle();
    ASSERT_EQ(writes.size(), 1U);
    EXPECT_EQ(writes[0].value, 1);
  }
  rig.logic.set_target(reg::kSeatLift, 0);
  now = rig.flush();
  ASSERT_EQ(now.size(), 1U);
  EXPECT_EQ(now[0].value, 0);
  EXPECT_TRUE(rig.cycle().empty());
}

// A release that comes between a poll and its rewrites is not undone by a
// rewrite of the old value (found by the attack test: 0x006A held on).
TEST(RehandHostLogic, ARewriteAfterAPollWritesTheTargetOfNow_NotOfThePoll) {
  Rig rig;
  rig.connect();
  rig.cycle();
  rig.logic.set_target(reg::kSeatLift, 1);
  rig.flush();
  rig.t = rig.logic.wake_at();
  const auto poll = rig.due();
  ASSERT_EQ(poll.kind, Kind::poll);
  rig.answer(poll);                         // the rewrite of seat_lift = 1 is queued now
  rig.logic.set_target(reg::kSeatLift, 0);  // the finger lifts
  const auto writes = rig.flush();
  ASSERT_EQ(writes.size(), 1U) << "the 0, and no stale 1 after it";
  EXPECT_EQ(writes[0].value, 0);
}

// The newest word wins, and target changes go before one-shots.
TEST(RehandHostLogic, AnUnsentChangeIsReplaced_OneShotsWaitBehindTargets_TheQueueIsBounded) {
  Rig rig;
  rig.connect();
  rig.cycle();
  ASSERT_TRUE(rig.logic.enqueue(reg::kLight, 1, 7));
  rig.logic.set_target(reg::kSeatLift, 1);
  rig.logic.set_target(reg::kSeatLift, 0);
  rig.logic.set_target(reg::kAntiPinch, 1);
  const auto writes = rig.flush();
  ASSERT_EQ(writes.size(), 3U);  // seat_lift's 1 never left: only its newest word, 0
  EXPECT_EQ(writes[0].address, reg::kSeatLift);
  EXPECT_EQ(writes[0].value, 0);
  EXPECT_EQ(writes[1].address, reg::kAntiPinch);
  EXPECT_EQ(writes[2].address, reg::kLight);
  const auto results = rig.logic.take_results();
  ASSERT_EQ(results.size(), 1U);
  EXPECT_EQ(results[0].first, 7U);
  EXPECT_TRUE(results[0].second.ok());
  for (size_t i = 0; i < HostLogic::kQueueLimit; ++i) ASSERT_TRUE(rig.logic.enqueue(reg::kLight, 1, 100 + i));
  EXPECT_FALSE(rig.logic.enqueue(reg::kLight, 1, 999)) << "a full queue refuses";
}

TEST(RehandHostLogic, PollEvents_ChangesEdgesAndLocalErrors) {
  Rig rig;
  rig.connect();
  rig.cycle();
  (void)rig.logic.take_events();
  rig.table1[reg::kHornButton] = 1;
  rig.table1[reg::kErrorCode] = 0x10C3;
  rig.cycle();
  const auto events = rig.logic.take_events();
  bool horn = false, raised = false, changed = false;
  for (const Event& e : events) {
    horn = horn || e.type == Event::Type::horn;
    raised = raised ||
             (e.type == Event::Type::error_raised && e.code == 0x10C3 && e.reason == "10C3 Seat lift Error");
    changed =
        changed || (e.type == Event::Type::changed && e.address == reg::kErrorCode && e.value == 0x10C3);
  }
  EXPECT_TRUE(horn);
  EXPECT_TRUE(raised);
  EXPECT_TRUE(changed);
  EXPECT_EQ(rig.logic.active_error(), 0x10C3);
  rig.cycle();  // still pressed: no second horn
  EXPECT_FALSE(rig.has(Event::Type::horn));
}

// D-8 on the host's side: an error clears every target and writes 0 at
// once; the session ends the presses, so nothing is written again.
TEST(RehandHostLogic, AnErrorClearsEveryTarget_AndWritesZero_D8) {
  Rig rig;
  rig.connect();
  rig.cycle();
  rig.logic.set_target(reg::kLegRotate, 1);
  rig.flush();
  rig.table1[reg::kErrorCode] = 0x1093;
  auto writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1u);
  EXPECT_EQ(writes[0].address, reg::kLegRotate);
  EXPECT_EQ(writes[0].value, 0);
  EXPECT_EQ(rig.logic.target(reg::kLegRotate), 0);
  rig.table1[reg::kErrorCode] = 0;
  EXPECT_TRUE(rig.cycle().empty());  // cleared: nothing written, nothing moves
}

TEST(RehandHostLogic, LinkLossClearsEveryTarget_AndFailsQueuedOneShots) {
  Rig rig;
  rig.connect();
  rig.cycle();
  rig.logic.set_target(reg::kPhoneForward, 1);
  rig.flush();
  for (int i = 0; i < 3; ++i) rig.cycle(Errc::timeout);
  EXPECT_EQ(rig.logic.active_error(), kMasterCommunicationError);
  EXPECT_EQ(rig.logic.target(reg::kPhoneForward), 0);
  EXPECT_FALSE(rig.logic.enqueue(reg::kLight, 1, 6)) << "nothing is queued for a link that is down";
}

// A target write that fails (a timeout: the controller may have executed it
// before the answer was lost) says so, and 0 is written after the next
// poll: any doubt about motion, stop.
TEST(RehandHostLogic, AFailedTargetWriteIsReported_AndZeroedAfterTheNextPoll) {
  Rig rig;
  rig.connect();
  rig.cycle();
  rig.logic.set_target(reg::kSeatLift, 1);
  auto w = rig.logic.next(rig.t);
  ASSERT_TRUE(w.has_value());
  rig.logic.on_result(rig.t, Errc::timeout);
  EXPECT_TRUE(rig.has(Event::Type::write_failed, reg::kSeatLift));
  rig.logic.set_target(reg::kSeatLift, 0);  // the session ended the press
  EXPECT_TRUE(rig.flush().size() <= 1u);
  auto writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1u);
  EXPECT_EQ(writes[0].address, reg::kSeatLift);
  EXPECT_EQ(writes[0].value, 0);
  EXPECT_TRUE(rig.cycle().empty());  // once
}

// What the controller may hold, for whoever stops the host: a release set
// but not yet written still counts (found by a CI run: the CLI's hold
// stopped its host while the 0 waited behind a poll, and the seat went on
// rising); so does a 0 whose write failed.
TEST(RehandHostLogic, AReleaseNotYetWrittenStillMayHold_UntilItsZeroIsWritten) {
  Rig rig;
  rig.connect();
  rig.cycle();
  EXPECT_FALSE(rig.logic.may_hold(reg::kSeatLift));
  rig.logic.set_target(reg::kSeatLift, 1);
  EXPECT_TRUE(rig.logic.may_hold(reg::kSeatLift));
  ASSERT_EQ(rig.flush().size(), 1U);
  rig.logic.set_target(reg::kSeatLift, 0);  // released: the 0 is queued, not sent
  EXPECT_EQ(rig.logic.target(reg::kSeatLift), 0);
  EXPECT_TRUE(rig.logic.may_hold(reg::kSeatLift)) << "the controller still holds 1";
  auto zero = rig.logic.next(rig.t);
  ASSERT_TRUE(zero.has_value());
  EXPECT_EQ(zero->value, 0);
  rig.logic.on_result(rig.t, Errc::timeout);  // the 0 may not have arrived
  EXPECT_TRUE(rig.logic.may_hold(reg::kSeatLift));
  rig.logic.set_target(reg::kSeatLift, 1);
  rig.flush();
  rig.logic.set_target(reg::kSeatLift, 0);
  rig.flush();  // the 0 written and answered
  EXPECT_FALSE(rig.logic.may_hold(reg::kSeatLift));
  EXPECT_FALSE(rig.logic.may_hold(reg::kBackrest));  // never pressed
}

}  // namespace
}  // namespace rtukit::rehand6600
