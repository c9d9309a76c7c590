// The Rehand 6600 controller model on a virtual clock: the strict tables
// (exception matrix), every command's values, posture commands and limits,
// anti-pinch, pulses, phone rules, charging, lock-out and the watchdog.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "rtukit/core/slave.hpp"
#include "rtukit/devices/rehand6600/chair.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "wire.hpp"

namespace rtukit::rehand6600 {
namespace {

// A chair polled like the host does: a frame every `poll_ms` (0: a silent host).
struct Rig {
  explicit Rig(uint32_t watchdog_ms = 500) : chair(0, watchdog_ms) {}
  void run_for(uint64_t ms, uint64_t poll_ms = 50) {
    const uint64_t end = now + ms;
    while (now < end) {
      now = std::min(end, now + (poll_ms ? poll_ms : ms));
      chair.advance_to(now);
      if (poll_ms) chair.frame_received();
    }
  }
  Errc write(uint16_t address, std::vector<uint16_t> values) {
    chair.advance_to(now);
    chair.frame_received();
    return chair.write(address, values);
  }
  uint16_t at(uint16_t address) const { return chair.status(address); }

  uint64_t now = 0;
  Chair chair;
};

// ------------------------------------------------------------ tables (D-3)

TEST(RehandTables, ExceptionMatrixThroughTheEngine) {
  Rig rig;
  SlaveEngine engine;
  ASSERT_FALSE(engine.add_unit(UnitId{1}, rig.chair));  // the chair is the bank; requests feed its watchdog
  std::array<uint8_t, 256> out{};
  const auto pdu = [&](const std::string& hex) {
    const auto req = test::bytes(hex);
    const size_t n = engine.handle_pdu(UnitId{1}, req, out).length;
    return test::hex({out.data(), n});
  };
  EXPECT_EQ(pdu("03 00 00 00 01"), "03 02 00 68");           // device ID
  EXPECT_EQ(pdu("03 00 00 00 30").substr(0, 5), "03 60");    // all of table 1: 96 bytes
  EXPECT_EQ(pdu("03 00 2F 00 02"), "83 02");                 // runs into the gap
  EXPECT_EQ(pdu("03 00 30 00 01"), "83 02");                 // the gap
  EXPECT_EQ(pdu("03 00 60 00 01"), "83 02");                 // table 2 is write-only
  EXPECT_EQ(pdu("06 00 01 00 05"), "86 02");                 // table 1 is read-only
  EXPECT_EQ(pdu("06 00 40 00 01"), "86 02");                 // the gap
  EXPECT_EQ(pdu("06 00 80 00 01"), "86 02");                 // past table 2
  EXPECT_EQ(pdu("06 00 60 00 04"), "86 03");                 // drive mode 4
  EXPECT_EQ(pdu("06 00 60 00 03"), "06 00 60 00 03");        // outdoor
  EXPECT_EQ(pdu("10 00 62 00 02 04 00 01 00 07"), "90 03");  // 7 is no seat-lift value: all refused
  EXPECT_EQ(rig.chair.command(reg::kStandSit), 0);           // nothing applied
  EXPECT_EQ(pdu("10 00 7F 00 02 04 00 01 00 01"), "90 02");  // runs past 0x007F
  EXPECT_EQ(pdu("04 00 00 00 01"), "84 01");                 // only 03, 06, 10
  EXPECT_EQ(pdu("01 00 00 00 01"), "81 01");
  EXPECT_EQ(pdu("05 00 00 FF 00"), "85 01");
}

TEST(RehandTables, EveryCommandAcceptsItsValuesAndRefusesOthers) {
  for (const Register& r : registers()) {
    if (table_of(r) != Table::command) continue;
    std::vector<uint16_t> good, bad;
    if (!r.names.empty()) {
      for (const Named& c : r.names) good.push_back(c.value);
      bad = {static_cast<uint16_t>(r.names.back().value + 1), 0xFFFF};
    } else if (r.is_signed() || r.role == Kind::reserved) {
      good = {0, 1, 0x7FFF, 0xFFFF};  // any int16 / stored
    } else {
      good = {static_cast<uint16_t>(r.range.min), static_cast<uint16_t>(r.range.max)};
      bad = {static_cast<uint16_t>(r.range.min - 1), static_cast<uint16_t>(r.range.max + 1)};
    }
    for (uint16_t v : good) {
      Rig rig;
      EXPECT_EQ(rig.write(r.address, {v}), Errc::ok) << r.key << " = " << v;
      EXPECT_EQ(rig.chair.command(r.address), v) << r.key;
    }
    for (uint16_t v : bad) {
      Rig rig;
      EXPECT_EQ(rig.write(r.address, {v}), Errc::illegal_data_value) << r.key << " = " << v;
    }
  }
}

TEST(RehandTables, PowerOnState) {  // D-7
  Rig rig;
  EXPECT_EQ(rig.at(reg::kDeviceId), 0x68);
  EXPECT_EQ(rig.at(reg::kBattery), 80);
  EXPECT_EQ(rig.at(reg::kCharging), 0);
  EXPECT_EQ(rig.at(reg::kClutch), 1);
  EXPECT_EQ(rig.at(reg::kMotion), 1);
  EXPECT_EQ(rig.at(reg::kSpeed), 0);
  for (uint16_t a = reg::kActuatorPosition; a < reg::kActuatorPosition + 6; ++a) EXPECT_EQ(rig.at(a), 0);
  EXPECT_EQ(rig.chair.command(reg::kDriveMode), 1);
  EXPECT_EQ(rig.chair.command(reg::kSpeedLevel), 1);
  EXPECT_EQ(rig.at(reg::kErrorCode), 0);
}

TEST(RehandTables, ErrorTable) {
  EXPECT_EQ(error_text(0x1010), "1010 Master Error");
  EXPECT_EQ(error_text(0x10C3), "10C3 Seat lift Error");
  EXPECT_EQ(error_text(0x119A), "119A Legs Error");
  EXPECT_EQ(error_text(0x109A), "109A Legs Error");
  EXPECT_EQ(error_text(0x108D), "108D Tilt Error");
  EXPECT_EQ(error_text(0x127B), "127B Chassis motor Error");
  EXPECT_EQ(error_text(0x1234), "1234 Unknown Error");
  EXPECT_EQ(error_codes().size(), 9u + 13u + 11u + 11u + 11u + 11u + 11u + 11u);
}

// ------------------------------------------------------------ posture

struct PostureCase {
  const char* name;
  uint16_t command, value;
  std::array<int, 6> moves;  ///< +1 up, -1 down, 0 still, per actuator
  uint16_t status_register;
  uint16_t status_value;
};

// Listed by name (ctest -N, a failure's header), not as the object's bytes.
void PrintTo(const PostureCase& c, std::ostream* os) {
  *os << c.name;
}

class RehandPosture : public ::testing::TestWithParam<PostureCase> {};

TEST_P(RehandPosture, MovesTheDocumentedActuatorsAndStopsAtTheLimit) {
  const PostureCase& c = GetParam();
  Rig rig;
  // Start mid-stroke so both directions can move: 5 s of every actuator up.
  for (uint16_t cmd : {reg::kSeatLift, reg::kBackrest, reg::kSeatTilt, reg::kLegRotate, reg::kPlateTilt})
    ASSERT_EQ(rig.write(cmd, {1}), Errc::ok);
  rig.run_for(5000);
  for (uint16_t cmd = reg::kStandSit; cmd <= reg::kPlateTilt; ++cmd) ASSERT_EQ(rig.write(cmd, {0}), Errc::ok);
  rig.run_for(100);
  std::array<uint16_t, 6> before{};
  for (unsigned i = 0; i < 6; ++i) before[i] = rig.at(static_cast<uint16_t>(reg::kActuatorPosition + i));

  ASSERT_EQ(rig.write(c.command, {c.value}), Errc::ok);
  rig.run_for(1000);
  for (unsigned i = 0; i < 6; ++i) {
    const int after = rig.at(static_cast<uint16_t>(reg::kActuatorPosition + i));
    const int delta = after - before[i];
    if (c.moves[i] > 0) EXPECT_EQ(delta, 100) << "actuator " << i + 1;
    if (c.moves[i] < 0) EXPECT_EQ(delta, -100) << "actuator " << i + 1;
    if (c.moves[i] == 0) EXPECT_EQ(delta, 0) << "actuator " << i + 1;
    EXPECT_EQ(rig.at(static_cast<uint16_t>(reg::kActuatorState + i)), c.moves[i] ? 1 : 0)
        << "actuator " << i + 1;
  }
  if (c.status_register) EXPECT_EQ(rig.at(c.status_register), c.status_value);

  rig.run_for(15000);  // far past the end of the stroke
  for (unsigned i = 0; i < 6; ++i) {
    if (!c.moves[i]) continue;
    EXPECT_EQ(rig.at(static_cast<uint16_t>(reg::kActuatorPosition + i)), c.moves[i] > 0 ? 1000 : 0);
    EXPECT_EQ(rig.at(static_cast<uint16_t>(reg::kActuatorState + i)),
              c.moves[i] > 0 ? 2 : 3);  // at its limit
  }
  if (c.status_register) EXPECT_EQ(rig.at(c.status_register), 0);  // nothing moves any more
  ASSERT_EQ(rig.write(c.command, {0}), Errc::ok);
  rig.run_for(100);
  for (unsigned i = 0; i < 6; ++i) EXPECT_EQ(rig.at(static_cast<uint16_t>(reg::kActuatorState + i)), 0);
}

INSTANTIATE_TEST_SUITE_P(
    Commands, RehandPosture,
    ::testing::Values(
        PostureCase{"Stand", reg::kStandSit, 1, {1, 1, 0, 1, 0, 0}, reg::kStandStatus, 1},
        PostureCase{"Sit", reg::kStandSit, 2, {-1, -1, 0, -1, 0, 0}, reg::kStandStatus, 2},
        PostureCase{"SeatUp", reg::kSeatLift, 1, {1, 0, 0, 0, 0, 0}, reg::kSeatLiftStatus, 1},
        PostureCase{"SeatDown", reg::kSeatLift, 2, {-1, 0, 0, 0, 0, 0}, reg::kSeatLiftStatus, 2},
        PostureCase{"BackForward", reg::kBackrest, 1, {0, 1, 0, 0, 0, 0}, reg::kBackrestStatus, 1},
        PostureCase{"BackBack", reg::kBackrest, 2, {0, -1, 0, 0, 0, 0}, reg::kBackrestStatus, 2},
        PostureCase{"TiltForward", reg::kSeatTilt, 1, {0, 0, 1, 0, 0, 0}, reg::kSeatTiltStatus, 1},
        PostureCase{"TiltBack", reg::kSeatTilt, 2, {0, 0, -1, 0, 0, 0}, reg::kSeatTiltStatus, 2},
        PostureCase{"LegsUp", reg::kLegRotate, 1, {0, 0, 0, 1, 1, 0}, reg::kLegRestStatus, 1},
        PostureCase{"LegsDown", reg::kLegRotate, 2, {0, 0, 0, -1, -1, 0}, reg::kLegRestStatus, 2},
        PostureCase{"LegsExtend", reg::kLegExtend, 1, {0, 0, 0, 0, 1, 0}, reg::kLegRestStatus, 3},
        PostureCase{"LegsRetract", reg::kLegExtend, 2, {0, 0, 0, 0, -1, 0}, reg::kLegRestStatus, 3},
        PostureCase{"PlateForward", reg::kPlateTilt, 1, {0, 0, 0, 0, 0, 1}, 0, 0},
        PostureCase{"PlateBack", reg::kPlateTilt, 2, {0, 0, 0, 0, 0, -1}, 0, 0}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(RehandPostureRules, AntiPinchStopsEverything) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kSeatLiftStatus), 1);
  ASSERT_EQ(rig.write(reg::kAntiPinch, {1}), Errc::ok);
  const uint16_t at = rig.at(reg::kActuatorPosition);
  rig.run_for(2000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), at);
  EXPECT_EQ(rig.at(reg::kSeatLiftStatus), 0);
  ASSERT_EQ(rig.write(reg::kBackrest, {1}), Errc::ok);  // accepted, no effect
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition + 1), 0);
  ASSERT_EQ(rig.write(reg::kAntiPinch, {0}), Errc::ok);
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), at);  // no restart by itself (D-8)
  EXPECT_EQ(rig.chair.command(reg::kSeatLift), 0);
  ASSERT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);  // a new rising edge
  rig.run_for(1000);
  EXPECT_GT(rig.at(reg::kActuatorPosition), at);
}

TEST(RehandPostureRules, PhysicalButtonOutranksTheUi) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);
  rig.run_for(3000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), 300);
  rig.chair.press_button(reg::kSeatLift, 2);  // down, held on the chair
  // The UI's hold ends as the button is pressed, not as it is let go
  // (chair.cpp:164, the condition negated, survived the mutation run).
  EXPECT_EQ(rig.chair.command(reg::kSeatLift), 0);
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), 200);
  EXPECT_EQ(rig.at(reg::kSeatLiftStatus), 2);
  rig.chair.press_button(reg::kSeatLift, 0);
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), 200);  // the UI's hold does not come back (D-8)
  EXPECT_EQ(rig.chair.command(reg::kSeatLift), 0);
}

TEST(RehandPostureRules, OverCurrentActuatorDoesNotMove) {
  Rig rig;
  rig.chair.set_actuator_overcurrent(1, true);
  ASSERT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), 0);
  EXPECT_EQ(rig.at(reg::kActuatorState), 4);
}

// ------------------------------------------------------------ pulses

TEST(RehandPulse, TogglesOnTheRisingEdgeOnly) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kLight, {1}), Errc::ok);
  EXPECT_EQ(rig.at(reg::kMainLight), 1);
  ASSERT_EQ(rig.write(reg::kLight, {1}), Errc::ok);  // no edge
  EXPECT_EQ(rig.at(reg::kMainLight), 1);
  ASSERT_EQ(rig.write(reg::kLight, {0}), Errc::ok);
  EXPECT_EQ(rig.at(reg::kMainLight), 1);
  ASSERT_EQ(rig.write(reg::kLight, {1}), Errc::ok);
  EXPECT_EQ(rig.at(reg::kMainLight), 0);
  ASSERT_EQ(rig.write(reg::kPhoneLight, {2}), Errc::ok);  // D-4: the seed's 2
  EXPECT_EQ(rig.at(reg::kMainLight), 1);
  ASSERT_EQ(rig.write(reg::kPhoneLeftSignal, {1}), Errc::ok);
  EXPECT_EQ(rig.at(reg::kLeftSignal), 1);
  ASSERT_EQ(rig.write(reg::kPhoneRightSignal, {1}), Errc::ok);
  EXPECT_EQ(rig.at(reg::kRightSignal), 1);
  EXPECT_EQ(rig.at(reg::kLeftSignal), 0);  // one signal at a time
}

// ------------------------------------------------------------ driving

// Level 5, normal mode, the joystick full forward for 5 s: 6 km/h reached.
void FullSpeedForward(Rig& rig) {
  ASSERT_EQ(rig.write(reg::kSpeedLevel, {5}), Errc::ok);
  rig.chair.set_joystick(0, 100);
  rig.run_for(5000);
}

TEST(RehandDrive, JoystickSpeedFromLevelAndMode) {
  Rig rig;
  FullSpeedForward(rig);
  EXPECT_EQ(rig.at(reg::kMotion), 2);
  EXPECT_EQ(rig.at(reg::kSpeed), 6);  // level 5, normal
  EXPECT_EQ(rig.at(reg::kMotor1State), 1);
  ASSERT_EQ(rig.write(reg::kDriveMode, {2}), Errc::ok);  // indoor
  rig.run_for(3000);
  EXPECT_EQ(rig.at(reg::kSpeed), 4);  // 3.6 km/h
  rig.chair.set_joystick(-100, 0);
  rig.run_for(3000);
  EXPECT_EQ(rig.at(reg::kMotion), 4);  // spin left, after stopping first
  rig.chair.set_joystick(0, 0);
  rig.run_for(3000);
  EXPECT_EQ(rig.at(reg::kMotion), 1);
  EXPECT_EQ(rig.at(reg::kSpeed), 0);
}

// The joystick's dead band: a deflection of 10 is a demand, 9 is not, in
// each direction (a mutant that moved the edge survived: scripts/mutate.py).
TEST(RehandDrive, JoystickDeadBandEndsAt10) {
  const struct {
    int x, y;
    uint16_t motion;  // 1 static, 2 forward, 3 backward, 4 spin left, 5 spin right
  } cases[] = {{0, 9, 1}, {0, 10, 2}, {0, -9, 1}, {0, -10, 3}, {-9, 0, 1}, {-10, 0, 4},
               {9, 0, 1}, {10, 0, 5}, {10, 9, 5}, {-10, -9, 4}};  // 9 beside 10: still no demand
  for (const auto& c : cases) {
    Rig rig;
    rig.chair.set_joystick(c.x, c.y);
    rig.run_for(1000);
    EXPECT_EQ(rig.at(reg::kMotion), c.motion) << "joystick " << c.x << " " << c.y;
  }
}

// Turning is a third of the forward speed, reverse a half (level 5,
// normal: 6, 3 and 2 km/h; chair.cpp:235's `>` as `>=`, a turn at the
// forward speed, survived the mutation run).
TEST(RehandDrive, ReverseAtHalfAndTurningAtAThirdOfTheForwardSpeed) {
  const struct {
    int x, y;
    uint16_t motion, kmh;
  } cases[] = {{0, 100, 2, 6}, {0, -100, 3, 3}, {-100, 0, 4, 2}, {100, 0, 5, 2}};
  for (const auto& c : cases) {
    Rig rig;
    ASSERT_EQ(rig.write(reg::kSpeedLevel, {5}), Errc::ok);
    rig.chair.set_joystick(c.x, c.y);
    rig.run_for(5000);
    EXPECT_EQ(rig.at(reg::kMotion), c.motion) << c.x << " " << c.y;
    EXPECT_EQ(rig.at(reg::kSpeed), c.kmh) << c.x << " " << c.y;
  }
}

// Each of the phone's four drive commands drives its way; two that
// contradict each other stand still (chair.cpp:222 and :224, the
// contradiction rule as `&&` and reverse driving nowhere, survived).
TEST(RehandDrive, EachPhoneCommandDrivesItsWay_ContradictingOnesStandStill) {
  const struct {
    std::vector<uint16_t> commands;
    uint16_t motion;
  } cases[] = {{{reg::kPhoneForward}, 2},
               {{reg::kPhoneReverse}, 3},
               {{reg::kPhoneLeft}, 4},
               {{reg::kPhoneRight}, 5},
               {{reg::kPhoneForward, reg::kPhoneReverse}, 1},
               {{reg::kPhoneLeft, reg::kPhoneRight}, 1}};
  for (const auto& c : cases) {
    Rig rig;
    for (const uint16_t command : c.commands) ASSERT_EQ(rig.write(command, {1}), Errc::ok);
    rig.run_for(2000);
    EXPECT_EQ(rig.at(reg::kMotion), c.motion)
        << c.commands.size() << " commands, the first " << c.commands[0];
  }
}

// A write of any of the four drive commands is refused while charging (the
// range of the phone's drive commands ended one short in a mutant of
// chair.cpp:104, which survived).
TEST(RehandDrive, EachPhoneDriveCommandIsRefusedWhileCharging) {
  for (const uint16_t command : {reg::kPhoneForward, reg::kPhoneReverse, reg::kPhoneLeft, reg::kPhoneRight}) {
    Rig rig;
    rig.chair.set_charging(true);
    EXPECT_EQ(rig.write(command, {1}), Errc::server_device_failure) << command;
    EXPECT_EQ(rig.chair.command(command), 0) << command;
  }
}

// An obstacle stops motion towards it when it is closer than the stop
// distance: at exactly that distance the chair still drives, and one behind
// does not stop a turn on the spot (chair.cpp:230).
TEST(RehandDrive, AnObstacleAtExactlyTheStopDistanceDoesNotStopTheChair) {
  const struct {
    unsigned side;  // 0 front, 1 rear
    uint16_t mm;
    int x, y;
    uint16_t motion;
  } cases[] = {{0, 300, 0, 100, 2},  {0, 299, 0, 100, 1},  {1, 300, 0, -100, 3},
               {1, 299, 0, -100, 1}, {1, 100, -100, 0, 4}, {0, 100, 100, 0, 5}};
  for (const auto& c : cases) {
    Rig rig;
    rig.chair.set_distance(c.side, c.mm);
    rig.chair.set_joystick(c.x, c.y);
    rig.run_for(2000);
    EXPECT_EQ(rig.at(reg::kMotion), c.motion)
        << "side " << c.side << ", " << c.mm << " mm, " << c.x << " " << c.y;
  }
}

// The joystick's registers read its deflection clamped to -100..100
// (chair.cpp:150 and :151, the clamp's bounds off by one, survived).
TEST(RehandDrive, JoystickRegistersReadTheDeflectionClampedTo100) {
  Rig rig;
  rig.chair.set_joystick(150, -150);
  EXPECT_EQ(static_cast<int16_t>(rig.at(reg::kJoystickX)), 100);
  EXPECT_EQ(static_cast<int16_t>(rig.at(reg::kJoystickY)), -100);
  rig.chair.set_joystick(-150, 150);
  EXPECT_EQ(static_cast<int16_t>(rig.at(reg::kJoystickX)), -100);
  EXPECT_EQ(static_cast<int16_t>(rig.at(reg::kJoystickY)), 100);
}

// The joystick let go at speed: the chair coasts to a stop showing the
// motion it still has, and the phone may not drive until it is still (the
// local user had the chair; chair.cpp:252 and :261 survived).
TEST(RehandDrive, AfterTheJoystickIsLetGoTheChairCoastsAndThePhoneWaits) {
  Rig rig;
  FullSpeedForward(rig);
  ASSERT_EQ(rig.at(reg::kSpeed), 6);
  rig.chair.set_joystick(0, 0);
  rig.run_for(500);  // 6 km/h at 4 km/h/s: 4 km/h left
  EXPECT_EQ(rig.at(reg::kMotion), 2) << "still moving forward";
  EXPECT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::server_device_failure);
  rig.run_for(2000);
  EXPECT_EQ(rig.at(reg::kMotion), 1);
  EXPECT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok) << "still now: the phone may drive";
}

TEST(RehandDrive, NoDrivingWhileChargingOrInPush) {
  for (int variant = 0; variant < 2; ++variant) {
    Rig rig;
    if (variant == 0) rig.chair.set_charging(true);
    if (variant == 1) rig.chair.set_clutch_drive(false);
    rig.chair.set_joystick(0, 100);
    rig.run_for(2000);
    EXPECT_EQ(rig.at(reg::kMotion), 1) << variant;
    EXPECT_EQ(rig.at(reg::kSpeed), 0) << variant;
  }
}

TEST(RehandDrive, PhoneRefusedWhileJoystickMoves_LocalOverridesAtOnce) {
  Rig rig;
  rig.chair.set_joystick(0, 60);
  EXPECT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::server_device_failure);
  rig.chair.set_joystick(0, 0);
  rig.run_for(2000);
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);  // neutral and static
  rig.run_for(2000);
  EXPECT_EQ(rig.at(reg::kMotion), 2);
  rig.chair.set_joystick(0, -60);  // the local user takes over
  EXPECT_EQ(rig.chair.command(reg::kPhoneForward), 0);
  rig.run_for(3000);
  EXPECT_EQ(rig.at(reg::kMotion), 3);
}

TEST(RehandDrive, ObstacleAheadStops) {
  Rig rig;
  rig.chair.set_distance(0, 200);
  rig.chair.set_joystick(0, 100);
  rig.run_for(2000);
  EXPECT_EQ(rig.at(reg::kSpeed), 0);
  rig.chair.set_joystick(0, -100);  // straight to reverse: the joystick was never neutral (D-8)
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kMotion), 1);
  rig.chair.set_joystick(0, 0);
  rig.run_for(100);
  rig.chair.set_joystick(0, -100);  // backing away is fine
  rig.run_for(2000);
  EXPECT_EQ(rig.at(reg::kMotion), 3);
}

TEST(RehandDrive, BatteryDrainsMovingAndCharges) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
  rig.run_for(60000);
  EXPECT_EQ(rig.at(reg::kBattery), 77);  // 80 - 0.05 %/s x 60 s
  ASSERT_EQ(rig.write(reg::kPhoneForward, {0}), Errc::ok);
  rig.chair.set_charging(true);
  rig.run_for(100000);
  EXPECT_EQ(rig.at(reg::kBattery), 86);  // 76.98 (braking drained a little) + 0.1 %/s x 100 s
}

// ------------------------------------------------------------ safety: D-6 and D-5

TEST(RehandSafety, FaultLocksOutMotionButReleasingWorks) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
  rig.run_for(2000);
  ASSERT_GT(rig.at(reg::kSpeed), 0);
  rig.chair.set_error(0x10C3);
  EXPECT_EQ(rig.at(reg::kErrorCode), 0x10C3);
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kSpeed), 0);  // motion stops
  EXPECT_EQ(rig.write(reg::kSeatLift, {1}), Errc::server_device_failure);
  EXPECT_EQ(rig.write(reg::kPhoneReverse, {1}), Errc::server_device_failure);
  EXPECT_EQ(rig.write(reg::kPhoneForward, {0}), Errc::ok);  // releasing
  EXPECT_EQ(rig.write(reg::kLight, {1}), Errc::ok);         // not motion
  rig.chair.set_error(0);
  EXPECT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);
}

// ------------------------------------------------------------ safety: D-5a, D-8, D-9, D-10, D-11

// A chair behind the slave engine, as the bus reaches it.
struct Bus {
  Bus() { EXPECT_FALSE(engine.add_unit(UnitId{1}, rig.chair)); }
  std::string pdu(const std::string& hex) {
    rig.chair.advance_to(rig.now);
    const auto req = test::bytes(hex);
    std::array<uint8_t, 256> out{};
    const size_t n = engine.handle_pdu(UnitId{1}, req, out).length;
    return test::hex({out.data(), n});
  }
  Rig rig;
  SlaveEngine engine;
};

TEST(RehandSafety, OnlyExecutedRequestsFeedTheWatchdog_D5a) {
  Bus bus;
  ASSERT_EQ(bus.pdu("06 00 6E 00 01"), "06 00 6E 00 01");  // phone forward, executed
  // A host stuck sending requests the controller rejects, every 50 ms.
  const char* rejected[] = {"04 00 00 00 30",   // FC04: 01
                            "03 00 60 00 01",   // table 2 read: 02
                            "06 00 60 00 09",   // a value not listed: 03
                            "06 00 01 00 01"};  // table 1 write: 02
  for (int i = 0; i < 10; ++i) {
    bus.rig.now += 50;
    const std::string answer = bus.pdu(rejected[i % 4]);
    ASSERT_EQ(answer.substr(0, 1), "8") << answer;  // an exception
  }
  EXPECT_EQ(bus.rig.chair.command(reg::kPhoneForward), 0);  // a dead host
  EXPECT_EQ(bus.rig.chair.watchdog_trips(), 1u);
  // An executed poll does feed it.
  ASSERT_EQ(bus.pdu("06 00 6F 00 01"), "06 00 6F 00 01");
  for (int i = 0; i < 20; ++i) {
    bus.rig.now += 50;
    ASSERT_EQ(bus.pdu("03 00 00 00 30").substr(0, 5), "03 60");
  }
  EXPECT_EQ(bus.rig.chair.command(reg::kPhoneReverse), 1);
}

TEST(RehandSafety, ClearingAFaultRestartsNothing_PostureHeld_D8) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kLegRotate, {1}), Errc::ok);  // posture 5
  rig.run_for(1000);
  const uint16_t at = rig.at(reg::kActuatorPosition + 3);
  ASSERT_GT(at, 0);
  rig.chair.set_error(0x1093);
  rig.run_for(500);
  rig.chair.set_error(0);
  rig.run_for(2000);  // the host keeps polling
  EXPECT_EQ(rig.at(reg::kActuatorPosition + 3), at);
  EXPECT_EQ(rig.at(reg::kLegRestStatus), 0);
  EXPECT_EQ(rig.chair.command(reg::kLegRotate), 0);
}

TEST(RehandSafety, ClearingAFaultRestartsNothing_PhoneForwardHeld_D8) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
  rig.run_for(2000);
  ASSERT_GT(rig.chair.speed_kmh(), 0);
  rig.chair.set_error(0x1271);
  rig.run_for(1000);
  rig.chair.set_error(0);
  rig.run_for(3000);  // polling goes on: the chair stays put
  EXPECT_EQ(rig.chair.speed_kmh(), 0);
  EXPECT_EQ(rig.at(reg::kMotion), 1);
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);  // a new rising edge drives
  rig.run_for(1000);
  EXPECT_GT(rig.chair.speed_kmh(), 0);
}

TEST(RehandSafety, WatchdogTripNeedsANewRisingEdge_D8) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
  rig.run_for(1000);
  rig.run_for(2000, 0);  // the host stalls
  ASSERT_EQ(rig.chair.watchdog_trips(), 1u);
  rig.run_for(2000);  // it comes back and polls, without writing
  EXPECT_EQ(rig.chair.speed_kmh(), 0);
  EXPECT_EQ(rig.chair.command(reg::kPhoneForward), 0);
}

TEST(RehandSafety, JoystickMustBeNeutralOnceAfterAFault_D8) {
  Rig rig;
  rig.chair.set_joystick(0, 100);
  rig.run_for(1000);
  ASSERT_GT(rig.chair.speed_kmh(), 0);
  rig.chair.set_error(0x1271);
  rig.run_for(500);
  rig.chair.set_error(0);
  rig.run_for(2000);  // still deflected: no drive
  EXPECT_EQ(rig.chair.speed_kmh(), 0);
  EXPECT_TRUE(rig.chair.joystick_locked());
  rig.chair.set_joystick(0, 0);
  rig.run_for(100);
  EXPECT_FALSE(rig.chair.joystick_locked());
  rig.chair.set_joystick(0, 100);
  rig.run_for(1000);
  EXPECT_GT(rig.chair.speed_kmh(), 0);
}

TEST(RehandSafety, ObstacleStopDoesNotResumeWhenTheObstacleGoes_D8) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
  rig.run_for(2000);
  rig.chair.set_distance(0, 200);
  rig.run_for(100);
  EXPECT_EQ(rig.chair.command(reg::kPhoneForward), 0);
  EXPECT_TRUE(rig.chair.emergency_braking());
  rig.chair.set_distance(0, 2000);
  rig.run_for(2000);
  EXPECT_EQ(rig.chair.speed_kmh(), 0);
}

TEST(RehandSafety, FaultAndAntiPinchBrakeAtTheEmergencyRate_D9) {
  for (int kind = 0; kind < 2; ++kind) {
    Rig rig;
    ASSERT_EQ(rig.write(reg::kSpeedLevel, {5}), Errc::ok);
    ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
    rig.run_for(5000);
    ASSERT_EQ(rig.chair.speed_kmh(), 6.0);
    if (kind == 0)
      rig.chair.set_error(0x1271);
    else
      ASSERT_EQ(rig.write(reg::kAntiPinch, {1}), Errc::ok);
    rig.run_for(700);
    EXPECT_NEAR(rig.chair.speed_kmh(), 0.4, 1e-9) << kind;  // 6 - 8 km/h/s x 0.7 s
    rig.run_for(100);
    EXPECT_EQ(rig.chair.speed_kmh(), 0.0) << kind;
  }
  Rig release;  // a release brakes at the normal rate
  ASSERT_EQ(release.write(reg::kSpeedLevel, {5}), Errc::ok);
  ASSERT_EQ(release.write(reg::kPhoneForward, {1}), Errc::ok);
  release.run_for(5000);
  ASSERT_EQ(release.write(reg::kPhoneForward, {0}), Errc::ok);
  release.run_for(1000);
  EXPECT_NEAR(release.chair.speed_kmh(), 2.0, 1e-9);
}

TEST(RehandSafety, EveryStopWithinOneAndAHalfSecondsOfTheLastRequest_D9) {
  const std::vector<StoppingEntry> table = stopping_table();
  ASSERT_EQ(table.size(), 15u);  // 5 levels x 3 modes
  double worst = 0;
  for (const StoppingEntry& e : table) {
    EXPECT_LE(e.host_lost_s, 1.5) << "level " << e.level << " mode " << e.mode;
    EXPECT_GT(e.top_kmh, 0);
    worst = std::max(worst, e.host_lost_s);
  }
  EXPECT_DOUBLE_EQ(worst, 1.4);  // level 5 outdoor: 0.5 s watchdog + 7.2 / 8 s
}

TEST(RehandSafety, RaisedChairCrawlsAndThePhoneMayNotDrive_D10) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kSpeedLevel, {5}), Errc::ok);
  ASSERT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);
  rig.run_for(1000);
  ASSERT_EQ(rig.write(reg::kSeatLift, {0}), Errc::ok);
  ASSERT_FALSE(rig.chair.seated());
  EXPECT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::server_device_failure);
  rig.chair.set_joystick(0, 100);
  rig.run_for(3000);
  EXPECT_DOUBLE_EQ(rig.chair.speed_kmh(), 1.2);
  rig.chair.set_joystick(0, 0);
  rig.run_for(1000);
  ASSERT_EQ(rig.write(reg::kSeatLift, {2}), Errc::ok);  // back down
  rig.run_for(2000);
  ASSERT_TRUE(rig.chair.seated());
  ASSERT_EQ(rig.write(reg::kSeatLift, {0}), Errc::ok);
  EXPECT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
  // Raising the seat while the phone drives stops the phone.
  ASSERT_EQ(rig.write(reg::kSeatTilt, {1}), Errc::ok);
  rig.run_for(500);
  EXPECT_EQ(rig.chair.command(reg::kPhoneForward), 0);
}

TEST(RehandSafety, DeflectedJoystickAtHandshakeIsLockedUntilNeutral_D11) {
  Rig rig;
  rig.chair.set_joystick(0, 100);                        // held since before the host came up...
  ASSERT_EQ(rig.write(reg::kHostReady, {1}), Errc::ok);  // ...the handshake
  rig.run_for(1000);
  EXPECT_EQ(rig.chair.speed_kmh(), 0);
  rig.chair.set_joystick(0, 0);
  rig.run_for(50);
  rig.chair.set_joystick(0, 100);
  rig.run_for(1000);
  EXPECT_GT(rig.chair.speed_kmh(), 0);
}

TEST(RehandSafety, ChargingBlocksStandingUpAndRaisingButNotLowering_D11) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);
  rig.run_for(1000);
  ASSERT_EQ(rig.write(reg::kSeatLift, {0}), Errc::ok);
  rig.chair.set_charging(true);
  EXPECT_EQ(rig.write(reg::kStandSit, {1}), Errc::server_device_failure);
  EXPECT_EQ(rig.write(reg::kSeatLift, {1}), Errc::server_device_failure);
  rig.chair.press_button(reg::kSeatLift, 1);  // the physical button neither
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), 100);
  rig.chair.press_button(reg::kSeatLift, 0);
  EXPECT_EQ(rig.write(reg::kSeatLift, {2}), Errc::ok);  // lowering stays allowed
  rig.run_for(1000);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), 0);
  EXPECT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::server_device_failure);
}

TEST(RehandSafety, WatchdogStopsAHeldPhoneForwardWhenTheHostFallsSilent) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kSpeedLevel, {5}), Errc::ok);
  ASSERT_EQ(rig.write(reg::kPhoneForward, {1}), Errc::ok);
  rig.run_for(5000);  // a polling host: keeps moving
  ASSERT_EQ(rig.at(reg::kSpeed), 6);
  ASSERT_EQ(rig.chair.command(reg::kPhoneForward), 1);
  const uint64_t silent_from = rig.now;
  rig.run_for(499, 0);  // the host dies
  EXPECT_EQ(rig.chair.command(reg::kPhoneForward), 1);
  rig.run_for(1, 0);  // exactly the watchdog time
  EXPECT_EQ(rig.now - silent_from, 500u);
  EXPECT_EQ(rig.chair.command(reg::kPhoneForward), 0);
  EXPECT_EQ(rig.chair.watchdog_trips(), 1u);
  rig.run_for(750, 0);  // emergency braking at 8 km/h/s from 6 km/h (D-9)
  EXPECT_EQ(rig.chair.speed_kmh(), 0.0);
  EXPECT_EQ(rig.at(reg::kMotion), 1);
}

TEST(RehandSafety, WatchdogResetsPostureHoldsToo_AndCanBeDisabled) {
  Rig rig;
  ASSERT_EQ(rig.write(reg::kSeatLift, {1}), Errc::ok);
  rig.run_for(2000, 0);
  EXPECT_EQ(rig.at(reg::kActuatorPosition), 50);  // moved only until the watchdog fired
  Rig no_watchdog(0);
  ASSERT_EQ(no_watchdog.write(reg::kSeatLift, {1}), Errc::ok);
  no_watchdog.run_for(2000, 0);
  EXPECT_EQ(no_watchdog.at(reg::kActuatorPosition), 200);
}

}  // namespace
}  // namespace rtukit::rehand6600
