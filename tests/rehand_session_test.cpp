// The remote-control rules (rehand6600/session.hpp) on virtual time: every
// press, lease, lapse and loss of control checked to the millisecond, with
// no thread, bus or sleep. Each finding of the trusted-remote review that is
// a rule is here: a late renewal after a lapse, 1 Hz renewals, stand/sit
// latching, a second phone taking a held command, the emergency stop on a
// lost phone.
#include <gtest/gtest.h>

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

  Rig() {
    session.join(kDisplay, ClientKind::display);
    session.join(kPhone, ClientKind::phone);
    session.join(kPhone2, ClientKind::phone);
    poll();
  }
  void poll() { session.on_status(status, error, t); }
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
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1) << "0x006A: the controller brakes at the emergency rate (D-9)";
  EXPECT_EQ(r.session.wanted(reg::kPhoneForward), 0);
  EXPECT_EQ(r.session.wanted(reg::kLegRotate), 0) << "every other press ends: none restarts after the stop";
  // Nothing new starts while the chair is being stopped.
  EXPECT_EQ(r.session.press(kDisplay, reg::kSeatLift, 2, 2, r.t).code(), Errc::refused);
  r.advance(500ms);
  EXPECT_EQ(r.session.wanted(reg::kAntiPinch), 1) << "held while the chair still moves";
  r.status.regs[reg::kMotion] = 1;
  r.status.regs[reg::kSpeed] = 0;
  r.advance(100ms);
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

TEST(RehandSession, TheStopButtonEndsEveryPressOfEveryClient) {
  Rig r;
  ASSERT_FALSE(r.session.press(kDisplay, reg::kBackrest, 2, 1, r.t));
  ASSERT_FALSE(r.session.press(kPhone, reg::kPhoneHorn, 1, 1, r.t));
  r.session.stop_all(r.t);
  EXPECT_TRUE(r.session.presses().empty());
  EXPECT_EQ(r.session.wanted(reg::kBackrest), 0);
  EXPECT_EQ(r.session.wanted(reg::kPhoneHorn), 0);
}

TEST(RehandSession, PhoneDrivingRules_OnePlaceWithTheirReasons) {
  const auto refused = [](Rig& r, const char* why) {
    const rtukit::Status e = r.session.press(kPhone, reg::kPhoneForward, 1, 100, r.t);
    EXPECT_EQ(e.code(), Errc::refused) << why;
    EXPECT_NE(e.reason().find(why), std::string::npos) << e.reason();
    EXPECT_EQ(r.session.disabled().drive.find(why) != std::string::npos, true) << r.session.disabled().drive;
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

}  // namespace
}  // namespace rtukit::rehand6600
