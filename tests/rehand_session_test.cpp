// The remote-control rules (rehand6600/session.hpp) on virtual time: every
// press, lease, lapse and loss of control checked to the millisecond, with
// no thread, bus or sleep. Each finding of the trusted-remote review that is
// a rule is here: a late renewal after a lapse, 1 Hz renewals, stand/sit
// latching, a second phone taking a held command, the emergency stop on a
// lost phone.
#include <gtest/gtest.h>

#include <functional>

#include "rtukit/devices/rehand6600/session.hpp"

namespace rtukit::rehand6600 {
namespace {

using namespace std::chrono_literals;
using Type = Session::Event::Type;

constexpr Session::ClientId kDisplay = 1, kPhone = 2, kPhone2 = 3;

struct Rig {
  Session session;
  Session::TimePoint t{std::chrono::hours(1)};
  Snapshot status = [] {
    Snapshot s;
    s.valid = true;
    s.regs[reg::kDeviceId] = kDeviceId;
    s.regs[reg::kMotion] = 1;  // static
    s.regs[reg::kClutch] = 1;  // drive
    s.regs[reg::kBattery] = 80;
    for (uint16_t a = reg::kDistanceFront; a < reg::kDistanceFront + 4; ++a) s.regs[a] = 3000;
    return s;
  }();
  uint16_t error = 0;
  bool settled = false;  ///< what HostLogic::stop_settled() would say

  Rig() {
    session.join(kDisplay, ClientKind::display);
    session.join(kPhone, ClientKind::phone);
    session.join(kPhone2, ClientKind::phone);
    poll();
  }
  // A poll: a new reading (its sequence grows, as the host's do).
  void poll() {
    ++status.sequence;
    session.on_status(status, error, t, settled);
  }
  // Time passes in steps of one poll (50 ms), as the host ticks.
  void advance(std::chrono::milliseconds d) {
    const auto end = t + d;
    while (t < end) {
      t = std::min(end, t + 50ms);
      session.tick(t);
      poll();
    }
  }
  bool ended(Session::PressId id, bool* emergency = nullptr) {
    for (const auto& e : session.take_events())
      if (e.type == Type::press_ended && e.press == id) {
        if (emergency) *emergency = e.emergency;
        return true;
      }
    return false;
  }
};

TEST(RehandSession, APressHeldByRenewalsLives_ALapseEndsItForGood_ALateRenewalNeverMoves) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 1);
  for (int i = 0; i < 20; ++i) {  // 2 s of renewals every 100 ms
    r.advance(100ms);
    ASSERT_FALSE(r.session.renew(kDisplay, 1, r.t)) << i;
    ASSERT_EQ(r.session.wanted(reg::kSeatLift), 1);
  }
  // The socket stalls: 300 ms without a renewal ends the press.
  r.advance(299ms);
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 1);
  r.advance(1ms);
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 0);
  // The stalled renewal arrives late: refused, and the chair stays still.
  const rtukit::Status late = r.session.renew(kDisplay, 1, r.t + 10ms);
  EXPECT_EQ(late.code(), Errc::refused);
  EXPECT_NE(late.reason().find("has ended"), std::string::npos) << late.reason();
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 0);
}

TEST(RehandSession, RenewalsAt1HzNeverMoveAfterTheFirstLapse) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  int moving_polls = 0;
  for (int second = 0; second < 10; ++second) {
    for (int step = 0; step < 20; ++step) {
      r.advance(50ms);
      if (r.session.wanted(reg::kPhoneForward)) ++moving_polls;
    }
    EXPECT_TRUE(r.session.renew(kPhone, 1, r.t)) << "a 1-Hz renewal was taken at second " << second;
    EXPECT_EQ(r.session.wanted(reg::kPhoneForward), 0);
  }
  // Only the first lease moved the chair: 300 ms = 5 polls of 50 ms.
  EXPECT_LE(moving_polls, 6);
}

TEST(RehandSession, StandAndSitAreHoldType_TheFingerLiftingStopsThem) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kStandSit, 1, 7, r.t));
  EXPECT_EQ(r.session.wanted(reg::kStandSit), 1);
  r.advance(100ms);
  ASSERT_FALSE(r.session.renew(kDisplay, 7, r.t));
  r.session.release(kDisplay, 7, r.t);
  EXPECT_EQ(r.session.wanted(reg::kStandSit), 0);
  bool emergency = true;
  EXPECT_TRUE(r.ended(7, &emergency));
  EXPECT_FALSE(emergency) << "a deliberate release stops at the normal rate";
  // A tap (press, no renewal) moves for one lease at most.
  ASSERT_FALSE(r.session.press(kDisplay, reg::kStandSit, 2, 8, r.t));
  r.advance(350ms);
  EXPECT_EQ(r.session.wanted(reg::kStandSit), 0);
  EXPECT_FALSE(r.session.emergency()) << "a display's lapse is a normal stop";
}

TEST(RehandSession, PressIdsOnlyGrow_AnOldIdNeverPressesAgain) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kBackrest, 1, 5, r.t));
  r.session.release(kDisplay, 5, r.t);
  EXPECT_EQ(r.session.press(kDisplay, reg::kBackrest, 1, 5, r.t).code(), Errc::invalid_argument);
  EXPECT_EQ(r.session.press(kDisplay, reg::kBackrest, 1, 4, r.t).code(), Errc::invalid_argument);
  EXPECT_EQ(r.session.wanted(reg::kBackrest), 0);
  EXPECT_FALSE(r.session.press(kDisplay, reg::kBackrest, 1, 6, r.t));
  EXPECT_EQ(r.session.wanted(reg::kBackrest), 1);
}

TEST(RehandSession, ASecondPhoneCannotTakeAHeldCommand_NorDriveWhileAnotherDrives) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  const rtukit::Status taken = r.session.press(kPhone2, reg::kPhoneForward, 1, 1, r.t);
  EXPECT_EQ(taken.code(), Errc::refused);
  EXPECT_EQ(r.session.press(kPhone2, reg::kPhoneLeft, 1, 2, r.t).code(), Errc::refused);
  // Nor renew the first phone's press by its id.
  EXPECT_TRUE(r.session.renew(kPhone2, 1, r.t));
  EXPECT_EQ(r.session.driver(), kPhone);
  // The driver's seat frees up 2 s after the phone held nothing.
  r.session.release(kPhone, 1, r.t);
  r.advance(1900ms);
  EXPECT_EQ(r.session.driver(), kPhone);
  r.advance(150ms);
  EXPECT_FALSE(r.session.driver().has_value());
  EXPECT_FALSE(r.session.press(kPhone2, reg::kPhoneLeft, 1, 3, r.t));
  EXPECT_EQ(r.session.driver(), kPhone2);
}

TEST(RehandSession, ALostPhoneStopsWithTheStopCommand_HeldUntilTheChairIsStill) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kDisplay, reg::kLegRotate, 1, 1, r.t));
  r.status.regs[reg::kMotion] = 2;
  r.status.regs[reg::kSpeed] = 6;
  r.poll();
  r.session.leave(kPhone, r.t);
  bool emergency = false;
  EXPECT_TRUE(r.ended(1, &emergency));  // (both presses have id 1; the phone's is reported first)
  EXPECT_TRUE(emergency);
  EXPECT_TRUE(r.session.emergency());
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1)
      << "0x006A: the controller brakes at the emergency rate (D-9)";
  EXPECT_EQ(r.session.wanted(reg::kPhoneForward), 0);
  EXPECT_EQ(r.session.wanted(reg::kLegRotate), 0) << "every other press ends: none restarts after the stop";
  // Nothing new starts while the chair is being stopped.
  EXPECT_EQ(r.session.press(kDisplay, reg::kSeatLift, 2, 2, r.t).code(), Errc::refused);
  r.advance(500ms);
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1) << "held while the chair still moves";
  r.status.regs[reg::kMotion] = 1;
  r.status.regs[reg::kSpeed] = 0;
  r.advance(100ms);
  EXPECT_TRUE(r.session.emergency()) << "still, but the host has not seen two still polls after the stop";
  r.settled = true;  // HostLogic: the 1 confirmed, two polls since read the chair still
  r.advance(50ms);
  EXPECT_FALSE(r.session.emergency());
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 0);
  EXPECT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 2, 3, r.t));
}

TEST(RehandSession, APhoneWhoseLeaseLapsesIsALossOfControl_ADisplaysIsNot) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneReverse, 1, 1, r.t));
  r.advance(300ms);
  EXPECT_TRUE(r.session.emergency());
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1);
  Rig d;
  ASSERT_FALSE(d.session.press(kDisplay, reg::kSeatTilt, 1, 1, d.t));
  d.advance(300ms);
  EXPECT_FALSE(d.session.emergency());
  EXPECT_EQ(d.session.wanted(reg::kAntiPinch), 0);
  EXPECT_EQ(d.session.wanted(reg::kSeatTilt), 0);
}

TEST(RehandSession, AnErrorEndsEveryPress_NothingRestartsWhenItClears_D8) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kLegRotate, 1, 1, r.t));
  r.error = 0x10C3;
  r.poll();
  EXPECT_EQ(r.session.wanted(reg::kLegRotate), 0);
  EXPECT_EQ(r.session.press(kDisplay, reg::kLegRotate, 1, 2, r.t).code(), Errc::refused);
  r.error = 0;
  r.poll();
  EXPECT_TRUE(r.session.renew(kDisplay, 1, r.t)) << "the finger still down does not press again";
  EXPECT_EQ(r.session.wanted(reg::kLegRotate), 0);
  EXPECT_FALSE(r.session.press(kDisplay, reg::kLegRotate, 1, 3, r.t)) << "a new press does";
  // The link lost (1010) is an error like any other.
  r.error = kMasterCommunicationError;
  r.poll();
  EXPECT_EQ(r.session.wanted(reg::kLegRotate), 0);
}

// The display's STOP is an emergency stop (0x006A), latched: every press
// ends, and no phone (nor the display) presses again until the display
// lifts it; 0x006A is released only once the host says the chair is still.
TEST(RehandSession, TheStopButtonIsALatchedEmergencyStop_NothingPressesUntilItIsLifted) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kBackrest, 2, 1, r.t));
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneHorn, 1, 1, r.t));
  r.session.stop_all(r.t);
  EXPECT_TRUE(r.session.presses().empty());
  EXPECT_EQ(r.session.wanted(reg::kBackrest), 0);
  EXPECT_EQ(r.session.wanted(reg::kPhoneHorn), 0);
  EXPECT_TRUE(r.session.emergency());
  EXPECT_TRUE(r.session.stop_latched());
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1) << "STOP brakes with the controller's stop command";
  // A phone press just after STOP is refused, however long the chair has been still.
  r.settled = true;
  r.advance(5s);
  const rtukit::Status phone = r.session.press(kPhone, reg::kPhoneForward, 1, 2, r.t);
  EXPECT_EQ(phone.code(), Errc::refused);
  EXPECT_NE(phone.reason().find("STOP"), std::string::npos) << phone.reason();
  EXPECT_EQ(r.session.press(kDisplay, reg::kSeatLift, 1, 2, r.t).code(), Errc::refused);
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1);
  // Lifted on the display: released at the next reading that finds the chair still.
  r.session.lift_stop();
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1) << "released by a reading, not by the tap";
  r.advance(50ms);
  EXPECT_FALSE(r.session.emergency());
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 0);
  EXPECT_TRUE(r.session.presses().empty()) << "nothing held before STOP comes back";
  EXPECT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 3, r.t));
}

// D-10, charging and push end a phone's drive press when they arise, not
// only when it starts; so does the joystick taking over.
TEST(RehandSession, WhatForbidsPhoneDrivingEndsADrivePressWhenItArises) {
  const auto ends = [](const char* why, const std::function<void(Snapshot&)>& change) {
    Rig r;
    ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t)) << why;
    r.status.regs[reg::kMotion] = 2;
    r.status.regs[reg::kSpeed] = 1;
    r.advance(100ms);
    ASSERT_FALSE(r.session.renew(kPhone, 1, r.t)) << why;
    change(r.status);
    r.poll();
    EXPECT_EQ(r.session.wanted(reg::kPhoneForward), 0) << why;
    EXPECT_FALSE(r.session.emergency()) << why << ": a rule's stop, not a loss of control";
    const rtukit::Status renewal = r.session.renew(kPhone, 1, r.t);
    EXPECT_EQ(renewal.code(), Errc::refused) << why;
  };
  ends("the seat rises", [](Snapshot& s) { s.regs[reg::kActuatorPosition] = 5; });
  ends("the charger", [](Snapshot& s) { s.regs[reg::kCharging] = 1; });
  ends("push", [](Snapshot& s) { s.regs[reg::kClutch] = 0; });
  ends("the joystick", [](Snapshot& s) { s.regs[reg::kJoystickY] = 50; });
}

// A reading from before a link loss is history: after the handshake nothing
// is allowed until the first poll after it.
TEST(RehandSession, AfterALinkLossNothingIsAllowedUntilAFreshReading) {
  Rig r;
  r.error = kMasterCommunicationError;
  r.poll();
  r.error = 0;
  // The link is back (the handshake), but the last reading is from before.
  r.session.on_status(r.status, 0, r.t, false);
  const rtukit::Status e = r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t);
  EXPECT_EQ(e.code(), Errc::refused);
  EXPECT_NE(e.reason().find("waiting for the controller"), std::string::npos) << e.reason();
  r.poll();
  EXPECT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 2, r.t));
}

// Each press has its own serial: the host writes a press's word once, so a
// new serial is the only thing that can put a word back on the wire.
TEST(RehandSession, EveryAcceptedPressHasANewSerial_TheControllerStoppingOneEndsIt) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  const auto first = r.session.hold(reg::kSeatLift);
  EXPECT_EQ(first.value, 1);
  EXPECT_NE(first.serial, 0u);
  r.advance(100ms);
  ASSERT_FALSE(r.session.renew(kDisplay, 1, r.t));
  EXPECT_EQ(r.session.hold(reg::kSeatLift).serial, first.serial) << "a renewal is the same press";
  r.session.on_controller_stop(reg::kSeatLift, "the chair stopped seat_lift by itself", r.t);
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 0);
  EXPECT_EQ(r.session.renew(kDisplay, 1, r.t).code(), Errc::refused) << "press again";
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 2, r.t));
  EXPECT_GT(r.session.hold(reg::kSeatLift).serial, first.serial);
}

// The host going away is a loss of control for a phone that drives.
TEST(RehandSession, ShutdownEndsEveryPress_APhoneDrivingLosesControl) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneLeft, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kDisplay, reg::kBackrest, 1, 1, r.t));
  r.session.shutdown(r.t);
  EXPECT_TRUE(r.session.presses().empty());
  EXPECT_TRUE(r.session.emergency());
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1);
  Rig d;
  ASSERT_FALSE(d.session.press(kDisplay, reg::kBackrest, 1, 1, d.t));
  d.session.shutdown(d.t);
  EXPECT_FALSE(d.session.emergency()) << "a display press ends normally";
  EXPECT_TRUE(d.session.presses().empty()) << "but it ends";
  EXPECT_EQ(d.session.wanted(reg::kBackrest), 0);
}

TEST(RehandSession, PhoneDrivingRules_OnePlaceWithTheirReasons) {
  const auto refused = [](Rig& r, const char* why) {
    const rtukit::Status e = r.session.press(kPhone, reg::kPhoneForward, 1, 100, r.t);
    EXPECT_EQ(e.code(), Errc::refused) << why;
    EXPECT_NE(e.reason().find(why), std::string::npos) << e.reason();
    EXPECT_EQ(r.session.disabled().drive.find(why) != std::string::npos, true) << r.session.disabled().drive;
    // The same reason as a number (what a Bluetooth phone is sent), naming the same words.
    EXPECT_EQ(r.session.disabled().drive_reason, reason_of(r.session.disabled().drive)) << why;
    EXPECT_NE(r.session.disabled().drive_reason, Reason::other) << why;
  };
  {
    Rig r;
    r.status.regs[reg::kCharging] = 1;
    r.poll();
    refused(r, "charging");
    EXPECT_EQ(r.session.press(kDisplay, reg::kStandSit, 1, 1, r.t).code(), Errc::refused);  // D-11
    EXPECT_EQ(r.session.press(kDisplay, reg::kSeatLift, 1, 2, r.t).code(), Errc::refused);
    EXPECT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 2, 3, r.t)) << "lowering stays allowed";
  }
  {
    Rig r;
    r.status.regs[reg::kClutch] = 0;
    r.poll();
    refused(r, "clutch");
  }
  {
    Rig r;
    r.status.regs[reg::kActuatorPosition] = 300;
    r.poll();
    refused(r, "not fully seated");  // D-10
  }
  {
    Rig r;
    r.status.regs[reg::kJoystickY] = 40;
    r.poll();
    refused(r, "joystick");
  }
  {
    Rig r;
    r.status.regs[reg::kMotion] = 2;
    r.status.regs[reg::kSpeed] = 3;
    r.poll();
    refused(r, "static");
  }
  {
    Rig r;
    r.error = kMasterCommunicationError;
    r.poll();
    refused(r, "1010");
  }
}

TEST(RehandSession, EachKindOfClientSendsOnlyItsCommands) {
  Rig r;
  EXPECT_EQ(r.session.press(kDisplay, reg::kPhoneForward, 1, 1, r.t).code(), Errc::invalid_argument);
  EXPECT_EQ(r.session.press(kPhone, reg::kSeatLift, 1, 1, r.t).code(), Errc::invalid_argument);
  EXPECT_EQ(r.session.press(kPhone, reg::kAntiPinch, 1, 2, r.t).code(), Errc::invalid_argument);
  EXPECT_EQ(r.session.press(kDisplay, reg::kHostReady, 1, 3, r.t).code(), Errc::invalid_argument);
  EXPECT_EQ(r.session.press(kDisplay, reg::kSeatLift, 3, 4, r.t).code(), Errc::invalid_argument);
  EXPECT_EQ(r.session.press(99, reg::kSeatLift, 1, 1, r.t).code(), Errc::invalid_argument);
  EXPECT_FALSE(r.session.check_command(kDisplay, reg::kSpeedLevel, 3));
  EXPECT_EQ(r.session.check_command(kPhone, reg::kSpeedLevel, 3).code(), Errc::invalid_argument);
  EXPECT_FALSE(r.session.check_command(kPhone, reg::kPhoneLight, 2));
  EXPECT_EQ(r.session.check_command(kDisplay, reg::kSpeedLevel, 9).code(), Errc::invalid_argument);
  EXPECT_TRUE(r.session.presses().empty());
}

TEST(RehandSession, AFailedWriteEndsThePress) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  r.session.on_write_failed(reg::kSeatLift, r.t);
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 0);
  EXPECT_TRUE(r.session.renew(kDisplay, 1, r.t));
}

TEST(RehandSession, NearObstacleWhileMoving) {
  Rig r;
  r.status.regs[reg::kDistanceFront + 2] = 400;
  r.poll();
  EXPECT_FALSE(r.session.near_obstacle()) << "static: no view by itself";
  r.status.regs[reg::kMotion] = 2;
  r.status.regs[reg::kSpeed] = 2;
  r.poll();
  EXPECT_TRUE(r.session.near_obstacle());
}

// The rules below were each left untested until a mutant of them survived
// the suite (scripts/mutate.py, docs/reliability.md "Mutation check").

// A driving phone that leaves frees the driver's seat at once: another phone
// may drive, and the display hears that nobody drives.
TEST(RehandSession, ADriverThatLeavesFreesTheSeatAtOnce) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  ASSERT_EQ(r.session.driver(), kPhone);
  r.session.leave(kPhone, r.t);
  EXPECT_FALSE(r.session.driver().has_value());
  bool nobody = false;
  for (const auto& e : r.session.take_events())
    nobody = nobody || (e.type == Type::driver_changed && e.client == 0);
  EXPECT_TRUE(nobody) << "the display is told that nobody drives";
}

// A client's new press of a command it already holds replaces the old one:
// the old press ends, its renewals are refused.
TEST(RehandSession, ANewPressOfTheSameCommandReplacesTheOld) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 2, 2, r.t));
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 2);
  EXPECT_TRUE(r.ended(1));
  EXPECT_TRUE(r.session.renew(kDisplay, 1, r.t)) << "the replaced press is over";
  EXPECT_FALSE(r.session.renew(kDisplay, 2, r.t));
  size_t held = 0;
  for (const auto& p : r.session.presses()) held += p.command == reg::kSeatLift;
  EXPECT_EQ(held, 1u);
}

// With nothing pressed, the session still wakes the host when a driving
// phone's idle time frees the driver's seat.
TEST(RehandSession, WakesWhenTheDriversIdleTimeEnds) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  r.session.release(kPhone, 1, r.t);
  ASSERT_TRUE(r.session.presses().empty());
  ASSERT_EQ(r.session.driver(), kPhone);
  const auto at = r.session.wake_at();
  ASSERT_TRUE(at.has_value());
  EXPECT_EQ(*at, r.t + SessionOptions{}.driver_idle);
}

// Each of the four sensors counts (front, rear, left, right), the last one
// too (a mutant that read three of them survived the suite: scripts/mutate.py).
TEST(RehandSession, NearObstacleOnEachOfTheFourSides) {
  for (uint16_t side = 0; side < 4; ++side) {
    Rig r;
    r.status.regs[reg::kMotion] = 2;
    r.status.regs[reg::kSpeed] = 2;
    r.poll();
    EXPECT_FALSE(r.session.near_obstacle()) << "side " << side << ": nothing near yet";
    r.status.regs[static_cast<uint16_t>(reg::kDistanceFront + side)] = 400;
    r.poll();
    EXPECT_TRUE(r.session.near_obstacle()) << "side " << side;
  }
}

// The display learns who drives: a phone's first drive press says so, once
// (a mutant that never said it survived the suite: scripts/mutate.py).
TEST(RehandSession, APhonesFirstDrivePressNamesTheDriver) {
  Rig r;
  (void)r.session.take_events();
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  size_t said = 0;
  for (const auto& e : r.session.take_events())
    if (e.type == Type::driver_changed) {
      ++said;
      EXPECT_EQ(e.client, kPhone);
    }
  EXPECT_EQ(said, 1u);
  ASSERT_FALSE(r.session.renew(kPhone, 1, r.t));
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneLeft, 1, 2, r.t));  // the same driver: nothing new
  for (const auto& e : r.session.take_events()) EXPECT_NE(e.type, Type::driver_changed);
}

// Who may send which one-shot command, each command and each kind of client
// (a mutant that let the display send every command but one survived).
TEST(RehandSession, EachKindSendsExactlyItsOneShotCommands) {
  const uint16_t local[] = {reg::kLight, reg::kDriveMode, reg::kSpeedLevel};
  const uint16_t remote[] = {reg::kPhoneLight, reg::kPhoneLeftSignal, reg::kPhoneRightSignal};
  const uint16_t neither[] = {reg::kSeatLift, reg::kPhoneForward, reg::kAntiPinch, reg::kHostReady};
  for (uint16_t c : local) {
    EXPECT_TRUE(may_send(ClientKind::display, c)) << c;
    EXPECT_FALSE(may_send(ClientKind::phone, c)) << c;
    EXPECT_TRUE(may_send(ClientKind::tool, c)) << c;
  }
  for (uint16_t c : remote) {
    EXPECT_FALSE(may_send(ClientKind::display, c)) << c;
    EXPECT_TRUE(may_send(ClientKind::phone, c)) << c;
    EXPECT_TRUE(may_send(ClientKind::tool, c)) << c;
  }
  for (uint16_t c : neither)
    for (ClientKind k : {ClientKind::display, ClientKind::phone, ClientKind::tool})
      EXPECT_FALSE(may_send(k, c)) << c << " is held, not sent";
}

// A client that leaves ends its own presses and only its own: the display
// leaving while a phone drives leaves the phone driving (and its seat), and
// the display's posture press ends without an emergency stop.
TEST(RehandSession, ALeavingClientEndsItsOwnPressesOnly) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  (void)r.session.take_events();
  r.session.leave(kDisplay, r.t);
  EXPECT_EQ(r.session.wanted(reg::kPhoneForward), 1) << "the phone still drives";
  EXPECT_EQ(r.session.driver(), kPhone) << "and keeps the driver's seat";
  EXPECT_FALSE(r.session.emergency());
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 0) << "the display's press ended with it";
  bool emergency = true;
  for (const auto& e : r.session.take_events())
    if (e.type == Type::press_ended && e.client == kDisplay) emergency = e.emergency;
  EXPECT_FALSE(emergency) << "a display leaving is no loss of control";
  EXPECT_FALSE(r.session.renew(kPhone, 1, r.t));
}

// A phone that leaves holding the horn and driving: the drive ends as a loss
// of control, the horn as a plain release (it moves nothing).
TEST(RehandSession, ALeavingPhonesDriveIsALossOfControl_ItsHornIsNot) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneHorn, 1, 2, r.t));
  (void)r.session.take_events();
  r.session.leave(kPhone, r.t);
  std::optional<bool> drive, horn;
  for (const auto& e : r.session.take_events())
    if (e.type == Type::press_ended) (e.press == 1 ? drive : horn) = e.emergency;
  ASSERT_TRUE(drive.has_value() && horn.has_value());
  EXPECT_TRUE(*drive);
  EXPECT_FALSE(*horn);
  EXPECT_TRUE(r.session.presses().empty());
}

// A press of another command does not end what the client already holds
// (two fingers on two posture buttons), and a phone's horn does not end its
// drive; only a second drive direction replaces the first.
TEST(RehandSession, APressOfAnotherCommandKeepsTheClientsOtherPresses) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kDisplay, reg::kBackrest, 1, 2, r.t));
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 1);
  EXPECT_EQ(r.session.wanted(reg::kBackrest), 1);
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneHorn, 1, 2, r.t));
  EXPECT_EQ(r.session.wanted(reg::kPhoneForward), 1);
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneLeft, 1, 3, r.t));
  EXPECT_EQ(r.session.wanted(reg::kPhoneForward), 0) << "one direction at a time";
  EXPECT_EQ(r.session.wanted(reg::kPhoneLeft), 1);
  EXPECT_EQ(r.session.wanted(reg::kPhoneHorn), 1);
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 1) << "another client's presses untouched";
}

// A renewal that comes after the lease, with no tick between (the host was
// busy), finds the press ended: it never extends a lease that has run out.
TEST(RehandSession, ARenewalPastTheLeaseWithNoTickBetweenIsRefused) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  const auto late = r.t + SessionOptions{}.lease + 1ms;
  EXPECT_TRUE(r.session.renew(kDisplay, 1, late));
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 0);
  EXPECT_TRUE(r.ended(1));
}

// The overlay says what disables the chair: the link (1010) as "no
// communication", any other error as active.
TEST(RehandSession, TheOverlaySaysWhichErrorDisablesTheChair) {
  Rig r;
  r.error = kMasterCommunicationError;
  r.poll();
  EXPECT_NE(r.session.disabled().all.find("no communication with the controller"), std::string::npos)
      << r.session.disabled().all;
  r.error = 0x10C3;
  r.poll();
  EXPECT_NE(r.session.disabled().all.find("is active"), std::string::npos) << r.session.disabled().all;
  EXPECT_EQ(r.session.disabled().all.find("no communication"), std::string::npos) << r.session.disabled().all;
  EXPECT_EQ(r.session.disabled().all_reason, Reason::error_active);
  EXPECT_EQ(r.session.disabled().drive_reason, Reason::error_active);
  r.error = kMasterCommunicationError;
  r.poll();
  EXPECT_EQ(r.session.disabled().all_reason, Reason::no_controller);
  EXPECT_EQ(r.session.disabled().raise_reason, Reason::no_controller);
}

// A release ends the press it names and nothing else: not the client's
// other press, not another client's press that has the same id.
TEST(RehandSession, AReleaseEndsOnlyThePressItNames) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  ASSERT_FALSE(r.session.press(kDisplay, reg::kBackrest, 1, 2, r.t));
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneHorn, 1, 1, r.t));
  r.session.release(kDisplay, 1, r.t);
  EXPECT_EQ(r.session.wanted(reg::kSeatLift), 0);
  EXPECT_EQ(r.session.wanted(reg::kBackrest), 1) << "the display's other press";
  EXPECT_EQ(r.session.wanted(reg::kPhoneHorn), 1) << "the phone's press 1";
  EXPECT_EQ(r.session.presses().size(), 2u);
}

// The driver's seat is freed exactly when the idle time has passed, and the
// display is told.
TEST(RehandSession, TheDriversSeatIsFreedExactlyAtTheIdleTime_AndTheDisplayIsTold) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  r.session.release(kPhone, 1, r.t);
  (void)r.session.take_events();
  const auto at = r.t + SessionOptions{}.driver_idle;
  r.session.tick(at - 1ms);
  EXPECT_EQ(r.session.driver(), kPhone);
  r.session.tick(at);
  EXPECT_FALSE(r.session.driver().has_value());
  bool told = false;
  for (const auto& e : r.session.take_events()) told = told || e.type == Type::driver_changed;
  EXPECT_TRUE(told);
}

// When an emergency stop ends (the chair still, the stop settled), the pages
// are told, so the display's banner goes.
TEST(RehandSession, TheEndOfAnEmergencyStopIsAnEvent) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  r.session.leave(kPhone, r.t);
  ASSERT_TRUE(r.session.emergency());
  (void)r.session.take_events();
  r.settled = true;
  r.poll();
  ASSERT_FALSE(r.session.emergency());
  bool told = false;
  for (const auto& e : r.session.take_events()) told = told || e.type == Type::emergency_ended;
  EXPECT_TRUE(told);
}

// The host wakes at the earliest lease end among the presses (to end a
// lapsed one on time), not only at the driver's idle time.
TEST(RehandSession, WakesAtTheEarliestLeaseEnd) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kSeatLift, 1, 1, r.t));
  r.t += 100ms;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kBackrest, 1, 2, r.t));
  const auto at = r.session.wake_at();
  ASSERT_TRUE(at.has_value());
  EXPECT_EQ(*at, r.t - 100ms + SessionOptions{}.lease);
}

// While the driving phone holds a press, the next wake-up is that press's
// lease end, not the driver's idle time counted from a press that ended
// long ago: a wake-up in the past made the host's thread spin for as long
// as a phone drove (found by RehandHostCore's rig, whose time loop hung).
TEST(RehandSession, WhileThePhoneDrivesTheWakeUpIsItsLeaseNotAnOldIdleTime) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  r.session.release(kPhone, 1, r.t);
  r.t += 1s;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 2, r.t));
  for (int i = 0; i < 50; ++i) {  // 5 s, renewed all along
    r.t += 100ms;
    ASSERT_FALSE(r.session.renew(kPhone, 2, r.t));
  }
  const auto at = r.session.wake_at();
  ASSERT_TRUE(at.has_value());
  EXPECT_EQ(*at, r.t + SessionOptions{}.lease);
  // Released: the seat frees 2 s later, and that is the wake-up.
  r.session.release(kPhone, 2, r.t);
  ASSERT_TRUE(r.session.wake_at().has_value());
  EXPECT_EQ(*r.session.wake_at(), r.t + SessionOptions{}.driver_idle);
}

// "Closer than 500 mm": 500 is not near, 499 is.
TEST(RehandSession, NearObstacleIsStrictlyCloserThanTheLimit) {
  Rig r;
  r.status.regs[reg::kMotion] = 2;
  r.status.regs[reg::kSpeed] = 2;
  r.status.regs[reg::kDistanceFront] = 500;
  r.poll();
  EXPECT_FALSE(r.session.near_obstacle());
  r.status.regs[reg::kDistanceFront] = 499;
  r.poll();
  EXPECT_TRUE(r.session.near_obstacle());
}

// The first cause of an emergency stop starts it, with its event and the
// stop command's own serial (a new word on the wire); a second cause while
// it lasts changes neither.
TEST(RehandSession, AnEmergencyStopStartsOnceWithItsEventAndSerial) {
  Rig r;
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneForward, 1, 1, r.t));
  (void)r.session.take_events();
  r.session.leave(kPhone, r.t);
  int started = 0;
  for (const auto& e : r.session.take_events()) started += e.type == Type::emergency_started;
  EXPECT_EQ(started, 1);
  const auto hold = r.session.hold(reg::kAntiPinch);
  EXPECT_EQ(hold.value, 1);
  EXPECT_NE(hold.serial, 0u);
  r.session.stop_all(r.t);
  for (const auto& e : r.session.take_events()) started += e.type == Type::emergency_started;
  EXPECT_EQ(started, 1) << "already stopping";
  EXPECT_EQ(r.session.hold(reg::kAntiPinch).serial, hold.serial) << "the same stop: not written again";
}

}  // namespace
}  // namespace rtukit::rehand6600
