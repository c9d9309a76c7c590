// The Rehand 6600 host controller's decisions on virtual time: HostLogic is
// sans-IO, so the handshake retry (1 s), "1010 after 3 unanswered requests",
// the write rules (a stop until it is confirmed, a press's word once, nothing
// written again after a poll, 0x006A released only when still) and recovery
// are checked to the millisecond without a thread, a link or a sleep.
// (rehand_fault_test.cpp runs the same rules end to end through a faulty
// link; rehand_sim_test.cpp keeps the real-time Host against the simulator.)
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/devices/rehand6600/motion.hpp"

namespace rtukit::rehand6600 {
namespace {

using namespace std::chrono_literals;
using Kind = HostLogic::Request::Kind;
using Request = HostLogic::Request;

// Every hold-type command the host zeroes at its first handshake (0x006A
// only once two polls read the chair still).
constexpr uint16_t kHeld[] = {reg::kStandSit,     reg::kSeatLift,  reg::kBackrest,   reg::kSeatTilt,
                              reg::kLegRotate,    reg::kLegExtend, reg::kPlateTilt,  reg::kPhoneForward,
                              reg::kPhoneReverse, reg::kPhoneLeft, reg::kPhoneRight, reg::kPhoneHorn};

// A bound on every loop that waits for the logic to settle: a defect that
// never settles fails its test at once instead of hanging it (the mutation
// check, scripts/mutate.py, counted such a hang only at its time-out).
constexpr int kMaxSteps = 1000;

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
  uint64_t serial = 100;

  // The request due at `t` (fails the test when there is none).
  Request due() {
    auto r = logic.next(t);
    EXPECT_TRUE(r.has_value());
    return r.value_or(Request{Kind::poll});
  }
  void answer(const Request& r, Error e = {}) {
    if (e) return logic.on_result(t, e);
    if (r.kind == Kind::read_device_id) return logic.on_result(t, e, std::span(table1.data(), 1));
    if (r.kind == Kind::poll) return logic.on_result(t, e, table1);
    logic.on_result(t, e);
  }
  // The handshake, the first start's zeros and the boot-complete write, all answered.
  void connect() {
    answer(due());  // device ID
    for (int n = 0;; ++n) {
      ASSERT_LT(n, kMaxSteps) << "the handshake never ends";
      const auto w = due();
      ASSERT_EQ(w.kind, Kind::write);
      answer(w);
      if (w.address == reg::kHostReady) break;
    }
    EXPECT_TRUE(logic.connected());
  }
  // Connected, with a first poll answered and nothing owed (0x006A's
  // release after two still polls included).
  void ready() {
    connect();
    for (int i = 0; i < 3; ++i) cycle();
  }
  // One poll at the next wake-up (answered with `poll_error`), then every
  // write due after it, answered; returns those writes.
  std::vector<Request> cycle(Error poll_error = {}) {
    t = std::max(t, logic.wake_at());
    auto poll = due();
    std::vector<Request> writes;
    while (poll.kind == Kind::write) {  // stops owed before the poll
      if (writes.size() > kMaxSteps) {
        ADD_FAILURE() << "writes without end before the poll";
        return writes;
      }
      writes.push_back(poll);
      answer(poll);
      poll = due();
    }
    EXPECT_EQ(poll.kind, Kind::poll);
    answer(poll, poll_error);
    for (auto& w : flush()) writes.push_back(w);
    return writes;
  }
  // The writes due now, answered normally.
  std::vector<Request> flush() {
    std::vector<Request> writes;
    for (int n = 0; auto w = logic.next(t); ++n) {
      if (n > kMaxSteps) {
        ADD_FAILURE() << "requests without end at one instant";
        break;
      }
      if (w->kind != Kind::write) {
        answer(*w);
        continue;
      }
      writes.push_back(*w);
      answer(*w);
    }
    return writes;
  }
  // Three polls unanswered: the link is lost (1010), as the session then
  // releases every press.
  void lose_link() {
    for (int i = 0; i < 3; ++i) cycle(Errc::timeout);
    EXPECT_EQ(logic.active_error(), kMasterCommunicationError);
  }
  void press(uint16_t command, uint16_t value) { logic.set_target(command, value, ++serial); }
  void release(uint16_t command) { logic.set_target(command, 0, 0); }
  bool has(Event::Type type, uint16_t code = 0) {
    for (const Event& e : logic.take_events())
      if (e.type == type && (code == 0 || e.code == code || e.address == code)) return true;
    return false;
  }
};

TEST(RehandHostLogic, HandshakeRetriesEverySecond_WrongDeviceIsRefused_NothingIsWrittenToIt) {
  Rig rig;
  auto r = rig.due();
  EXPECT_EQ(r.kind, Kind::read_device_id);
  rig.answer(r, Errc::timeout);
  EXPECT_TRUE(rig.has(Event::Type::error_raised, kMasterCommunicationError));
  EXPECT_EQ(rig.logic.active_error(), kMasterCommunicationError);
  EXPECT_FALSE(rig.logic.next(rig.t + 999ms))
      << "nothing before the retry, and no write to an unknown device";
  rig.t += 1000ms;
  rig.table1[reg::kDeviceId] = 0x69;
  rig.answer(rig.due());
  EXPECT_FALSE(rig.logic.connected());
  EXPECT_EQ(rig.logic.last_failure().code(), Errc::refused);
  EXPECT_EQ(rig.logic.last_failure().reason(), "handshake: device ID 0x69, expected 0x68");
  EXPECT_FALSE(rig.has(Event::Type::error_raised));  // raised once, not again
  EXPECT_FALSE(rig.logic.next(rig.t + 999ms)) << "another device: no zero is written to it";
  rig.t += 1000ms;
  rig.table1[reg::kDeviceId] = kDeviceId;
  rig.connect();
  const auto events = rig.logic.take_events();
  ASSERT_EQ(events.size(), 2U);
  EXPECT_EQ(events[0].type, Event::Type::error_cleared);
  EXPECT_EQ(events[1].type, Event::Type::connected);
  rig.table1[reg::kErrorCode] = 0x1091;
  rig.cycle();
  EXPECT_EQ(rig.logic.active_error(), 0x1091);
}

// A host that starts does not know what an earlier run left: a daemon that
// crashed while holding seat lift and was restarted before the controller's
// watchdog tripped would otherwise feed that watchdog with its polls while
// the seat goes on rising. Every hold-type command gets its 0 first, 0x006A
// once two polls read the chair still.
TEST(RehandHostLogic, AtTheFirstHandshakeEveryHoldCommandIsZeroed_BeforeBootComplete) {
  Rig rig;
  rig.answer(rig.due());  // device ID
  std::vector<uint16_t> zeroed;
  for (int n = 0;; ++n) {
    ASSERT_LT(n, kMaxSteps) << "the handshake never ends";
    const auto w = rig.due();
    ASSERT_EQ(w.kind, Kind::write);
    rig.answer(w);
    if (w.address == reg::kHostReady) break;
    EXPECT_EQ(w.value, 0);
    zeroed.push_back(w.address);
  }
  EXPECT_EQ(zeroed, std::vector<uint16_t>(std::begin(kHeld), std::end(kHeld)));
  EXPECT_TRUE(rig.logic.may_hold(reg::kAntiPinch)) << "0x006A waits for the chair to be still";
  EXPECT_TRUE(rig.cycle().empty());
  const auto writes = rig.cycle();  // the second still poll
  ASSERT_EQ(writes.size(), 1U);
  EXPECT_EQ(writes[0].address, reg::kAntiPinch);
  EXPECT_EQ(writes[0].value, 0);
  EXPECT_FALSE(rig.logic.may_hold(reg::kAntiPinch));
  EXPECT_TRUE(rig.cycle().empty());
}

// Finding 1: a failed write of 0 was never written again, and the chair went
// on moving with nobody pressing. Now the 0 is written until the controller
// answers it, before any poll.
TEST(RehandHostLogic, ALostReleaseIsWrittenAgainUntilConfirmed_BeforeAnyPoll) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  ASSERT_EQ(rig.flush().size(), 1U);
  rig.release(reg::kSeatLift);
  auto zero = rig.due();
  EXPECT_EQ(zero.address, reg::kSeatLift);
  EXPECT_EQ(zero.value, 0);
  rig.answer(zero, Errc::timeout);  // the release lost on the line
  EXPECT_TRUE(rig.logic.may_hold(reg::kSeatLift));
  EXPECT_EQ(rig.logic.wake_at(), HostLogic::TimePoint::min()) << "again at once, not after the next poll";
  zero = rig.due();
  EXPECT_EQ(zero.address, reg::kSeatLift);
  EXPECT_EQ(zero.value, 0);
  rig.answer(zero, Errc::bad_crc);  // its answer corrupted
  zero = rig.due();
  EXPECT_EQ(zero.value, 0);
  rig.answer(zero);
  EXPECT_FALSE(rig.logic.may_hold(reg::kSeatLift));
  EXPECT_TRUE(rig.cycle().empty()) << "confirmed: not written again";
}

// Finding 1, second half: the 0 after a failed press (the controller may
// have executed the press before its answer was lost) is owed the same way.
TEST(RehandHostLogic, TheZeroAfterAFailedPressIsWrittenUntilConfirmed) {
  Rig rig;
  rig.ready();
  rig.press(reg::kPhoneForward, 1);
  const auto w = rig.due();
  ASSERT_EQ(w.value, 1);
  rig.answer(w, Errc::timeout);
  EXPECT_TRUE(rig.has(Event::Type::write_failed, reg::kPhoneForward));
  if (const auto n = rig.logic.next(rig.t)) {
    EXPECT_FALSE(n->kind == Kind::write && n->value == 1) << "a press is not written twice";
    rig.answer(*n);
  }
  rig.release(reg::kPhoneForward);  // the session ends the press
  const auto zero = rig.due();
  EXPECT_EQ(zero.address, reg::kPhoneForward);
  EXPECT_EQ(zero.value, 0);
  rig.answer(zero, Errc::timeout);
  EXPECT_TRUE(rig.logic.connected()) << "two unanswered requests (the press, its 0) are a glitch";
  rig.answer(rig.due());
  EXPECT_FALSE(rig.logic.may_hold(reg::kPhoneForward));
}

// Finding 3: live presses were written again after every poll, undoing
// every stop the controller made by itself. A press's word is written once.
TEST(RehandHostLogic, APressIsWrittenOnce_NothingIsWrittenAgainAfterAPoll) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  EXPECT_EQ(rig.logic.wake_at(), HostLogic::TimePoint::min()) << "a press waits for no poll";
  const auto now = rig.flush();
  ASSERT_EQ(now.size(), 1U);
  EXPECT_EQ(now[0].value, 1);
  rig.table1[reg::kSeatLiftStatus] = 1;
  rig.table1[reg::kActuatorState] = kActuatorMoving;
  for (int i = 0; i < 20; ++i) EXPECT_TRUE(rig.cycle().empty()) << "poll " << i;
  // The same press set again (a renewal) writes nothing either.
  rig.logic.set_target(reg::kSeatLift, 1, rig.serial);
  EXPECT_TRUE(rig.flush().empty());
}

// ... and when the controller stops by itself (its watchdog after a host
// stall, an obstacle, the joystick, a button), table 1 shows it and the
// press ends: only a new press moves the chair again (D-8).
TEST(RehandHostLogic, WhenTheControllerStopsAPressByItselfThePressEnds) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  rig.flush();
  EXPECT_TRUE(rig.cycle().empty());  // not moving yet: starting
  rig.table1[reg::kSeatLiftStatus] = 1;
  rig.table1[reg::kActuatorState] = kActuatorMoving;
  rig.cycle();
  EXPECT_FALSE(rig.has(Event::Type::chair_stopped));
  rig.table1[reg::kSeatLiftStatus] = 0;  // the watchdog tripped: still, not at a limit
  rig.table1[reg::kActuatorState] = kActuatorStill;
  EXPECT_TRUE(rig.cycle().empty()) << "nothing written back";
  const auto events = rig.logic.take_events();
  const auto stopped = std::find_if(events.begin(), events.end(),
                                    [](const Event& e) { return e.type == Event::Type::chair_stopped; });
  ASSERT_NE(stopped, events.end());
  EXPECT_EQ(stopped->address, reg::kSeatLift);
  EXPECT_NE(stopped->reason.find("by itself"), std::string::npos) << stopped->reason;
  // The session ends the press: its 0 is written (the controller holds 0 already; it is idempotent).
  rig.release(reg::kSeatLift);
  const auto zero = rig.flush();
  ASSERT_EQ(zero.size(), 1U);
  EXPECT_EQ(zero[0].value, 0);
}

// A phone's forward press: the motion state shows it; an obstacle stop
// (still, motion static) ends it.
TEST(RehandHostLogic, APhoneDrivePressEndsWhenTheChairStopsDriving) {
  Rig rig;
  rig.ready();
  rig.press(reg::kPhoneForward, 1);
  rig.flush();
  rig.table1[reg::kMotion] = kForward;
  rig.table1[reg::kSpeed] = 2;
  rig.cycle();
  rig.table1[reg::kSpeed] = 1;  // braking: still forward
  rig.cycle();
  EXPECT_FALSE(rig.has(Event::Type::chair_stopped));
  rig.table1[reg::kMotion] = kStatic;
  rig.table1[reg::kSpeed] = 0;
  EXPECT_TRUE(rig.cycle().empty());
  EXPECT_TRUE(rig.has(Event::Type::chair_stopped, reg::kPhoneForward));
}

// A posture pushing against its end is still obeyed (the controller holds
// it); one that never shows ends after the start timeout.
TEST(RehandHostLogic, APostureAtItsEndStaysPressed_OneThatNeverStartsEnds) {
  Rig rig;
  rig.ready();
  rig.press(reg::kLegRotate, 1);
  rig.flush();
  rig.table1[reg::kActuatorState + 3] = kUpperLimit;  // actuators 4 and 5 at their upper ends
  rig.table1[reg::kActuatorState + 4] = kUpperLimit;
  for (int i = 0; i < 60; ++i) rig.cycle();
  EXPECT_FALSE(rig.has(Event::Type::chair_stopped));
  rig.press(reg::kBackrest, 2);
  rig.flush();
  const auto pressed_at = rig.t;
  while (rig.t - pressed_at < 2400ms) rig.cycle();
  EXPECT_FALSE(rig.has(Event::Type::chair_stopped, reg::kBackrest)) << "within its start timeout";
  while (rig.t - pressed_at < 2600ms) rig.cycle();
  EXPECT_TRUE(rig.has(Event::Type::chair_stopped, reg::kBackrest));
}

// Finding 2: a link loss forgot what the controller might hold; when only
// the answers were lost, the last command went on after the link came back.
// Now the 0 stays owed through 1010, is tried at the poll rate while the
// link is down, and is the first thing written after the handshake.
TEST(RehandHostLogic, ALinkLossKeepsTheZerosOwed_TriedWhileDown_FirstAfterTheHandshake) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  rig.flush();
  rig.lose_link();
  rig.release(reg::kSeatLift);  // the session ends every press on 1010
  EXPECT_TRUE(rig.logic.may_hold(reg::kSeatLift));
  // While the link is down the 0 is tried every poll period.
  for (int i = 0; i < 3; ++i) {
    rig.t = std::max(rig.t, rig.logic.wake_at());
    const auto zero = rig.due();
    EXPECT_EQ(zero.kind, Kind::write) << i;
    EXPECT_EQ(zero.address, reg::kSeatLift);
    EXPECT_EQ(zero.value, 0);
    const auto sent = rig.t;
    rig.answer(zero, Errc::timeout);
    EXPECT_LE(rig.logic.wake_at() - sent, 50ms);
  }
  // The link is back: the 0 is answered, and the handshake follows at once.
  rig.t = std::max(rig.t, rig.logic.wake_at());
  rig.answer(rig.due());
  EXPECT_FALSE(rig.logic.may_hold(reg::kSeatLift));
  EXPECT_EQ(rig.due().kind, Kind::read_device_id);
}

// The handshake ends with the boot-complete word: host_ready = 1 (the seed's
// value; anything else is no handshake to the controller).
TEST(RehandHostLogic, TheHandshakeWritesBootCompleteAsOne) {
  Rig rig;
  rig.answer(rig.due());  // device ID
  for (int n = 0; n < 20; ++n) {
    const auto w = rig.due();
    ASSERT_EQ(w.kind, Kind::write);
    if (w.address == reg::kHostReady) {
      EXPECT_EQ(w.value, 1);
      return;
    }
    rig.answer(w);
  }
  FAIL() << "no boot-complete write";
}

// While the link is down an owed zero is tried at the poll rate, not faster:
// after a failed try, nothing goes until the poll period has passed.
TEST(RehandHostLogic, WhileDownAZeroIsTriedAtThePollRateNotFaster) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  rig.flush();
  rig.lose_link();
  rig.release(reg::kSeatLift);
  for (int i = 0; i < 3; ++i) {
    rig.t = std::max(rig.t, rig.logic.wake_at());
    const auto zero = rig.due();
    ASSERT_EQ(zero.address, reg::kSeatLift) << i;
    const auto sent = rig.t;
    rig.answer(zero, Errc::timeout);
    EXPECT_FALSE(rig.logic.next(rig.t).has_value()) << "tried again at once, " << i;
    EXPECT_GE(rig.logic.wake_at() - sent, 50ms) << i;
  }
}

// Two zeros owed while the link is down are tried in turn: one that keeps
// failing does not keep the other from being tried.
TEST(RehandHostLogic, ZerosOwedWhileDownAreTriedInTurn) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  rig.press(reg::kBackrest, 1);
  rig.flush();
  rig.lose_link();
  rig.release(reg::kSeatLift);
  rig.release(reg::kBackrest);
  std::vector<uint16_t> tried;
  for (int i = 0; i < 4; ++i) {
    rig.t = std::max(rig.t, rig.logic.wake_at());
    const auto zero = rig.due();
    ASSERT_EQ(zero.kind, Kind::write) << i;
    tried.push_back(zero.address);
    rig.answer(zero, Errc::timeout);
  }
  EXPECT_NE(tried[0], tried[1]);
  EXPECT_EQ(tried[0], tried[2]);
  EXPECT_EQ(tried[1], tried[3]);
}

TEST(RehandHostLogic, AfterALinkLossTheZeroGoesBeforeBootCompleteAndThePoll) {
  Rig rig;
  rig.ready();
  rig.press(reg::kBackrest, 1);
  rig.flush();
  for (int i = 0; i < 3; ++i) rig.cycle(Errc::timeout);
  rig.release(reg::kBackrest);
  // Down: every try of the 0 fails for a second (the 0 is the probe: no handshake meanwhile).
  const auto down_at = rig.t;
  while (rig.t - down_at < 1s) {
    rig.t = std::max(rig.t, rig.logic.wake_at());
    rig.answer(rig.due(), Errc::timeout);
    rig.t += 100ms;  // each failure takes its response timeout
  }
  rig.t = std::max(rig.t, rig.logic.wake_at());
  std::vector<Request> order;
  while (!rig.logic.connected() || order.empty() || order.back().kind != Kind::poll) {
    ASSERT_LT(order.size(), size_t{kMaxSteps}) << "never connected again";
    rig.t = std::max(rig.t, rig.logic.wake_at());
    const auto r = rig.due();
    order.push_back(r);
    rig.answer(r);
  }
  ASSERT_GE(order.size(), 2U);
  const auto zero = std::find_if(order.begin(), order.end(), [](const Request& r) {
    return r.kind == Kind::write && r.address == reg::kBackrest;
  });
  const auto ready = std::find_if(order.begin(), order.end(), [](const Request& r) {
    return r.kind == Kind::write && r.address == reg::kHostReady;
  });
  ASSERT_NE(zero, order.end());
  ASSERT_NE(ready, order.end());
  EXPECT_LT(zero - order.begin(), ready - order.begin());
  EXPECT_EQ(zero->value, 0);
}

// Finding 4: 0x006A was released on the poll count of every request and on
// a reading that may predate the stop. Now: kept until two polls sent after
// its confirmed 1 read the chair still.
TEST(RehandHostLogic, TheStopCommandIsReleasedOnlyAfterTwoStillPollsAfterItsConfirmation) {
  Rig rig;
  rig.ready();
  rig.table1[reg::kMotion] = kForward;  // driving
  rig.table1[reg::kSpeed] = 4;
  rig.cycle();
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);  // a phone lost control
  auto stop = rig.due();
  EXPECT_EQ(stop.address, reg::kAntiPinch);
  EXPECT_EQ(stop.value, 1);
  rig.answer(stop, Errc::timeout);
  EXPECT_FALSE(rig.logic.stop_settled());
  stop = rig.due();
  EXPECT_EQ(stop.address, reg::kAntiPinch) << "a stop is written until confirmed";
  rig.answer(stop);
  rig.cycle();
  EXPECT_FALSE(rig.logic.stop_settled()) << "still moving";
  rig.table1[reg::kMotion] = kStatic;
  rig.table1[reg::kSpeed] = 0;
  rig.cycle();
  EXPECT_FALSE(rig.logic.stop_settled()) << "one still poll";
  rig.table1[reg::kActuatorState + 1] = kActuatorMoving;  // an actuator still moves
  rig.cycle();
  EXPECT_FALSE(rig.logic.stop_settled());
  rig.table1[reg::kActuatorState + 1] = kActuatorStill;
  rig.cycle();
  rig.cycle();
  EXPECT_TRUE(rig.logic.stop_settled());
  // Even asked for early, the 0 waits for the chair (here it is still).
  rig.logic.set_target(reg::kAntiPinch, 0, 0);
  const auto zero = rig.flush();
  ASSERT_EQ(zero.size(), 1U);
  EXPECT_EQ(zero[0].value, 0);
}

TEST(RehandHostLogic, AReleaseOfTheStopCommandWaitsForTheChair) {
  Rig rig;
  rig.ready();
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);
  rig.flush();
  rig.table1[reg::kMotion] = kForward;
  rig.table1[reg::kSpeed] = 3;
  rig.logic.set_target(reg::kAntiPinch, 0, 0);  // released too early (a display's anti-pinch tap)
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(rig.cycle().empty()) << "not while the chair moves";
  rig.table1[reg::kMotion] = kStatic;
  rig.table1[reg::kSpeed] = 0;
  EXPECT_TRUE(rig.cycle().empty());
  const auto writes = rig.cycle();
  ASSERT_EQ(writes.size(), 1U);
  EXPECT_EQ(writes[0].address, reg::kAntiPinch);
  EXPECT_EQ(writes[0].value, 0);
}

// Finding 6: during 1010 the stop command was not written at all. Now it is
// tried while the link is down and written as soon as it is back, then held
// as after any confirmation.
TEST(RehandHostLogic, AStopDueDuringALinkLossIsWrittenAsSoonAsTheLinkIsBack) {
  Rig rig;
  rig.ready();
  for (int i = 0; i < 3; ++i) rig.cycle(Errc::timeout);
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);
  rig.t = std::max(rig.t, rig.logic.wake_at());
  auto first = rig.due();
  EXPECT_EQ(first.address, reg::kAntiPinch);
  EXPECT_EQ(first.value, 1);
  rig.answer(first);  // the link is back
  EXPECT_EQ(rig.due().kind, Kind::read_device_id);
}

// Finding 5: a new error dropped a release's 0 not sent yet; a retried 0
// could overtake a newer press (stop-and-go), and 0x006A bounce 1-0-1.
TEST(RehandHostLogic, ANewErrorKeepsAnUnsentZero) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatTilt, 1);
  rig.flush();
  // The finger lifts while a poll is on the wire; that poll reports a fault.
  rig.t = rig.logic.wake_at();
  const auto poll = rig.due();
  ASSERT_EQ(poll.kind, Kind::poll);
  rig.release(reg::kSeatTilt);
  rig.table1[reg::kErrorCode] = 0x1081;
  rig.answer(poll);
  EXPECT_TRUE(rig.has(Event::Type::error_raised, 0x1081));
  const auto zero = rig.due();
  EXPECT_EQ(zero.address, reg::kSeatTilt) << "the release is not dropped because the controller faulted";
  EXPECT_EQ(zero.value, 0);
}

TEST(RehandHostLogic, ANewerPressReplacesAnOwedZero_NoOldWordOvertakesANewOne) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  rig.flush();
  rig.release(reg::kSeatLift);
  rig.answer(rig.due(), Errc::timeout);  // the 0 lost
  rig.press(reg::kSeatLift, 2);          // the finger presses down before the 0 went through
  const auto writes = rig.flush();
  ASSERT_EQ(writes.size(), 1U) << "only the newest word: no 0 after the 2";
  EXPECT_EQ(writes[0].value, 2);
  // And 0x006A: set, released early, set again before its 0 was due: one 1, no 0 between.
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);
  EXPECT_EQ(rig.flush().size(), 1U);
  rig.logic.set_target(reg::kAntiPinch, 0, 0);
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);
  rig.table1[reg::kSeatLiftStatus] = 2;
  for (int i = 0; i < 4; ++i)
    for (const Request& w : rig.cycle()) EXPECT_NE(w.address, reg::kAntiPinch) << "no 1-0-1 bounce";
}

// Unanswered requests of any kind raise 1010: a link that loses every
// write is not hidden behind answered polls, and a dead link is not written
// to for ever.
TEST(RehandHostLogic, ThreeUnansweredRequestsRaise1010_ThenTheHandshakeRecovers) {
  Rig rig;
  rig.ready();
  (void)rig.logic.take_events();
  rig.cycle(Errc::timeout);
  rig.cycle(Errc::timeout);
  EXPECT_TRUE(rig.logic.connected());  // two failures are a glitch
  EXPECT_FALSE(rig.has(Event::Type::error_raised));
  rig.cycle(Errc::timeout);
  EXPECT_FALSE(rig.logic.connected());
  EXPECT_TRUE(rig.has(Event::Type::error_raised, kMasterCommunicationError));
  EXPECT_EQ(rig.logic.last_failure().reason(), "3 consecutive polls failed (timeout)");
  const auto failed_at = rig.t;
  rig.t = rig.logic.wake_at();
  EXPECT_EQ(rig.t - failed_at, 50ms);
  rig.connect();
  EXPECT_TRUE(rig.has(Event::Type::error_cleared, kMasterCommunicationError));
  // Writes count too.
  rig.cycle();
  rig.press(reg::kBackrest, 1);
  rig.answer(rig.due(), Errc::timeout);
  rig.release(reg::kBackrest);
  rig.answer(rig.due(), Errc::timeout);
  rig.answer(rig.due(), Errc::timeout);
  EXPECT_FALSE(rig.logic.connected());
}

// A refused stop (an exception: the controller answers, so the link is
// fine) is tried again after the next poll, not in a loop that starves the polls.
TEST(RehandHostLogic, AStopAnsweredWithAnExceptionIsTriedAgainAfterEachPoll) {
  Rig rig;
  rig.ready();
  rig.press(reg::kBackrest, 1);
  rig.flush();
  rig.release(reg::kBackrest);
  rig.answer(rig.due(), Errc::server_device_failure);
  rig.t = std::max(rig.t, rig.logic.wake_at());
  const auto poll = rig.due();
  EXPECT_EQ(poll.kind, Kind::poll);
  rig.answer(poll);
  const auto again = rig.due();
  EXPECT_EQ(again.address, reg::kBackrest);
  EXPECT_EQ(again.value, 0);
  EXPECT_TRUE(rig.logic.connected());
}

// Stopping the host writes only what is owed, a few tries each; a stop
// command held for a lost phone stays held; a dead link is given up.
TEST(RehandHostLogic, ShutdownWritesOnlyStops_KeepsTheStopCommand_GivesUpOnADeadLink) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  rig.press(reg::kPhoneForward, 1);
  rig.flush();
  rig.release(reg::kSeatLift);
  rig.release(reg::kPhoneForward);
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);
  ASSERT_TRUE(rig.logic.enqueue(reg::kLight, 1, 7));
  rig.logic.begin_shutdown();
  std::vector<Request> writes;
  while (auto w = rig.logic.next(rig.t)) {
    ASSERT_LT(writes.size(), size_t{kMaxSteps}) << "a shutdown that never ends";
    writes.push_back(*w);
    rig.answer(*w, writes.size() == 2 ? Error(Errc::timeout) : Error());
  }
  ASSERT_GE(writes.size(), 3U);
  EXPECT_EQ(writes[0].address, reg::kAntiPinch);
  EXPECT_EQ(writes[0].value, 1);
  for (const Request& w : writes) {
    EXPECT_NE(w.kind, Kind::poll);
    EXPECT_NE(w.address, reg::kLight) << "no one-shot";
    if (w.address == reg::kAntiPinch) EXPECT_EQ(w.value, 1) << "never released in the middle of a stop";
  }
  EXPECT_FALSE(rig.logic.may_hold(reg::kSeatLift));
  EXPECT_FALSE(rig.logic.may_hold(reg::kPhoneForward));
  // A dead link: three unanswered tries in all, then nothing.
  Rig dead;
  dead.ready();
  dead.press(reg::kSeatLift, 1);
  dead.press(reg::kBackrest, 1);
  dead.flush();
  dead.release(reg::kSeatLift);
  dead.release(reg::kBackrest);
  dead.logic.begin_shutdown();
  int tries = 0;
  while (auto w = dead.logic.next(dead.t)) {
    ASSERT_LT(tries, kMaxSteps) << "a shutdown that never ends";
    ++tries;
    dead.answer(*w, Errc::timeout);
  }
  EXPECT_EQ(tries, 3);
}

// At shutdown a stop the controller answers with an exception (it answers:
// the link is up) is tried kShutdownAttempts times, no more: the host ends.
TEST(RehandHostLogic, AtShutdownAStopRefusedByTheControllerIsTriedThreeTimes) {
  Rig rig;
  rig.ready();
  rig.press(reg::kBackrest, 1);
  rig.flush();
  rig.release(reg::kBackrest);
  rig.logic.begin_shutdown();
  unsigned tries = 0;
  for (int n = 0; n < 20; ++n) {
    const auto w = rig.logic.next(rig.t);
    if (!w) break;
    tries += w->address == reg::kBackrest;
    rig.answer(*w, Errc::server_device_failure);
    rig.t += 50ms;
  }
  EXPECT_EQ(tries, HostLogic::kShutdownAttempts);
}

TEST(RehandHostLogic, PollEvents_ChangesEdgesAndLocalErrors) {
  Rig rig;
  rig.ready();
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

TEST(RehandHostLogic, OneShotsWaitBehindStopsAndPresses_TheQueueIsBounded_LinkLossFailsThem) {
  Rig rig;
  rig.ready();
  ASSERT_TRUE(rig.logic.enqueue(reg::kLight, 1, 7));
  rig.press(reg::kSeatLift, 1);
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);
  const auto writes = rig.flush();
  ASSERT_EQ(writes.size(), 3U);
  EXPECT_EQ(writes[0].address, reg::kAntiPinch);
  EXPECT_EQ(writes[1].address, reg::kSeatLift);
  EXPECT_EQ(writes[2].address, reg::kLight);
  const auto results = rig.logic.take_results();
  ASSERT_EQ(results.size(), 1U);
  EXPECT_EQ(results[0].first, 7U);
  EXPECT_TRUE(results[0].second.ok());
  for (size_t i = 0; i < HostLogic::kQueueLimit; ++i) ASSERT_TRUE(rig.logic.enqueue(reg::kLight, 1, 100 + i));
  EXPECT_FALSE(rig.logic.enqueue(reg::kLight, 1, 999)) << "a full queue refuses";
  Rig down;
  down.ready();
  for (int i = 0; i < 3; ++i) down.cycle(Errc::timeout);
  EXPECT_FALSE(down.logic.enqueue(reg::kLight, 1, 6)) << "nothing is queued for a link that is down";
}

// A poll answered with an exception is an answer: the link is up, and the
// count of unanswered requests starts again (mutation host.cpp:351 survived:
// a count left at 1 made the next two timeouts a 1010).
TEST(RehandHostLogic, APollAnsweredWithAnExceptionIsAnAnswer_TheCountStartsAgain) {
  Rig rig;
  rig.ready();
  rig.cycle(Errc::timeout);
  rig.cycle(Errc::timeout);
  rig.cycle(Error::exception(0x04));
  rig.cycle(Errc::timeout);
  rig.cycle(Errc::timeout);
  EXPECT_TRUE(rig.logic.connected());
  EXPECT_NE(rig.logic.active_error(), kMasterCommunicationError) << "two unanswered polls are not three";
  rig.cycle(Errc::timeout);
  EXPECT_EQ(rig.logic.active_error(), kMasterCommunicationError) << "the third is";
}

// After the link came back, the count of unanswered requests starts at 0
// (mutation host.cpp:276 survived: a count of 1 at the handshake made two
// timeouts a 1010).
TEST(RehandHostLogic, AfterTheLinkIsBackThreeUnansweredPollsMakeA1010_NotTwo) {
  Rig rig;
  rig.ready();
  rig.lose_link();
  for (int n = 0; !rig.logic.connected(); ++n) {
    ASSERT_LT(n, kMaxSteps) << "never connected again";
    rig.t = std::max(rig.t, rig.logic.wake_at());
    rig.answer(rig.due());
  }
  // The first two polls after the handshake go unanswered (an answered one
  // would start the count again by itself).
  rig.cycle(Errc::timeout);
  rig.cycle(Errc::timeout);
  EXPECT_NE(rig.logic.active_error(), kMasterCommunicationError)
      << "two unanswered polls after the link came back";
  rig.cycle(Errc::timeout);
  EXPECT_EQ(rig.logic.active_error(), kMasterCommunicationError) << "three";
}

// A one-shot (a light, a setting) queued when the link drops fails with its
// ticket and is never written after the link is back: the person pressed it
// for then, not for whenever the link returns (mutants host.cpp:430 and :440,
// the failing and the clearing dropped, survived the full run).
TEST(RehandHostLogic, AOneShotQueuedWhenTheLinkDropsFails_NeverWrittenAfterwards) {
  Rig rig;
  rig.ready();
  rig.cycle(Errc::timeout);
  rig.cycle(Errc::timeout);
  rig.t = std::max(rig.t, rig.logic.wake_at());
  const Request poll = rig.due();
  ASSERT_EQ(poll.kind, Kind::poll);
  ASSERT_TRUE(rig.logic.enqueue(reg::kLight, 1, 7));  // while the third poll is on the wire
  rig.answer(poll, Errc::timeout);
  ASSERT_EQ(rig.logic.active_error(), kMasterCommunicationError);
  const auto results = rig.logic.take_results();
  ASSERT_EQ(results.size(), 1U) << "the ticket is answered";
  EXPECT_EQ(results[0].first, 7U);
  EXPECT_TRUE(results[0].second) << "with an error";
  std::vector<Request> sent;
  for (int n = 0; !rig.logic.connected(); ++n) {
    ASSERT_LT(n, kMaxSteps) << "never connected again";
    rig.t = std::max(rig.t, rig.logic.wake_at());
    sent.push_back(rig.due());
    rig.answer(sent.back());
  }
  for (const Request& w : rig.cycle()) sent.push_back(w);
  for (const Request& w : rig.cycle()) sent.push_back(w);
  for (const Request& r : sent)
    EXPECT_NE(r.address, reg::kLight) << "the light written after the link came back";
}

// The stop (0x006A = 1) counts as settled only after two still polls from
// its own confirmation, whatever was still before, and another write
// meanwhile does not start the count again (the four mutants of
// host.cpp:300 survived the full run: the stop tests checked "released while
// still", not "not before the second still poll").
TEST(RehandHostLogic, AStopSettlesOnTheSecondStillPollAfterItsConfirmation) {
  Rig rig;
  rig.ready();  // three still polls already
  rig.logic.set_target(reg::kAntiPinch, 1, ++rig.serial);
  const auto stop = rig.flush();
  ASSERT_EQ(stop.size(), 1U);
  EXPECT_EQ(stop.front().address, reg::kAntiPinch);
  rig.cycle();
  EXPECT_FALSE(rig.logic.stop_settled()) << "one still poll since the stop";
  rig.press(reg::kSeatLift, 1);  // another word written before the next poll
  const auto between = rig.flush();
  ASSERT_EQ(between.size(), 1U);
  EXPECT_EQ(between.front().address, reg::kSeatLift);
  rig.cycle();
  EXPECT_TRUE(rig.logic.stop_settled()) << "the second, another write between";
}

// At shutdown a queued one-shot is not written (only stops are) and its
// ticket is answered at once, not left to the caller's time-out (mutant
// host.cpp:462, the failing dropped, survived the full run).
TEST(RehandHostLogic, AtShutdownAQueuedOneShotFailsAtOnce) {
  Rig rig;
  rig.ready();
  ASSERT_TRUE(rig.logic.enqueue(reg::kLight, 1, 5));
  rig.logic.begin_shutdown();
  const auto results = rig.logic.take_results();
  ASSERT_EQ(results.size(), 1U);
  EXPECT_EQ(results[0].first, 5U);
  EXPECT_EQ(results[0].second.code(), Errc::not_connected);
  EXPECT_FALSE(rig.logic.next(rig.t).has_value()) << "nothing owed, nothing written";
}

// A new press of the same value is a new word on the wire even when the host
// never saw the old press end in between (a release and a new press between
// two of its looks): D-8, only a new press moves the chair again, and it
// must be able to (mutants host.cpp:446, `set_target`'s early return on the
// value alone, survived the full run).
TEST(RehandHostLogic, ANewPressOfTheSameValueIsWrittenAgain) {
  Rig rig;
  rig.ready();
  rig.press(reg::kSeatLift, 1);
  const auto first = rig.flush();
  ASSERT_EQ(first.size(), 1U);
  rig.press(reg::kSeatLift, 1);  // a new serial, the same value
  const auto second = rig.flush();
  ASSERT_EQ(second.size(), 1U) << "the new press's word";
  EXPECT_EQ(second.front().address, reg::kSeatLift);
  EXPECT_EQ(second.front().value, 1);
}

// The first reading after the start tells of no error that went away: there
// was none before it (mutant host.cpp:372, an error "1" assumed before the
// first reading, survived the full run: the display would have logged a
// cleared error at every start).
TEST(RehandHostLogic, TheFirstReadingClearsNoError) {
  Rig rig;
  rig.connect();
  (void)rig.logic.take_events();
  rig.cycle();
  EXPECT_FALSE(rig.has(Event::Type::error_cleared)) << "nothing was raised";
}

// A boot-complete write that fails is a communication error the display is
// told of (1010, with the reason), not a silent retry (mutant host.cpp:270,
// the error dropped, survived the full run).
TEST(RehandHostLogic, AFailedBootCompleteWriteRaisesTheCommunicationError) {
  Rig rig;
  rig.answer(rig.due());  // device ID
  for (int n = 0;; ++n) {
    ASSERT_LT(n, kMaxSteps) << "the handshake never ends";
    const Request w = rig.due();
    ASSERT_EQ(w.kind, Kind::write);
    if (w.address == reg::kHostReady) {
      rig.answer(w, Errc::timeout);
      break;
    }
    rig.answer(w);
  }
  EXPECT_FALSE(rig.logic.connected());
  EXPECT_TRUE(rig.has(Event::Type::error_raised, kMasterCommunicationError));
  EXPECT_NE(std::string(rig.logic.last_failure().reason()).find("boot-complete"), std::string::npos)
      << rig.logic.last_failure().reason();
}

// Each reading is a newer snapshot (the session acts only on readings taken
// after the last outage, by their sequence: mutation host.cpp:380, a
// sequence that did not move, survived).
TEST(RehandHostLogic, EachReadingHasANewerSequence) {
  Rig rig;
  rig.ready();
  const uint64_t first = rig.logic.snapshot().sequence;
  rig.cycle();
  const uint64_t second = rig.logic.snapshot().sequence;
  rig.cycle();
  EXPECT_GT(second, first);
  EXPECT_GT(rig.logic.snapshot().sequence, second);
}

// A stop's 1 whose answer was lost may be on the controller: once the stop
// is no longer wanted, its 0 is written (host.cpp:311, a failed 1 that does
// not mark the command as possibly held, survived: 0x006A would stay 1 on
// the controller, the chair stopped for good while the host thinks it free).
TEST(RehandHostLogic, AStopWhoseAnswerWasLostIsReleasedWithAZero) {
  Rig rig;
  rig.ready();
  rig.press(reg::kAntiPinch, 1);
  const auto w = rig.due();  // a stop goes at once
  ASSERT_EQ(w.address, reg::kAntiPinch);
  ASSERT_EQ(w.value, 1);
  rig.answer(w, Errc::timeout);
  rig.release(reg::kAntiPinch);
  bool zero = false;
  for (const Request& x : rig.flush()) zero = zero || (x.address == reg::kAntiPinch && x.value == 0);
  for (int i = 0; i < 4 && !zero; ++i)
    for (const Request& x : rig.cycle()) zero = zero || (x.address == reg::kAntiPinch && x.value == 0);
  EXPECT_TRUE(zero);
}

// Only a press's word that fails is a press's failure (write_failed: the
// session ends the press); a 0 that fails is tried again, silently
// (host.cpp:313, `||` for `&&`, survived).
TEST(RehandHostLogic, AFailedZeroIsNoPressFailure_ItIsTriedAgain) {
  Rig rig;
  rig.ready();
  rig.press(reg::kStandSit, 1);
  rig.answer(rig.due());
  rig.release(reg::kStandSit);
  const auto zero = rig.due();
  ASSERT_EQ(zero.address, reg::kStandSit);
  ASSERT_EQ(zero.value, 0);
  rig.answer(zero, Errc::timeout);
  EXPECT_FALSE(rig.has(Event::Type::write_failed));
  bool again = false;
  for (const Request& x : rig.flush()) again = again || (x.address == reg::kStandSit && x.value == 0);
  EXPECT_TRUE(again);
  // A press's word that fails is told.
  rig.press(reg::kSeatLift, 1);
  const auto word = rig.due();
  ASSERT_EQ(word.address, reg::kSeatLift);
  rig.answer(word, Errc::timeout);
  EXPECT_TRUE(rig.has(Event::Type::write_failed, reg::kSeatLift));
}

// A poll answered with the wrong number of registers is a failed poll: no
// reading, and three make a 1010 as three unanswered ones do (host.cpp:349
// and :354, such an answer taken as a reading or not counted, survived).
TEST(RehandHostLogic, APollOfTheWrongSizeIsAFailure_ThreeMakeA1010) {
  Rig rig;
  rig.ready();
  const uint64_t sequence = rig.logic.snapshot().sequence;
  for (int i = 0; i < 3; ++i) {
    rig.t = std::max(rig.t, rig.logic.wake_at());
    const auto p = rig.due();
    ASSERT_EQ(p.kind, Kind::poll);
    rig.logic.on_result(rig.t, {}, std::span(rig.table1.data(), 10));
    EXPECT_EQ(rig.logic.connected(), i < 2) << "poll " << i + 1;
  }
  EXPECT_EQ(rig.logic.snapshot().sequence, sequence) << "no reading taken from them";
  EXPECT_EQ(rig.logic.active_error(), kMasterCommunicationError);
  EXPECT_EQ(rig.logic.last_failure().code(), Errc::unexpected_response);
}

// A press the chair does not start ends at the poll that falls on its start
// timeout, not one poll later (host.cpp:408, the deadline's `>=` as `>`,
// survived).
TEST(RehandHostLogic, APressTheChairDoesNotStartEndsAtThePollOnItsDeadline) {
  Rig rig;
  rig.ready();
  rig.t = rig.logic.wake_at();  // at the next poll's time
  rig.press(reg::kStandSit, 1);
  const auto writes = rig.cycle();  // the word goes before this poll, at rig.t
  ASSERT_FALSE(writes.empty());
  ASSERT_EQ(writes.front().address, reg::kStandSit);
  const auto written = rig.t;
  for (int n = 0; !rig.has(Event::Type::chair_stopped, reg::kStandSit); ++n) {
    ASSERT_LT(n, 100) << "the press never ends";
    rig.cycle();
  }
  EXPECT_EQ(rig.t - written, HostOptions{}.start_timeout);
}

// ---------------------------------------------------------------- D-14: a phone drives at speed level 1
// HostCore, the logic and the session joined, on virtual time: what goes on
// the wire when a phone takes and gives up the driver's seat.

struct CoreRig {
  HostCore core{HostOptions{}};
  HostLogic::TimePoint t{std::chrono::hours(1)};
  std::array<uint16_t, reg::kStatusCount> table1 = Rig{}.table1;
  std::vector<Request> writes;                    ///< every write sent, in order
  std::vector<HostLogic::TimePoint> write_times;  ///< when each of `writes` was sent
  /// For each of `writes`: how long after the answer before it it was sent.
  std::vector<HostLogic::TimePoint::duration> answered_before;
  HostLogic::TimePoint last_answer{};
  /// The controller's answer to a write (an exception, a timeout), or none.
  std::function<Error(const Request&)> answer_write = [](const Request&) { return Error(); };
  bool dead = false;  ///< nothing answers

  CoreRig() {
    run_for(200ms);
    EXPECT_TRUE(core.logic().connected());
    core.session().join(kDisplay, ClientKind::display);
    core.session().join(kPhone, ClientKind::phone);
    clear_writes();
  }
  void clear_writes() {
    writes.clear();
    write_times.clear();
    answered_before.clear();
  }
  // Every request due until `t + d`, answered (each takes 5 ms on the wire).
  // After an answer it waits for the core's wake-up, as a driver that sleeps
  // until wake_at() does (the simulation's), so a stop the answer made owed
  // goes out only if wake_at() says so.
  void run_for(HostLogic::TimePoint::duration d) {
    const auto end = t + d;
    for (int n = 0; n < 100 * kMaxSteps; ++n) {
      const auto r = core.next(t);
      if (!r) {
        const auto at = core.wake_at();
        if (at >= end || t >= end) {
          t = end;
          return;
        }
        t = std::max(t + 1ms, at);
        continue;
      }
      if (r->kind == Kind::write) {
        writes.push_back(*r);
        write_times.push_back(t);
        answered_before.push_back(t - last_answer);
      }
      t += dead ? 100ms : 5ms;
      last_answer = t;  // a dead link: each request waits out its response timeout
      const Error e = dead ? Error(Errc::timeout) : r->kind == Kind::write ? answer_write(*r) : Error();
      if (e || r->kind == Kind::write) {
        core.on_result(t, e);
      } else {
        core.on_result(
            t, e, r->kind == Kind::poll ? std::span<const uint16_t>(table1) : std::span(table1.data(), 1));
      }
      if (const auto at = core.wake_at(); at > t) {
        if (at >= end) {
          t = end;
          return;
        }
        t = at;
      }
    }
    ADD_FAILURE() << "requests without end";
  }
  // Every request due at exactly `at` (time stands still: each is answered
  // at once), as a driver woken at that instant would send them.
  void step_at(HostLogic::TimePoint at) {
    t = std::max(t, at);
    for (int n = 0; auto r = core.next(t); ++n) {
      if (n > kMaxSteps) {
        ADD_FAILURE() << "requests without end at one instant";
        return;
      }
      if (r->kind == Kind::write) {
        writes.push_back(*r);
        write_times.push_back(t);
        answered_before.push_back(t - last_answer);
        core.on_result(t, answer_write(*r));
      } else {
        core.on_result(
            t, {}, r->kind == Kind::poll ? std::span<const uint16_t>(table1) : std::span(table1.data(), 1));
      }
      last_answer = t;
    }
  }
  // How many writes to `address` were sent.
  size_t count(uint16_t address) const {
    return static_cast<size_t>(
        std::count_if(writes.begin(), writes.end(), [&](const Request& w) { return w.address == address; }));
  }
  // Where `address` = `value` was first written, or -1.
  int written_at(uint16_t address, uint16_t value) const {
    for (size_t i = 0; i < writes.size(); ++i)
      if (writes[i].address == address && writes[i].value == value) return static_cast<int>(i);
    return -1;
  }
  static constexpr Session::ClientId kDisplay = 1, kPhone = 2;
};

TEST(RehandHostCore, APhoneDrivesAtSpeedLevelOne_TheDisplaysLevelComesBackWhenTheSeatIsFree) {
  CoreRig rig;
  ASSERT_FALSE(rig.core.queue(CoreRig::kDisplay, reg::kSpeedLevel, 3, 100));
  rig.run_for(100ms);
  EXPECT_GE(rig.written_at(reg::kSpeedLevel, 3), 0);
  EXPECT_EQ(rig.core.speed_level(), 3);

  rig.clear_writes();
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  EXPECT_EQ(rig.core.speed_level(), 1) << "level 1 from the moment the phone holds the seat";
  // The display's level while the phone drives: refused, and said why.
  const rtukit::Status refused = rig.core.queue(CoreRig::kDisplay, reg::kSpeedLevel, 4, 101);
  EXPECT_EQ(refused.code(), Errc::refused);
  EXPECT_NE(std::string(refused.reason()).find("D-14"), std::string::npos) << refused.reason();
  // Within the press's first poll period (the still table 1 of this rig
  // would then stop the press: the controller is not moving).
  rig.run_for(20ms);
  const int slow = rig.written_at(reg::kSpeedLevel, 1);
  const int drive = rig.written_at(reg::kPhoneForward, 1);
  ASSERT_GE(slow, 0) << "the controller is set to level 1";
  ASSERT_GE(drive, 0) << "then the phone drives";
  EXPECT_LT(slow, drive) << "level 1 is confirmed before the first drive word";

  // The phone lets go; 2 s later the seat is free and level 3 is back.
  rig.core.session().release(CoreRig::kPhone, 1, rig.t);
  rig.clear_writes();
  rig.run_for(1900ms);
  EXPECT_EQ(rig.written_at(reg::kSpeedLevel, 3), -1) << "not while the phone still holds the seat";
  rig.run_for(300ms);
  EXPECT_FALSE(rig.core.session().driver());
  EXPECT_GE(rig.written_at(reg::kSpeedLevel, 3), 0) << "the display's level put back";
  EXPECT_EQ(rig.core.speed_level(), 3);
}

// The state document reads one HostState: the chosen drive mode and speed
// level (the daemon kept its own copies before), the phone in the seat
// with its press, the level actually written, all from one reading.
TEST(RehandHostCore, OneStateHoldsTheChoicesThePressesAndTheDriver) {
  CoreRig rig;
  HostState st = rig.core.state();
  EXPECT_EQ(st.drive_mode, 1) << "D-7: normal until chosen";
  EXPECT_EQ(st.chosen_speed, 1);
  ASSERT_FALSE(rig.core.queue(CoreRig::kDisplay, reg::kDriveMode, 3, 100));
  ASSERT_FALSE(rig.core.queue(CoreRig::kDisplay, reg::kSpeedLevel, 4, 101));
  rig.run_for(100ms);
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  rig.core.sync(rig.t);
  st = rig.core.state();
  EXPECT_EQ(st.drive_mode, 3);
  EXPECT_EQ(st.chosen_speed, 4) << "the display's level, put back after the phone";
  EXPECT_EQ(st.speed_level, 1) << "D-14: level 1 while a phone holds the seat";
  ASSERT_TRUE(st.driver);
  EXPECT_EQ(*st.driver, CoreRig::kPhone);
  ASSERT_EQ(st.presses.size(), 1U);
  EXPECT_EQ(st.presses[0].command, reg::kPhoneForward);
  EXPECT_TRUE(st.connected);
  EXPECT_EQ(st.active_error, 0);
  // A refused drive mode (not in its row) changes nothing.
  EXPECT_TRUE(rig.core.queue(CoreRig::kDisplay, reg::kDriveMode, 9, 102));
  EXPECT_EQ(rig.core.state().drive_mode, 3);
}

// A pulse is two writes, the phone's light 2 then 0 (D-4: the seed prints
// 2 for on) and a signal 1 then 0, under one ticket whose outcome reaches
// the caller (the HostCore mutants of host.cpp:526 and :545, the result
// kept back and the pulse's values, survived the mutation run).
TEST(RehandHostCore, APulseIsTwoWritesUnderOneTicket_ItsOutcomeIsPassedOn) {
  CoreRig rig;
  ASSERT_FALSE(rig.core.queue(CoreRig::kPhone, reg::kPhoneLight, 1, 41));
  ASSERT_FALSE(rig.core.queue(CoreRig::kPhone, reg::kPhoneLeftSignal, 1, 42));
  rig.run_for(30ms);
  std::vector<std::pair<uint16_t, uint16_t>> writes;
  for (const Request& w : rig.writes) writes.emplace_back(w.address, w.value);
  const std::vector<std::pair<uint16_t, uint16_t>> expected = {
      {reg::kPhoneLight, 2}, {reg::kPhoneLight, 0}, {reg::kPhoneLeftSignal, 1}, {reg::kPhoneLeftSignal, 0}};
  EXPECT_EQ(writes, expected);
  const auto results = rig.core.take_results();
  ASSERT_EQ(results.size(), 2U) << "one outcome per pulse";
  EXPECT_EQ(results[0].first, 41U);
  EXPECT_FALSE(results[0].second);
  EXPECT_EQ(results[1].first, 42U);
}

TEST(RehandHostCore, LevelOneNotConfirmed_NoDriveWordAndThePressEndsSayingWhy) {
  CoreRig rig;
  rig.answer_write = [](const Request& r) {
    return r.address == reg::kSpeedLevel ? Error::exception(0x04) : Error();  // the controller refuses it
  };
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  rig.run_for(100ms);
  EXPECT_GE(rig.written_at(reg::kSpeedLevel, 1), 0);
  EXPECT_EQ(rig.written_at(reg::kPhoneForward, 1), -1) << "never driven at the display's level";
  bool told = false;
  for (const Event& e : rig.core.take_events())
    told = told || (e.type == Event::Type::released && e.address == reg::kPhoneForward &&
                    e.reason.find("speed level 1") != std::string::npos);
  EXPECT_TRUE(told) << "the phone's press ends, saying why";
  EXPECT_TRUE(rig.core.session().presses().empty());
  // Tried again at the next press, not at bus speed in between.
  const size_t tries = rig.writes.size();
  rig.run_for(400ms);
  EXPECT_EQ(rig.writes.size(), tries) << "no new try without a press";
}

TEST(RehandHostCore, AfterAReconnectLevelOneIsWrittenAgainBeforeThePhoneDrivesAgain) {
  CoreRig rig;
  ASSERT_FALSE(rig.core.queue(CoreRig::kDisplay, reg::kSpeedLevel, 5, 100));
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  rig.run_for(20ms);
  ASSERT_GE(rig.written_at(reg::kPhoneForward, 1), 0);
  // The link drops (the controller may come back at any level) and returns
  // before the phone's seat is free: only the handshake can say that level 1
  // is to be written again (the mutants of host.cpp's "a handshake: level 1
  // again" survived a test whose seat had been given up by then).
  rig.dead = true;
  rig.run_for(400ms);
  ASSERT_FALSE(rig.core.logic().connected());
  rig.dead = false;
  rig.clear_writes();
  for (int n = 0; !rig.core.logic().connected(); ++n) {
    ASSERT_LT(n, 100) << "the link never comes back";
    rig.run_for(10ms);
  }
  ASSERT_TRUE(rig.core.session().driver()) << "the phone still holds the seat";
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 2, rig.t));
  rig.run_for(20ms);
  const int ready = rig.written_at(reg::kHostReady, 1);
  const int drive = rig.written_at(reg::kPhoneForward, 1);
  ASSERT_GE(ready, 0) << "the handshake";
  ASSERT_GE(drive, 0);
  int slow = -1;  // the first level 1 after the handshake
  for (int i = ready; i < static_cast<int>(rig.writes.size()) && slow < 0; ++i)
    if (rig.writes[static_cast<size_t>(i)].address == reg::kSpeedLevel &&
        rig.writes[static_cast<size_t>(i)].value == 1)
      slow = i;
  EXPECT_GE(slow, 0) << "level 1 written again after the handshake";
  EXPECT_LT(slow, drive);
}

// D-14's restore puts back a level the display chose, and only one that is
// not 1: the controller is already there (mutants of the `!= 1` in sync()
// and absorb_results() survived the mutation run: they write a needless 1).
TEST(RehandHostCore, WhenTheSeatIsFreeTheDisplaysLevelOfOneIsNotWrittenAgain) {
  CoreRig rig;  // the display never chose: its level is 1
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  rig.run_for(20ms);
  ASSERT_GE(rig.written_at(reg::kSpeedLevel, 1), 0);
  rig.core.session().release(CoreRig::kPhone, 1, rig.t);
  rig.clear_writes();
  rig.run_for(2500ms);
  ASSERT_FALSE(rig.core.session().driver());
  EXPECT_EQ(rig.count(reg::kSpeedLevel), 0U);
  EXPECT_EQ(rig.core.speed_level(), 1);
}

// The phone gives up the seat while the write of level 1 is on its way: its
// confirmation then puts the display's level back (or nothing, when that is
// 1), and no drive word follows.
TEST(RehandHostCore, TheSeatGivenUpWhileLevelOneIsOnItsWay_TheDisplaysLevelComesBack) {
  for (const uint16_t chosen : {uint16_t{3}, uint16_t{1}}) {
    SCOPED_TRACE(chosen);
    CoreRig rig;
    if (chosen != 1) {
      ASSERT_FALSE(rig.core.queue(CoreRig::kDisplay, reg::kSpeedLevel, chosen, 100));
      rig.run_for(100ms);
    }
    ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
    const auto sent = rig.core.next(rig.t);
    ASSERT_TRUE(sent);
    ASSERT_EQ(sent->address, reg::kSpeedLevel);
    ASSERT_EQ(sent->value, 1);
    rig.core.session().release(CoreRig::kPhone, 1, rig.t);
    rig.core.session().leave(CoreRig::kPhone, rig.t);
    ASSERT_FALSE(rig.core.session().driver());
    rig.t += 5ms;
    rig.core.on_result(rig.t, {});
    rig.clear_writes();
    rig.run_for(100ms);
    EXPECT_EQ(rig.count(reg::kPhoneForward), 0U);
    if (chosen == 1) {
      EXPECT_EQ(rig.count(reg::kSpeedLevel), 0U);
    } else {
      EXPECT_EQ(rig.count(reg::kSpeedLevel), 1U);
      EXPECT_GE(rig.written_at(reg::kSpeedLevel, chosen), 0) << "the display's level put back";
    }
    EXPECT_EQ(rig.core.speed_level(), chosen);
  }
}

// After the controller refused level 1, the next press tries again 500 ms
// after the refusal, to the millisecond (mutants of the 500 and of the `>=`
// survived the mutation run).
TEST(RehandHostCore, ARefusedLevelOneIsTriedAgainAtTheNextPress_500msAfterTheRefusal) {
  CoreRig rig;
  int refusals = 1;
  rig.answer_write = [&refusals](const Request& r) {
    if (r.address != reg::kSpeedLevel || refusals == 0) return Error();
    --refusals;
    return Error::exception(0x04);
  };
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  rig.run_for(20ms);
  ASSERT_EQ(rig.written_at(reg::kSpeedLevel, 1), 0);
  ASSERT_TRUE(rig.core.session().presses().empty());
  const auto refused_at = rig.write_times[0] + 5ms;  // its answer
  rig.run_for(refused_at + 400ms - rig.t);
  ASSERT_LT(rig.t, refused_at + 499ms);
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 2, rig.t));
  rig.clear_writes();
  rig.step_at(refused_at + 499ms);
  EXPECT_EQ(rig.count(reg::kSpeedLevel), 0U) << "not before 500 ms";
  rig.step_at(refused_at + 500ms);
  EXPECT_GE(rig.written_at(reg::kSpeedLevel, 1), 0) << "at 500 ms";
}

// A refused level 1 ends a press of each of the four drive commands (a
// mutant that left the last one, right, survived the mutation run).
TEST(RehandHostCore, ARefusedLevelOneEndsAPressOfEachDriveCommand) {
  for (const uint16_t command : {reg::kPhoneForward, reg::kPhoneReverse, reg::kPhoneLeft, reg::kPhoneRight}) {
    SCOPED_TRACE(command);
    CoreRig rig;
    rig.answer_write = [](const Request& r) {
      return r.address == reg::kSpeedLevel ? Error::exception(0x04) : Error();
    };
    ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, command, 1, 1, rig.t));
    rig.run_for(100ms);
    EXPECT_EQ(rig.count(command), 0U);
    EXPECT_TRUE(rig.core.session().presses().empty());
  }
}

// A drive word the controller refuses ends the press at once, saying why
// (the session is told of the failed write).
TEST(RehandHostCore, ADriveWordTheControllerRefusesEndsThePressAtOnce) {
  CoreRig rig;
  rig.answer_write = [](const Request& r) {
    return r.address == reg::kPhoneForward && r.value != 0 ? Error::exception(0x04) : Error();
  };
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  rig.run_for(30ms);  // well inside the press's lease: only the refusal can end it
  ASSERT_GE(rig.written_at(reg::kPhoneForward, 1), 0);
  EXPECT_TRUE(rig.core.session().presses().empty());
  bool told = false;
  for (const Event& e : rig.core.take_events())
    told = told || (e.type == Event::Type::released && e.address == reg::kPhoneForward && !e.reason.empty());
  EXPECT_TRUE(told);
}

// A press the chair does not start ends when the start timeout passes: the
// logic's chair_stopped reaches the session and the caller, the press's 0 is
// due at that very answer (wake_at() says so), and level 1 is written once
// for the whole drive (no event but a handshake asks for it again).
TEST(RehandHostCore, APressTheChairDoesNotStartEnds_ItsZeroGoesAtOnce) {
  CoreRig rig;  // table 1 shows a still chair throughout
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  for (int n = 0; !rig.core.session().presses().empty(); ++n) {
    ASSERT_LT(n, 30) << "the press never ends";
    rig.run_for(200ms);
    (void)rig.core.session().renew(CoreRig::kPhone, 1, rig.t);
  }
  rig.run_for(100ms);
  bool stopped = false, ended = false;
  for (const Event& e : rig.core.take_events()) {
    stopped = stopped || (e.type == Event::Type::chair_stopped && e.address == reg::kPhoneForward);
    ended = ended || (e.type == Event::Type::released && e.address == reg::kPhoneForward &&
                      e.reason.find("did not start") != std::string::npos);
  }
  EXPECT_TRUE(stopped) << "the logic's event is passed on";
  EXPECT_TRUE(ended) << "the session ended the press with the logic's reason";
  const int zero = rig.written_at(reg::kPhoneForward, 0);
  ASSERT_GE(zero, 0);
  EXPECT_EQ(rig.answered_before[static_cast<size_t>(zero)], 0ms) << "sent at the answer that ended the press";
  EXPECT_EQ(rig.count(reg::kSpeedLevel), 1U);
}

// Each of the session's events reaches the caller as its own kind.
TEST(RehandHostCore, TheSessionsEventsReachTheCallerAsTheirOwnKinds) {
  CoreRig rig;
  ASSERT_FALSE(rig.core.session().press(CoreRig::kPhone, reg::kPhoneForward, 1, 1, rig.t));
  rig.run_for(20ms);
  rig.core.session().release(CoreRig::kPhone, 1, rig.t);
  rig.core.session().stop_all(rig.t);
  rig.run_for(20ms);
  rig.core.session().lift_stop();
  rig.run_for(1s);
  std::vector<Event::Type> kinds;
  for (const Event& e : rig.core.take_events())
    if (e.type == Event::Type::driver_changed || e.type == Event::Type::released ||
        e.type == Event::Type::emergency_started || e.type == Event::Type::emergency_ended)
      kinds.push_back(e.type);
  const std::vector<Event::Type> expected = {Event::Type::driver_changed, Event::Type::released,
                                             Event::Type::emergency_started, Event::Type::emergency_ended};
  EXPECT_EQ(kinds, expected);
}

// At shutdown every press ends, its 0 is written, and then nothing more is
// due: no polls (Host::stop() writes what next() gives until it gives nothing).
TEST(RehandHostCore, AtShutdownEveryPressEnds_ItsZeroIsWritten_ThenNothingIsDue) {
  CoreRig rig;
  ASSERT_FALSE(rig.core.session().press(CoreRig::kDisplay, reg::kStandSit, 1, 1, rig.t));
  rig.run_for(20ms);
  ASSERT_GE(rig.written_at(reg::kStandSit, 1), 0);
  rig.clear_writes();
  rig.core.begin_shutdown(rig.t);
  EXPECT_TRUE(rig.core.session().presses().empty());
  int n = 0;
  for (; n < 20; ++n) {
    const auto r = rig.core.next(rig.t);
    if (!r) break;
    ASSERT_EQ(r->kind, Kind::write) << "no poll once the host stops";
    rig.writes.push_back(*r);
    rig.t += 5ms;
    rig.core.on_result(rig.t, {});
  }
  EXPECT_LT(n, 20) << "next() never ran dry";
  EXPECT_GE(rig.written_at(reg::kStandSit, 0), 0);
}

// A one-shot still queued when the host stops fails at once, and its outcome
// is handed on (take_results() looks at the logic itself: after
// begin_shutdown() no answer comes to pass it on; the mutant without that
// look survived, leaving the caller to its time-out).
TEST(RehandHostCore, AtShutdownAQueuedOneShotFails_ItsOutcomeIsHandedOn) {
  CoreRig rig;
  ASSERT_FALSE(rig.core.queue(CoreRig::kDisplay, reg::kSpeedLevel, 3, 77));
  rig.core.begin_shutdown(rig.t);
  const auto results = rig.core.take_results();
  ASSERT_EQ(results.size(), 1U);
  EXPECT_EQ(results[0].first, 77U);
  EXPECT_TRUE(results[0].second) << "failed, not done";
}

}  // namespace
}  // namespace rtukit::rehand6600
