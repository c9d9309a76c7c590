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

TEST(RehandHostLogic, HeldCommandRewrittenEveryPoll_ReleasedWhenTheLeaseRunsOut) {
  Rig rig;
  rig.connect();
  rig.cycle();
  const auto held_at = rig.t;
  EXPECT_TRUE(rig.logic.hold(reg::kSeatLift, 1, held_at));   // the caller writes it now
  EXPECT_FALSE(rig.logic.hold(reg::kSeatLift, 1, held_at));  // renewing: no new write
  auto writes = rig.cycle();                                 // +50 ms
  ASSERT_EQ(writes.size(), 1U);
  EXPECT_EQ(writes[0].address, reg::kSeatLift);
  EXPECT_EQ(writes[0].value, 1);
  // Not renewed: the first poll at or after held_at + 300 ms writes 0.
  while (rig.logic.wake_at() < held_at + 300ms) {
    writes = rig.cycle();
    ASSERT_EQ(writes.size(), 1U);
    EXPECT_EQ(writes[0].value, 1);
  }
  (void)rig.logic.take_events();
  writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1U);
  EXPECT_EQ(writes[0].address, reg::kSeatLift);
  EXPECT_EQ(writes[0].value, 0);
  EXPECT_EQ(rig.t - held_at, 300ms);
  EXPECT_TRUE(rig.has(Event::Type::released, reg::kSeatLift));
  EXPECT_EQ(rig.logic.held(reg::kSeatLift), 0);
  EXPECT_TRUE(rig.cycle().empty());
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

// D-8 on the host's side: an error drops every hold (and writes 0), and a
// dropped hold stays refused until the UI releases it, so a finger that
// stayed on the button through a fault restarts nothing when it clears.
TEST(RehandHostLogic, AnErrorDropsEveryHold_UntilTheUiReleasesIt_D8) {
  Rig rig;
  rig.connect();
  rig.cycle();
  rig.logic.hold(reg::kLegRotate, 1, rig.t);
  auto writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1u);
  EXPECT_EQ(writes[0].value, 1);
  rig.logic.take_events();
  rig.table1[reg::kErrorCode] = 0x1093;
  writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1u);  // the hold written to 0 at once
  EXPECT_EQ(writes[0].address, reg::kLegRotate);
  EXPECT_EQ(writes[0].value, 0);
  EXPECT_TRUE(rig.logic.dropped(reg::kLegRotate));
  EXPECT_EQ(rig.logic.held(reg::kLegRotate), 0);
  rig.table1[reg::kErrorCode] = 0;
  EXPECT_TRUE(rig.cycle().empty());  // cleared: nothing written, nothing moves
  EXPECT_TRUE(rig.logic.dropped(reg::kLegRotate));
  rig.logic.release(reg::kLegRotate);  // the finger lifted
  EXPECT_FALSE(rig.logic.dropped(reg::kLegRotate));
}

TEST(RehandHostLogic, LinkLossDropsEveryHold_D8) {
  Rig rig;
  rig.connect();
  rig.cycle();
  rig.logic.hold(reg::kPhoneForward, 1, rig.t);
  rig.cycle();
  for (int i = 0; i < 3; ++i) rig.cycle(Errc::timeout);
  EXPECT_EQ(rig.logic.active_error(), kMasterCommunicationError);
  EXPECT_TRUE(rig.logic.dropped(reg::kPhoneForward));
  EXPECT_EQ(rig.logic.held(reg::kPhoneForward), 0);
}

// A press whose write failed (a timeout: the controller may have executed
// it before the answer was lost) is dropped as a stop drops it, and 0 is
// written after the next poll: any doubt about motion, stop. The finger
// still on the button does not press again by itself (a link that died
// before 1010 was raised, then came back): the UI must release first.
TEST(RehandHostLogic, APressWhoseWriteFailedIsDropped_AndZeroedAfterTheNextPoll) {
  Rig rig;
  rig.connect();
  rig.cycle();
  ASSERT_TRUE(rig.logic.hold(reg::kSeatLift, 1, rig.t));
  EXPECT_FALSE(rig.logic.press_settled(reg::kSeatLift, 1, /*written=*/false));
  EXPECT_EQ(rig.logic.held(reg::kSeatLift), 0);
  EXPECT_TRUE(rig.logic.dropped(reg::kSeatLift));
  auto writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1u);
  EXPECT_EQ(writes[0].address, reg::kSeatLift);
  EXPECT_EQ(writes[0].value, 0);
  EXPECT_TRUE(rig.cycle().empty());  // once
  EXPECT_TRUE(rig.logic.dropped(reg::kSeatLift));
  // Released and pressed again: held and rewritten as usual.
  rig.logic.release(reg::kSeatLift);
  EXPECT_FALSE(rig.logic.dropped(reg::kSeatLift));
  ASSERT_TRUE(rig.logic.hold(reg::kSeatLift, 1, rig.t));
  EXPECT_FALSE(rig.logic.press_settled(reg::kSeatLift, 1, true));
  writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1u);
  EXPECT_EQ(writes[0].value, 1);
  // Released while a press's write was on the bus, and the write failed: the
  // UI already let go, so the next press is not refused; a 0 still follows.
  rig.logic.release(reg::kSeatLift);
  ASSERT_TRUE(rig.logic.hold(reg::kBackrest, 1, rig.t));
  rig.logic.release(reg::kBackrest);
  EXPECT_FALSE(rig.logic.press_settled(reg::kBackrest, 1, /*written=*/false));
  EXPECT_FALSE(rig.logic.dropped(reg::kBackrest));
  writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1u);
  EXPECT_EQ(writes[0].address, reg::kBackrest);
  EXPECT_EQ(writes[0].value, 0);
}

// The link is lost while a press's write is on the bus: the stop wins (D-8).
// The failed write must not clear the "dropped" mark, or the finger still on
// the button would press again by itself once the link is back.
TEST(RehandHostLogic, ALinkLossDuringThePressWriteWins_D8) {
  Rig rig;
  rig.connect();
  rig.cycle();
  ASSERT_TRUE(rig.logic.hold(reg::kSeatLift, 1, rig.t));
  for (int i = 0; i < 3; ++i) rig.cycle(Errc::timeout);  // meanwhile, on the poll thread
  ASSERT_EQ(rig.logic.active_error(), kMasterCommunicationError);
  EXPECT_FALSE(rig.logic.press_settled(reg::kSeatLift, 1, /*written=*/false));
  EXPECT_TRUE(rig.logic.dropped(reg::kSeatLift));
  // The same when the write got through just before the stop: the caller is told to write 0.
  Rig other;
  other.connect();
  other.cycle();
  ASSERT_TRUE(other.logic.hold(reg::kSeatLift, 1, other.t));
  other.table1[reg::kErrorCode] = 0x1093;
  other.cycle();
  EXPECT_TRUE(other.logic.press_settled(reg::kSeatLift, 1, /*written=*/true));
  EXPECT_TRUE(other.logic.dropped(reg::kSeatLift));
  // A press that went through and is still held: nothing to undo.
  Rig fine;
  fine.connect();
  fine.cycle();
  ASSERT_TRUE(fine.logic.hold(reg::kSeatLift, 1, fine.t));
  EXPECT_FALSE(fine.logic.press_settled(reg::kSeatLift, 1, true));
}

}  // namespace
}  // namespace rtukit::rehand6600
