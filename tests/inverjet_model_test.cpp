// The Inverjet model on a virtual clock: seed frames byte for byte through
// the slave engine, the state machine table-driven, exceptions, persistence
// rules, the motor model. No I/O, no sleeping: device time is a number.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "rtukit/core/slave.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "wire.hpp"

namespace rtukit::inverjet {
namespace {

using test::bytes;
using test::hex;

// CRC-16/Modbus written out bit by bit, independent of the code under test.
std::vector<uint8_t> with_crc(std::vector<uint8_t> b) {
  uint16_t c = 0xFFFF;
  for (uint8_t x : b) {
    c ^= x;
    for (int i = 0; i < 8; ++i)
      c = (c & 1) ? static_cast<uint16_t>((c >> 1) ^ 0xA001) : static_cast<uint16_t>(c >> 1);
  }
  b.push_back(static_cast<uint8_t>(c & 0xFF));
  b.push_back(static_cast<uint8_t>(c >> 8));
  return b;
}

// The machine behind the slave engine, wired like the simulator: the
// address moves after the response. Time is `now`, moved by hand.
struct Rig {
  // `plans`: training plans stored before power-on (plan number, segments).
  explicit Rig(const std::vector<std::pair<unsigned, std::vector<Segment>>>& plans = {}) : machine(0) {
    for (const auto& [n, segs] : plans) {
      for (unsigned k = 0; k < kSegmentsPerPlan; ++k) {
        const Segment seg = k < segs.size() ? segs[k] : Segment{};
        machine.image().set(reg::plan_speed(n), seg.speed, k);
        machine.image().set(reg::plan_end(n), seg.end, k);
      }
    }
    (void)engine.add_unit(UnitId{static_cast<uint8_t>(machine.stored(reg::address))}, machine);
  }
  // The persisted words: what a state file would hold.
  std::vector<uint16_t> persisted() const {
    std::vector<uint16_t> out;
    for (const Row& r : kRows) {
      if (!r.has(profile::kPersisted)) continue;
      for (unsigned i = 0; i < r.repeat; ++i) out.push_back(static_cast<uint16_t>(machine.image().get(r, i)));
    }
    return out;
  }
  std::string send(const std::string& frame) {
    machine.advance_to(now);  // as the simulator host does before every request
    const auto adu = bytes(frame);
    std::array<uint8_t, 256> out{};
    const auto [n, handled] = engine.handle_rtu(adu, out);
    if (handled) {
      const auto change = machine.take_link_change();
      if (change.address)
        (void)engine.change_unit_address(UnitId{unit}, UnitId{*change.address}), unit = *change.address;
      if (change.baud) baud = *change.baud;
    }
    return hex({out.data(), n});
  }
  Errc write(uint16_t address, std::vector<uint16_t> values) {
    machine.advance_to(now);
    return machine.write_holding(address, values);
  }
  uint16_t holding(uint16_t address) {
    machine.advance_to(now);
    std::array<uint16_t, 1> v{};
    EXPECT_EQ(machine.read_holding(address, v), Errc::ok);
    return v[0];
  }
  uint16_t input(uint16_t address) {
    machine.advance_to(now);
    std::array<uint16_t, 1> v{};
    EXPECT_EQ(machine.read_input(address, v), Errc::ok);
    return v[0];
  }
  void at(uint64_t ms) {
    now = ms;
    machine.advance_to(now);
  }

  uint64_t now = 0;
  Machine machine;
  SlaveEngine engine;
  uint8_t unit = kDefaultAddress;
  uint32_t baud = 9600;
};

// ------------------------------------------------------------ seed frames

TEST(InverjetSeed, ReadAddress_AnswersDefault21) {
  Rig rig;
  EXPECT_EQ(rig.send("15 03 00 00 00 01 87 1E"), "15 03 02 00 15 49 88");
}

TEST(InverjetSeed, WriteAddress12_EchoFromOldAddressThenOnlyNewAnswers) {
  Rig rig;
  EXPECT_EQ(rig.send("15 06 00 00 00 0C 8A DB"), "15 06 00 00 00 0C 8A DB");
  EXPECT_EQ(rig.send("15 03 00 00 00 01 87 1E"), "");  // 0x15 is gone
  const std::vector<uint16_t> factory = Rig().persisted();
  EXPECT_EQ(rig.send("0C 03 00 00 00 01 85 17"), "0C 03 02 00 0C 95 80");
  EXPECT_EQ(rig.machine.stored(reg::address), 12);
  EXPECT_NE(rig.persisted(), factory);  // the simulator host saves it
}

TEST(InverjetSeed, ReadAndWriteBaud_9600IsCode3) {
  Rig rig;
  EXPECT_EQ(rig.send("15 03 00 01 00 01 D6 DE"), "15 03 02 00 03 C8 46");
  EXPECT_EQ(rig.send("15 06 00 01 00 03 9B 1F"), "15 06 00 01 00 03 9B 1F");
  EXPECT_EQ(rig.baud, 9600u);  // unchanged: no link change
}

TEST(InverjetSeed, ReadControlBlock_OffAtPowerOn) {
  Rig rig;
  EXPECT_EQ(rig.send("15 03 00 21 00 04 17 17"), "15 03 08 00 00 00 00 00 00 00 00 D4 27");  // D-12
}

TEST(InverjetSeed, FreeInitialFc06_WaitsThreeSecondsThenRuns) {
  Rig rig;
  EXPECT_EQ(rig.send("15 06 00 22 00 01 EB 14"), "15 06 00 22 00 01 EB 14");
  EXPECT_EQ(rig.holding(reg::kState), 1);
  rig.at(2999);
  EXPECT_EQ(rig.holding(reg::kState), 1);
  rig.at(3000);
  EXPECT_EQ(rig.holding(reg::kState), 2);
}

TEST(InverjetSeed, FreeRunningFc06_StartsAtOnce) {
  Rig rig;
  EXPECT_EQ(rig.send("15 06 00 22 00 03 6A D5"), "15 06 00 22 00 03 6A D5");
  EXPECT_EQ(phase_of(rig.holding(reg::kState)), Phase::starting);  // ramping
  EXPECT_EQ(rig.holding(reg::kSpeed), 50);                         // free-mode memory
  rig.at(10000);
  EXPECT_EQ(rig.holding(reg::kState), 3);
  EXPECT_EQ(rig.holding(reg::kRunTime), 10);
}

// Each FC10 example of sections 3.2.3.3 and 3.2.3.4, in the document's
// short form and in the standard form: response and effect.
struct Fc10Case {
  const char* name;
  const char* short_form;
  uint16_t quantity;
  uint16_t mode, state, speed, time;  // read back at once
};

class InverjetSeedFc10 : public ::testing::TestWithParam<Fc10Case> {};

TEST_P(InverjetSeedFc10, BothForms_StandardResponseAndSameEffect) {
  const Fc10Case& c = GetParam();
  const auto frame = bytes(c.short_form);
  // Standard form: insert the byte count, new CRC (independent implementation).
  std::vector<uint8_t> standard(frame.begin(), frame.begin() + 6);
  standard.push_back(static_cast<uint8_t>(2 * c.quantity));
  standard.insert(standard.end(), frame.begin() + 6, frame.end() - 2);
  const std::string response = hex(with_crc({frame.begin(), frame.begin() + 6}));
  for (const std::string& form : {std::string(c.short_form), hex(with_crc(standard))}) {
    Rig rig;
    EXPECT_EQ(rig.send(form), response) << form;
    EXPECT_EQ(rig.holding(reg::kWorkMode), c.mode) << form;
    EXPECT_EQ(rig.holding(reg::kState), c.state) << form;
    EXPECT_EQ(rig.holding(reg::kSpeed), c.speed) << form;
    EXPECT_EQ(rig.holding(reg::kRunTime), c.time) << form;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Seed, InverjetSeedFc10,
    ::testing::Values(
        Fc10Case{"FreeInitial", "15 10 00 21 00 02 00 00 00 01 25 40", 2, 0, 1, 50, 0},
        Fc10Case{"TimerInitial", "15 10 00 21 00 02 00 00 00 06 64 82", 2, 0, 6, 50, 1800},
        // The seed calls this "P1 initial" but writes 0x0C = 12, which the state
        // table names "training starting": read literally (B-6), it starts now.
        Fc10Case{"P1State12", "15 10 00 21 00 02 00 01 00 0C B5 45", 2, 1, 12, 20, 0},
        // P2 "running" (13, a training value): starts now, the motor ramps first.
        Fc10Case{"P2Running", "15 10 00 21 00 02 00 02 00 0D 84 85", 2, 2, 12, 20, 0},
        Fc10Case{"Timer80pct30min", "15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F", 4, 0, 6, 80, 1800},
        Fc10Case{"Free100pct", "15 10 00 21 00 04 00 00 00 01 00 64 00 00 60 A7", 4, 0, 1, 100, 0},
        Fc10Case{"TimerRunning80pct12min", "15 10 00 21 00 04 00 00 00 08 00 50 02 D0 FD 94", 4, 0, 7, 80,
                 720},
        // D-10: mode 1 with state 8 = P1 in the running phase.
        Fc10Case{"P1State8At50pct", "15 10 00 21 00 04 00 01 00 08 00 32 00 00 4C 76", 4, 1, 12, 50, 0},
        Fc10Case{"P1State8From12min", "15 10 00 21 00 04 00 01 00 08 00 32 02 D0 4C 8A", 4, 1, 15, 50, 720}),
    [](const auto& info) { return std::string(info.param.name); });
// (P1 from 12:00 with the factory plan of one minute has nothing left: ended.)

TEST(InverjetSeed, FlashRule_InitialWithSpeedAndTimeSavesMemory) {
  Rig rig;
  rig.send("15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F");
  EXPECT_EQ(rig.machine.stored(reg::timer_speed), 80);
  EXPECT_EQ(rig.machine.stored(reg::timer_time), 1800);
  rig.send("15 10 00 21 00 04 00 00 00 01 00 64 00 00 60 A7");
  EXPECT_EQ(rig.machine.stored(reg::free_speed), 100);
  EXPECT_EQ(rig.machine.stored(reg::free_time), 0);
  EXPECT_EQ(rig.holding(reg::kFreeSpeed), 100);
}

TEST(InverjetSeed, FlashRule_RunningAndTrainingWritesSaveNothing) {
  Rig rig;
  const std::vector<uint16_t> before = rig.persisted();
  rig.send("15 10 00 21 00 04 00 00 00 08 00 50 02 D0 FD 94");  // timer running 80 % 12:00
  rig.send("15 10 00 21 00 04 00 01 00 08 00 32 00 00 4C 76");  // P1 50 %
  rig.send("15 10 00 21 00 04 00 01 00 08 00 32 02 D0 4C 8A");  // P1 from 12:00
  EXPECT_EQ(rig.persisted(), before);
}

TEST(InverjetSeed, TimerExample_RunsAfter3sAndCountsDownFrom1800) {
  Rig rig;
  rig.send("15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F");
  rig.at(3000 + 1000);
  EXPECT_EQ(rig.holding(reg::kRunTime), 1799);
  rig.at(3000 + 1800 * 1000 - 1);
  EXPECT_EQ(rig.holding(reg::kRunTime), 1);
  EXPECT_EQ(rig.holding(reg::kState), 8);
  rig.at(3000 + 1800 * 1000);
  EXPECT_EQ(rig.holding(reg::kRunTime), 0);
  EXPECT_EQ(rig.holding(reg::kState), 10);
}

// ------------------------------------------------------------ state machine

struct Step {
  uint64_t at_ms;
  std::vector<uint16_t> write;                       ///< values at `address` (empty: only look)
  int state = -1, speed = -1, time = -1, mode = -1;  ///< expected after the step (-1: any)
  uint16_t address = reg::kWorkMode;
  Errc result = Errc::ok;
};

struct Scenario {
  const char* name;
  std::vector<std::pair<unsigned, std::vector<Segment>>> plans;  ///< plan number, segments
  std::vector<Step> steps;
};

std::vector<Segment> fifty_segments() {
  std::vector<Segment> s;
  for (uint16_t k = 0; k < 50; ++k)
    s.push_back({static_cast<uint16_t>(k * 2), static_cast<uint16_t>(60 * (k + 1))});
  return s;
}

// Listed by name (ctest -N, a failure's header), not as the object's bytes.
void PrintTo(const Scenario& c, std::ostream* os) {
  *os << c.name;
}

class InverjetStateMachine : public ::testing::TestWithParam<Scenario> {};

TEST_P(InverjetStateMachine, FollowsTheSchedule) {
  const Scenario& sc = GetParam();
  Rig rig(sc.plans);
  for (size_t i = 0; i < sc.steps.size(); ++i) {
    const Step& st = sc.steps[i];
    rig.at(st.at_ms);
    if (!st.write.empty()) ASSERT_EQ(rig.write(st.address, st.write), st.result) << "step " << i;
    if (st.state >= 0) EXPECT_EQ(rig.holding(reg::kState), st.state) << "step " << i << " at " << st.at_ms;
    if (st.speed >= 0) EXPECT_EQ(rig.holding(reg::kSpeed), st.speed) << "step " << i << " at " << st.at_ms;
    if (st.time >= 0) EXPECT_EQ(rig.holding(reg::kRunTime), st.time) << "step " << i << " at " << st.at_ms;
    if (st.mode >= 0) EXPECT_EQ(rig.holding(reg::kWorkMode), st.mode) << "step " << i << " at " << st.at_ms;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Modes, InverjetStateMachine,
    ::testing::Values(
        Scenario{"FreeInitialToEnded",
                 {},
                 {{0, {0, 1}, 1, 50, 0},
                  {2999, {}, 1, 50, 0},
                  {3000, {}, 2, 50, 0},  // starting: 50 % at 20 %/s takes 2.5 s
                  {5500, {}, 3, 50, 2},
                  {63000, {}, 3, 50, 60},                    // counts up
                  {63500, {5}, 5, 50, 60, -1, reg::kState},  // ended: time frozen
                  {90000, {}, 5, 50, 60}}},
        Scenario{"TimerInitialToEnded",
                 {},
                 {{0, {0, 6, 40, 90}, 6, 40, 90},
                  {3000, {}, 7, 40, 90},
                  {5000, {}, 8, 40, 88},
                  {92999, {}, 8, 40, 1},
                  {93000, {}, 10, 40, 0},  // exactly 3 s + 90 s
                  {200000, {}, 10, 40, 0}}},
        Scenario{"TimerPauseResume",
                 {},
                 {{0, {0, 8, 50, 60}, 7, 50, 60},
                  {10000, {}, 8, 50, 50},
                  {10000, {9}, 9, 50, 50, -1, reg::kState},
                  {40000, {}, 9, 50, 50},                    // paused: frozen
                  {40000, {8}, 7, 50, 50, -1, reg::kState},  // resumes: ramps again
                  {45000, {}, 8, 50, 45},
                  {89999, {}, 8, 50, 1},
                  {90000, {}, 10, 50, 0}}},
        Scenario{"FreePausedThenOff",
                 {},
                 {{0, {0, 3, 30}, 2, 30, 0},
                  {5000, {4}, 4, 30, 5, -1, reg::kState},
                  {6000, {0}, 0, 0, 0, 0, reg::kState}}},
        Scenario{"PlanOf3Segments",
                 {{1, {{30, 60}, {60, 120}, {40, 180}}}},
                 {{0, {1, 13}, 12, 30, 0, 1},
                  {59999, {}, 13, 30, 59},
                  {60000, {}, -1, 60, 60},
                  {120000, {}, 13, 40, 120},
                  {179999, {}, 13, 40, 179},
                  {180000, {}, 15, -1, 180}}},
        Scenario{"PlanOf50Segments",
                 {{2, fifty_segments()}},
                 {{0, {2, 13}, 12, 0, 0, 2},
                  {60000, {}, 13, 2, 60},
                  {1500000, {}, 13, 50, 1500},
                  {2999999, {}, 13, 98, 2999},
                  {3000000, {}, 15, -1, 3000}}},
        Scenario{"PlanEndsAtNonIncreasingEnd",
                 {{3, {{20, 60}, {40, 120}, {60, 100}, {80, 300}}}},
                 {{0, {3, 13}, 12, 20, 0, 3}, {119999, {}, 13, 40, 119}, {120000, {}, 15, -1, 120}}},
        Scenario{"PlanStartAt12Minutes",
                 {{1, {{20, 600}, {50, 900}, {70, 1200}}}},
                 {{0, {1, 8, 50, 720}, 12, 50, 720, 1},  // D-10: state 8 with mode 1 = P1 running
                  {179999, {}, 13, 50, 899},
                  {180000, {}, 13, 70, 900},  // next segment: the plan decides
                  {479999, {}, 13, 70, 1199},
                  {480000, {}, 15, -1, 1200}}},
        Scenario{"SpeedWriteOverridesOnlyTheCurrentSegment",
                 {{4, {{20, 60}, {30, 120}}}},
                 {{0, {4, 13}, 12, 20, 0, 4},
                  {10000, {55}, 13, 55, 10, -1, reg::kSpeed},
                  {60000, {}, 13, 30, 60}}},
        Scenario{"ModeChangeSwitchesProgram",
                 {},
                 {{0, {0, 8, 60, 100}, 7, 60, 100},
                  {10000, {0, 3}, 2, 50, 0, 0},  // timer -> free: a new run from free memory
                  {20000, {}, 3, 50, 10}}},
        Scenario{"MenuStopsTheMotor", {}, {{0, {0, 3}, 2, 50, 0}, {5000, {16}, 16, 0, 0, -1, reg::kState}}},
        Scenario{"TimerWithZeroTimeEndsAtOnce", {}, {{0, {0, 8, 50, 0}, 10, 50, 0}}},
        Scenario{
            "BadTransitionsAndValues",
            {},
            {{0, {9}, 0, 0, 0, -1, reg::kState, Errc::server_device_failure},  // pause: nothing runs
             {0, {17}, 0, -1, -1, -1, reg::kState, Errc::illegal_data_value},  // fault screen is not writable
             {0, {0, 13}, 0, -1, -1, -1, reg::kWorkMode, Errc::illegal_data_value},  // training needs a plan
             {0, {0, 8, 101, 10}, 0, 0, 0, 0, reg::kWorkMode, Errc::illegal_data_value},  // whole write
                                                                                          // refused
             {0, {0, 8, 50, 6000}, 0, 0, 0, 0, reg::kWorkMode, Errc::illegal_data_value},
             {0, {5, 3}, 0, 0, 0, 0, reg::kWorkMode, Errc::illegal_data_value}}}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(InverjetFault, InjectedWhileRunning_StopsMotorRefusesStartThenOff) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 8, 80, 600});
  rig.at(10000);
  EXPECT_GT(rig.input(reg::kMotorSpeed + 1), 0);
  rig.machine.set_injected_faults(kFaultOverCurrent);
  EXPECT_EQ(rig.input(reg::kFaults), kFaultOverCurrent);
  EXPECT_EQ(rig.holding(reg::kState), 17);
  EXPECT_EQ(rig.write(reg::kState, {8}), Errc::server_device_failure);
  EXPECT_EQ(rig.write(reg::kWorkMode, {0, 6}), Errc::server_device_failure);
  rig.at(20000);
  EXPECT_EQ(rig.input(reg::kMotorSpeed + 1), 0);  // coasted to a stop
  EXPECT_EQ(rig.holding(reg::kRunTime), 590);     // frozen when the fault came
  EXPECT_EQ(rig.write(reg::kState, {0}), Errc::ok);
  EXPECT_EQ(rig.holding(reg::kState), 17);  // the screen stays while the fault does
  rig.machine.set_injected_faults(0);
  EXPECT_EQ(rig.holding(reg::kState), 0);
  EXPECT_EQ(rig.write(reg::kState, {3}), Errc::ok);
}

TEST(InverjetFault, EveryFaultBitShowsAndDrivesState17) {
  for (const Named& c : fault_names()) {
    Rig rig;
    rig.machine.set_injected_faults(static_cast<uint16_t>(1U << c.value));
    EXPECT_EQ(rig.input(reg::kFaults), 1U << c.value) << c.name;
    EXPECT_EQ(rig.holding(reg::kState), 17) << c.name;
  }
}

TEST(InverjetFault, HotMosfetTripsThenCoolsAndClears) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 3, 60});
  rig.at(5000);
  rig.machine.set_mosfet_temperature(95.0);
  EXPECT_EQ(rig.input(reg::kFaults), kFaultMosfetTemperature);
  EXPECT_EQ(rig.holding(reg::kState), 17);
  rig.at(5000 + 60000);  // cools towards ambient (tau 60 s): below 80 degC
  EXPECT_EQ(rig.input(reg::kFaults), 0);
  EXPECT_EQ(rig.holding(reg::kState), 0);
}

// The bus's limits are inclusive: 260.0 and 360.0 V are inside, anything
// beyond sets the voltage bit (machine.cpp:414, `>` as `>=`, survived; at
// rest the bus is the mains, no sag).
TEST(InverjetFault, TheBusLimitsAreInside_BeyondThemIsAFault) {
  Rig rig;
  const struct {
    double volts;
    uint16_t faults;
  } cases[] = {{260.0, 0}, {259.9, kFaultVoltage}, {360.0, 0}, {360.1, kFaultVoltage}};
  for (const auto& c : cases) {
    rig.machine.set_mains_voltage(c.volts);
    EXPECT_EQ(rig.input(reg::kFaults), c.faults) << c.volts << " V";
  }
}

TEST(InverjetFault, MainsBrownoutSetsVoltageBit) {
  Rig rig;
  rig.machine.set_mains_voltage(230.0);
  EXPECT_EQ(rig.input(reg::kFaults), kFaultVoltage);
  rig.machine.set_mains_voltage(311.0);
  EXPECT_EQ(rig.input(reg::kFaults), 0);
}

// ------------------------------------------------------------ the second mutation sample's survivors
// Each test below failed against the mutant of devices/inverjet/src/machine.cpp
// named beside it (scripts/mutate.py --max 60 --seed 2; docs/reliability.md).

// A timer set to 1 s while it counts ends a second later, not at once
// (machine.cpp:220, "ended at time 0" as "at time 1").
TEST(InverjetTime, ATimerSetToOneSecondEndsASecondLater) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 8, 50, 720});  // timer running, 12:00
  rig.at(5000);
  ASSERT_EQ(rig.write(reg::kRunTime, {1}), Errc::ok);
  EXPECT_NE(rig.holding(reg::kState), 10);
  rig.at(6000);
  EXPECT_EQ(rig.holding(reg::kState), 10);
  EXPECT_EQ(rig.holding(reg::kRunTime), 0);
}

// A resume that carries a speed takes it, and so does a pause that carries
// a time (machine.cpp:250, the pause without its adjust(), survived).
TEST(InverjetStateRules, AResumeWithASpeedTakesIt) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 8, 50, 60});
  rig.at(10000);
  rig.write(reg::kState, {9});  // pause
  ASSERT_EQ(rig.holding(reg::kState), 9);
  ASSERT_EQ(rig.write(reg::kWorkMode, {0, 8, 70}), Errc::ok);  // resume at 70 %
  EXPECT_EQ(rig.holding(reg::kState), 7);
  EXPECT_EQ(rig.holding(reg::kSpeed), 70);
  rig.at(15000);
  ASSERT_EQ(rig.write(reg::kWorkMode, {0, 9, 70, 100}), Errc::ok);  // pause, the time set to 100 s
  EXPECT_EQ(rig.holding(reg::kState), 9);
  EXPECT_EQ(rig.holding(reg::kRunTime), 100);
}

// A plan shows its first segment's speed from the moment it is chosen,
// through the 3-s delay before it starts (machine.cpp:284, the start without
// update_plan_speed(), survived: a plan started "running" sets it again as it
// enters "starting", one started "initial" does not).
TEST(InverjetStateRules, APlanShowsItsFirstSegmentsSpeedFromTheStart) {
  for (const uint16_t state : {uint16_t{11}, uint16_t{13}}) {
    Rig rig({{1, {{40, 60}, {70, 120}}}});
    ASSERT_EQ(rig.write(reg::kWorkMode, {1, state}), Errc::ok);
    EXPECT_EQ(rig.holding(reg::kSpeed), 40) << "state " << state;
  }
}

// The MOSFET fault trips at 90.0 degC and clears below 80.0, each edge
// included as written (machine.cpp:411 and :412, the ties, survived).
TEST(InverjetFault, MosfetTripsAtNinetyAndClearsOnlyBelowEighty) {
  Rig rig;
  rig.machine.set_mosfet_temperature(89.9);
  EXPECT_EQ(rig.input(reg::kFaults), 0);
  rig.machine.set_mosfet_temperature(90.0);
  EXPECT_EQ(rig.input(reg::kFaults), kFaultMosfetTemperature);
  rig.machine.set_mosfet_temperature(80.0);
  EXPECT_EQ(rig.input(reg::kFaults), kFaultMosfetTemperature) << "80.0 is not below 80";
  rig.machine.set_mosfet_temperature(79.9);
  EXPECT_EQ(rig.input(reg::kFaults), 0);
}

// An injected fault shows at once, before any time passes (machine.cpp:439,
// the injection without update_faults(), survived).
TEST(InverjetFault, AnInjectedFaultShowsAtOnce) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 3, 60});
  rig.at(5000);
  rig.machine.set_injected_faults(kFaultMosfetTemperature);
  std::array<uint16_t, 1> state{};
  ASSERT_EQ(rig.machine.read_holding(reg::kState, state), Errc::ok);  // no advance_to: the same instant
  EXPECT_EQ(state[0], 17);
}

// Temperatures lag behind the current (tau 60 s for the MOSFET, 300 s for
// the water-cooled motor): 15 s after a start at full speed both are still
// far below their equilibrium of 79 and 43 degC (machine.cpp:385 and :387,
// a lag factor that jumps to equilibrium in one step, survived).
TEST(InverjetMotor, TemperaturesLagBehindTheCurrent) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 3, 100});
  rig.at(15000);
  EXPECT_LT(rig.input(reg::kMosfetTemperature), 450);  // 0.1 degC: at most 25 + 54 x (1 - e^-0.25) = 37
  EXPECT_LT(rig.input(reg::kMotorTemperature), 300);   // at most 25 + 18 x (1 - e^-0.05) = 26
  EXPECT_GT(rig.input(reg::kMosfetTemperature), 250);  // but rising
}

// The version registers and the device identification objects (FC 2B/0E)
// read what the machine was built with, numbers of several digits included
// (machine.cpp:73, :460, :461, :463 and :474 survived: every test used V1.x).
TEST(InverjetRegisters, VersionsReadAsBuilt_ManyDigitsIncluded) {
  Versions v;
  v.display_software = (12U << 16) | 345U;
  v.display_hardware = (7U << 16) | 10U;
  v.driver_software = (3U << 16) | 1009U;
  v.driver_hardware = (65535U << 16) | 0U;
  Machine m(0, MotorModel{}, v);
  RegisterBank& bank = m;  // as the slave engine asks (FC 2B/0E)
  EXPECT_EQ(bank.device_object(2), "V12.345");
  EXPECT_EQ(bank.device_object(0x80), "V12.345");
  EXPECT_EQ(bank.device_object(0x81), "V7.10");
  EXPECT_EQ(bank.device_object(0x82), "V3.1009");
  EXPECT_EQ(bank.device_object(0x83), "V65535.0");
  std::array<uint16_t, 2> words{};
  ASSERT_EQ(m.read_input(reg::at(reg::driver_software), words), Errc::ok);
  EXPECT_EQ(words[0], 3);
  EXPECT_EQ(words[1], 1009);
}

// ------------------------------------------------------------ registers and exceptions

TEST(InverjetRegisters, ReservedAddressesAnswer02) {
  Rig rig;
  std::array<uint16_t, 2> two{};
  std::array<uint16_t, 1> one{};
  for (uint16_t a : {0x0005, 0x0020, 0x0025, 0x007F, 0x0084, 0x00FF, 0x0164, 0x017F, 0x01E4, 0x02E4, 0x0300})
    EXPECT_EQ(rig.machine.read_holding(a, one), Errc::illegal_data_address) << a;
  EXPECT_EQ(rig.machine.read_holding(0x0004, two), Errc::illegal_data_address);  // touches 0x0005
  EXPECT_EQ(rig.machine.read_holding(0x0020, two), Errc::illegal_data_address);
  EXPECT_EQ(rig.machine.read_input(0x0010, two), Errc::illegal_data_address);
  EXPECT_EQ(rig.write(0x0005, {1}), Errc::illegal_data_address);
  EXPECT_EQ(rig.write(0x0024, {1, 2}), Errc::illegal_data_address);
  EXPECT_EQ(rig.holding(reg::kRunTime), 0);  // nothing applied
  std::array<uint16_t, 100> plan{};
  EXPECT_EQ(rig.machine.read_holding(0x0280, plan), Errc::ok);
  std::array<uint16_t, 17> inputs{};
  EXPECT_EQ(rig.machine.read_input(0, inputs), Errc::ok);
  EXPECT_EQ(inputs[0], 1);  // V1.2 (D-9: high word first)
  EXPECT_EQ(inputs[1], 2);
}

TEST(InverjetRegisters, ValuesOutOfRangeAnswer03) {
  struct W {
    uint16_t address, value;
    Errc result;
  };
  for (const W& w :
       {W{reg::kAddress, 0, Errc::illegal_data_value}, W{reg::kAddress, 255, Errc::illegal_data_value},
        W{reg::kAddress, 254, Errc::ok}, W{reg::kBaud, 5, Errc::illegal_data_value},
        W{reg::kBaud, 4, Errc::ok}, W{reg::kControlMask, 8, Errc::illegal_data_value},
        W{reg::kPairing, 3, Errc::illegal_data_value}, W{reg::kPoleCount, 4, Errc::illegal_data_value},
        W{reg::kPoleCount, 5, Errc::ok}, W{reg::kSpeed, 101, Errc::illegal_data_value},
        W{reg::kRunTime, 6000, Errc::illegal_data_value}, W{reg::kFreeSpeed, 101, Errc::illegal_data_value},
        W{reg::kTimerTime, 6000, Errc::illegal_data_value}, W{0x0100, 101, Errc::illegal_data_value},
        W{0x02E3, 6000, Errc::illegal_data_value}, W{0x02E3, 5999, Errc::ok}}) {
    Rig rig;
    EXPECT_EQ(rig.write(w.address, {w.value}), w.result)
        << std::hex << w.address << " = " << std::dec << w.value;
  }
}

TEST(InverjetRegisters, PlanWriteIsAllOrNothing) {
  Rig rig;
  std::vector<uint16_t> values(100, 10);
  values[99] = 6000;  // the last end time is out of range
  EXPECT_EQ(rig.write(reg::plan_base(2), values), Errc::illegal_data_value);
  const std::vector<uint16_t> factory = Rig().persisted();
  EXPECT_EQ(rig.machine.plan(2), default_plan());
  EXPECT_EQ(rig.persisted(), factory);
}

TEST(InverjetRegisters, ControlMaskBit1_BlocksControlButNotConfigOrReads) {
  Rig rig;
  EXPECT_EQ(rig.write(reg::kControlMask, {2}), Errc::ok);
  EXPECT_EQ(rig.write(reg::kState, {3}), Errc::server_device_failure);  // D-5
  EXPECT_EQ(rig.write(reg::kWorkMode, {0, 8, 50, 60}), Errc::server_device_failure);
  EXPECT_EQ(rig.write(reg::kFreeSpeed, {10}), Errc::server_device_failure);
  EXPECT_EQ(rig.write(reg::plan_base(1), {10, 20}), Errc::server_device_failure);
  EXPECT_EQ(rig.holding(reg::kState), 0);  // reads work
  EXPECT_EQ(rig.write(reg::kPairing, {1}), Errc::ok);
  EXPECT_EQ(rig.write(reg::kControlMask, {0}), Errc::ok);
  EXPECT_EQ(rig.write(reg::kState, {3}), Errc::ok);
  // Bits 0 and 2 (Bluetooth, Wi-Fi) do not concern Modbus.
  EXPECT_EQ(rig.write(reg::kControlMask, {5}), Errc::ok);
  EXPECT_EQ(rig.write(reg::kState, {0}), Errc::ok);
}

TEST(InverjetRegisters, PairingWindowClosesAfter60s) {
  Rig rig;
  rig.at(1000);
  EXPECT_EQ(rig.write(reg::kPairing, {2}), Errc::ok);  // D-6
  rig.at(60999);
  EXPECT_EQ(rig.holding(reg::kPairing), 2);
  rig.at(61000);
  EXPECT_EQ(rig.holding(reg::kPairing), 0);
}

TEST(InverjetRegisters, BaudChangeIsReportedForAfterTheResponse) {
  Rig rig;
  EXPECT_EQ(rig.send(hex(with_crc(bytes("15 06 00 01 00 04")))), hex(with_crc(bytes("15 06 00 01 00 04"))));
  EXPECT_EQ(rig.baud, 19200u);  // D-4
}

TEST(InverjetRegisters, TableDescribesEveryReadableAddressOnce) {
  unsigned holding = 0, input = 0;
  for (uint32_t a = 0; a <= 0xFFFF; ++a) {
    if (find_register(Table::holding, static_cast<uint16_t>(a))) ++holding;
    if (find_register(Table::input, static_cast<uint16_t>(a))) ++input;
  }
  EXPECT_EQ(holding, 5u + 4u + 4u + 4u * 100u);
  EXPECT_EQ(input, 17u);
  EXPECT_EQ(find_register("p3_end")->address, 0x0201);
  unsigned index = 0;
  EXPECT_EQ(find_register(Table::holding, 0x0263, &index)->key, "p3_end");
  EXPECT_EQ(index, 49u);
}

TEST(InverjetRegisters, FormatsValuesFromTheTable) {
  EXPECT_EQ(format_value(*find_register("state"), 8), "timer running (8)");
  EXPECT_EQ(format_value(*find_register("run_time"), 1800), "30:00");
  EXPECT_EQ(format_value(*find_register("faults"), 0x0081), "voltage, motor drive");
  EXPECT_EQ(format_value(*find_register("display_software"), 0x00010002), "V1.2");
  EXPECT_EQ(format_value(*find_register("mosfet_temperature"), 315), "31.5 degC");
  EXPECT_EQ(format_value(*find_register("motor_current"), 782), "7.82 A");
  EXPECT_EQ(*profile::parse_duration("30:00"), 1800u);
  EXPECT_EQ(*profile::parse_duration("1:30"), 90u);
  EXPECT_EQ(*profile::parse_duration("30m"), 1800u);
  EXPECT_EQ(*profile::parse_duration("90s"), 90u);
  EXPECT_EQ(*profile::parse_duration("1m30s"), 90u);
  // A bare number has no unit: refused, with an example.
  EXPECT_FALSE(profile::parse_duration("30").ok());
  EXPECT_NE(profile::parse_duration("30").error().reason().find("30:00"), std::string_view::npos);
  for (const char* bad :
       {"", "1:5", "abc", "1:60", "m", "s", "30x", "1m60s", "-5s", "1m30", ":30", "999999s"})
    EXPECT_FALSE(profile::parse_duration(bad).ok()) << bad;
}

// ------------------------------------------------------------ motor model

TEST(InverjetMotor, PlausibleAtFullSpeed) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 3, 100});
  rig.at(600000);                                     // 10 minutes
  EXPECT_EQ(rig.input(reg::kMotorSpeed + 1), 15000);  // 3000 rpm x 5 poles
  const uint32_t centiamps = rig.input(reg::kMotorCurrent + 1);
  EXPECT_EQ(centiamps, 1200u);
  const uint16_t bus = rig.input(reg::kBusVoltage);
  EXPECT_NEAR(bus, 3038, 2);  // 311 V - 0.6 V/A x 12 A
  const uint16_t mosfet = rig.input(reg::kMosfetTemperature);
  EXPECT_GT(mosfet, 700);  // approaching 25 + 4.5 x 12 = 79 degC
  EXPECT_LT(mosfet, 800);
  EXPECT_GT(rig.input(reg::kMotorTemperature), 300);
}

TEST(InverjetMotor, CurrentRisesWithSpeedAndRampsFromStandstill) {
  Rig rig;
  rig.write(reg::kWorkMode, {0, 3, 40});
  rig.at(1000);
  EXPECT_EQ(rig.input(reg::kMotorSpeed + 1), 3000);  // 20 % after 1 s of ramp
  rig.at(10000);
  const uint16_t at40 = rig.input(reg::kMotorCurrent + 1);
  rig.write(reg::kSpeed, {80});
  rig.at(20000);
  const uint16_t at80 = rig.input(reg::kMotorCurrent + 1);
  EXPECT_GT(at80, 2 * at40);
}

// A motor at rest draws nothing, and the bus then shows the mains (a mutant
// that gave a stopped motor its idle current survived: scripts/mutate.py).
TEST(InverjetMotor, AtRestItDrawsNothing) {
  Rig rig;
  rig.at(5000);
  EXPECT_EQ(rig.input(reg::kMotorCurrent + 1), 0);
  EXPECT_EQ(rig.input(reg::kBusVoltage), 3110);
  rig.write(reg::kWorkMode, {0, 3, 40});
  rig.at(10000);
  EXPECT_GT(rig.input(reg::kMotorCurrent + 1), 0);
  rig.write(reg::kState, {0});  // off: the motor coasts to a stop
  rig.at(60000);
  EXPECT_EQ(rig.input(reg::kMotorCurrent + 1), 0);
}

}  // namespace
}  // namespace rtukit::inverjet
