// The device layer's verbs and views (issue 27: cli/ holds no device logic):
// what the Inverjet's and the Rehand 6600's text front-ends print and
// refuse, on simulated values (a MachineStatus, a Snapshot) and on a slave
// behind a MemoryLink on a ManualClock: no process, no port, no sleeping.
#include <fmt/core.h>
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <sstream>
#include <string>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/devices/inverjet/plan_file.hpp"
#include "rtukit/devices/inverjet/typed.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/inverjet/views.hpp"
#include "rtukit/devices/rehand6600/device.hpp"
#include "rtukit/devices/rehand6600/motion.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/verbs.hpp"
#include "rtukit/devices/rehand6600/views.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/memory_link.hpp"

namespace rtukit {
namespace {

using namespace std::chrono_literals;
namespace ij = inverjet;
namespace rh = rehand6600;

// A generic slave at `unit` behind a MemoryLink on virtual time.
struct Rig {
  explicit Rig(uint8_t unit, size_t registers = 200) : bank(registers) {
    (void)engine.add_unit(UnitId{unit}, bank);
    auto link = std::make_unique<MemoryLink>(clock, [this](std::span<const uint8_t> request) {
      if (silent) return MemoryLink::Reply{};
      std::array<uint8_t, kMaxRtuAduSize> out{};
      const size_t n = engine.handle_rtu(request, out).length;
      return MemoryLink::Reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 2ms};
    });
    master =
        std::make_unique<Master>(std::move(link), MasterOptions{.response_timeout = 100ms, .clock = &clock});
  }
  ManualClock clock;
  MemoryBank bank;
  SlaveEngine engine;
  bool silent = false;
  std::unique_ptr<Master> master;
};

std::string bracket(std::string_view t) {
  return "[" + std::string(t) + "]";
}

void expect_at_most_80_columns(const std::string& text) {
  std::string line;
  for (std::istringstream in(text); std::getline(in, line);) EXPECT_LE(line.size(), 80U) << line;
}

// ---------------------------------------------------------------- Inverjet

ij::MachineStatus timer_run() {
  ij::MachineStatus s;
  s.state = 8;  // timer running
  s.speed = 60;
  s.run_time = 25 * 60;
  s.rpm = 1200;
  s.current_a = 3.5;
  s.mosfet_c = 41.25;
  s.motor_c = 38;
  s.bus_v = 310.4;
  s.display_software = (1U << 16) | 2;
  return s;
}

TEST(InverjetViews, TheTimeSaysWhatItCounts_TheFaultsByName) {
  const ij::MachineStatus s = timer_run();
  EXPECT_EQ(ij::version_text((1U << 16) | 2), "V1.2");
  EXPECT_EQ(ij::factory_plan_text(), "01:00 at 20 %");
  EXPECT_EQ(ij::time_text(s), "25:00 remaining");
  EXPECT_EQ(ij::faults_text(s), "none");
  ij::MachineStatus fault = s;
  fault.state = 17;  // the fault screen: nobody saw which run it was
  fault.faults = 0x0081;
  EXPECT_EQ(ij::faults_text(fault), "voltage, motor drive (0x0081)");
  EXPECT_EQ(ij::time_text(fault), "25:00 at the fault");
  EXPECT_EQ(ij::time_text(fault, ij::Family::timer), "25:00 remaining");
}

TEST(InverjetViews, ThePanelHighlightsOnlyAFault_TheLineStartsWithItsPrefix) {
  const ij::MachineStatus s = timer_run();
  const std::string calm = ij::status_panel(s, ij::Family::none, bracket);
  EXPECT_EQ(calm.find('['), std::string::npos) << calm;
  EXPECT_TRUE(
      calm.starts_with("state     timer running (8)   mode free & timer (0)\n"
                       "speed     60 %   motor 1200 rpm, 3.50 A\n"
                       "time      25:00 remaining\n"
                       "faults    none\n"
                       "temps     MOSFET 41.2 degC, motor 38.0 degC\n"
                       "bus       310.4 V\n"
                       "versions  display V1.2 (hw V0.0)"))
      << calm;
  expect_at_most_80_columns(calm);
  ij::MachineStatus fault = s;
  fault.state = 17;
  fault.faults = 1;
  const std::string alarm = ij::status_panel(fault, ij::Family::none, bracket);
  EXPECT_NE(alarm.find("state     [fault screen] (17)"), std::string::npos) << alarm;
  EXPECT_NE(alarm.find("faults    [voltage (0x0001)]\n"), std::string::npos) << alarm;
  // Without a highlight, the same text as it is.
  EXPECT_NE(ij::status_panel(fault).find("faults    voltage (0x0001)\n"), std::string::npos);
  EXPECT_EQ(ij::status_line(s),
            "timer running     speed  60 %  time 25:00 remaining  motor 1200 rpm 3.50 A  MOSFET "
            "41.2 degC  motor 38.0 degC  faults none");
}

// What the pool panel's page types, read by the device layer (the page
// parses nothing): the CLI's duration grammar, the rows' ranges, the
// swimmer's words, the first thing wrong with a plan and where it is.
TEST(InverjetTyped, TimesAndSpeedsAsTheCliReadsThem_InTheSwimmersWords) {
  EXPECT_EQ(ij::read_time_text(" 30m ", "Time").value, 1800U) << "spaces around are no error";
  EXPECT_EQ(ij::read_time_text("1m30s", "Time").value, 90U);
  EXPECT_EQ(ij::read_time_text("99:59", "Time").value, 5999U);
  EXPECT_EQ(ij::read_time_text("", "Time").why, "Time is empty: write 30:00, 30m or 90s.");
  EXPECT_EQ(ij::read_time_text("5", "End").why, "End \"5\" has no unit: write 30:00, 30m or 90s.");
  EXPECT_EQ(ij::read_time_text("30M", "Time").why, "Time \"30M\" is not a time: write 30:00, 30m or 90s.")
      << "the CLI refuses 30M: so does the page";
  EXPECT_EQ(ij::read_time_text("100:00", "Time").why, "Time 100:00 is out of range: 00:01 to 99:59.")
      << "a time, too long; not 'no time'";
  EXPECT_EQ(ij::read_time_text("0s", "Time").why, "Time 0s is out of range: 00:01 to 99:59.");
  EXPECT_EQ(ij::read_speed_text(" 60 % ").value, 60U);
  EXPECT_EQ(ij::read_speed_text("0").value, 0U);
  EXPECT_EQ(ij::read_speed_text("").why, "Speed is empty: enter 0 to 100 %, for example 60.");
  EXPECT_EQ(ij::read_speed_text("101").why, "Speed \"101\" is not 0 to 100 %: for example 60.");
  EXPECT_FALSE(ij::read_speed_text("6o").value);
  EXPECT_FALSE(ij::read_speed_text("-1").value);
}

TEST(InverjetTyped, APlansFirstFaultAndItsRow_AStartsFieldsForTheCommand) {
  using J = nlohmann::json;
  J r = ij::check_typed(
      J{{"segments", {{{"speed", "60"}, {"end", "1:00"}}, {{"speed", 70}, {"end", "00:30"}}}}});
  EXPECT_EQ(r["why"], "segment 2: end 00:30 is not after 01:00");
  EXPECT_EQ(r["row"], 1);
  EXPECT_EQ(r["field"], "end");
  EXPECT_EQ(r["segments"][0]["end_s"], 60);
  EXPECT_EQ(r["segments"][1]["speed"], 70) << "a number sent as a number reads too";
  r = ij::check_typed(J{{"segments", {{{"speed", "60"}, {"end", "1m"}}, {{"speed", "70"}, {"end", "60s"}}}}});
  EXPECT_EQ(r["why"], "segment 2: end 01:00 is not after 01:00")
      << "an end equal to the one before is no segment";
  r = ij::check_typed(J{{"segments", {{{"speed", "6o"}, {"end", "x"}}}}});
  EXPECT_EQ(r["row"], 0);
  EXPECT_EQ(r["field"], "speed") << "the first thing wrong, not the last";
  EXPECT_TRUE(r["segments"][0]["speed"].is_null());
  EXPECT_EQ(ij::check_typed(J{{"segments", J::array()}})["why"], "a plan has 1 to 50 segments");
  J many = J::array();
  for (int i = 1; i <= 51; ++i) many.push_back({{"speed", "50"}, {"end", std::to_string(i) + "m"}});
  EXPECT_EQ(ij::check_typed(J{{"segments", many}})["why"], "a plan has 1 to 50 segments");
  many.erase(many.end() - 1);
  r = ij::check_typed(J{{"segments", many}});
  EXPECT_EQ(r["why"], "") << r.dump();
  EXPECT_EQ(r["segments"].size(), 50U);

  r = ij::check_typed(J{{"start", {{"mode", "timer"}, {"speed", "60"}, {"duration", "30m"}}}});
  EXPECT_EQ(r["why"], "");
  EXPECT_EQ(r["fields"], (J{{"mode", "timer"}, {"speed", 60}, {"duration", "30:00"}}));
  r = ij::check_typed(J{{"start", {{"mode", "timer"}, {"speed", "60"}}}});
  EXPECT_EQ(r["field"], "duration");
  EXPECT_FALSE(r.contains("fields")) << "a refused start has no body to send";
  EXPECT_EQ(ij::check_typed(J{{"start", {{"mode", "free"}, {"speed", ""}}}})["field"], "speed");
  EXPECT_EQ(ij::check_typed(J{{"start", {{"mode", "plan"}, {"plan", 4}}}})["fields"]["plan"], 4);
  EXPECT_EQ(ij::check_typed(J{{"start", {{"mode", "plan"}, {"plan", 5}}}})["why"], "Choose a plan, 1 to 4.");
  EXPECT_EQ(ij::check_typed(J{{"speed", "80%"}})["speed"], 80);
  EXPECT_EQ(ij::check_typed(J{{"speed", 1.5}})["why"], "Speed \"1.5\" is not 0 to 100 %: for example 60.")
      << "a value that is no text is refused as what it is, not as empty";
  EXPECT_EQ(ij::check_typed(J{{"speed", nullptr}})["why"],
            "Speed is empty: enter 0 to 100 %, for example 60.");
  // Anything else gets an answer, never an exception.
  for (const J& odd : {J(), J(3), J::array(), J{{"segments", 1}}, J{{"start", "x"}}, J{{"speed", J::array()}},
                       J{{"segments", {1, "x", J()}}}})
    EXPECT_NE(ij::check_typed(odd)["why"], "") << odd.dump();
}

TEST(InverjetIdentify, ThePoleCountTellsAnInverjetFromAnotherDevice) {
  Rig jet(21);
  jet.bank.holding[ij::reg::kPoleCount] = ij::kMap.row(ij::reg::pole_count).writable_range.min;
  EXPECT_TRUE(ij::identify(*jet.master, UnitId{21}).ok());

  Rig other(21);  // a generic slave: the register reads 0
  const rtukit::Status zero = ij::identify(*other.master, UnitId{21});
  EXPECT_EQ(zero.code(), Errc::refused);
  EXPECT_EQ(
      zero.reason(),
      "not an Inverjet: its motor pole count (holding 0x0004) reads 0 where an Inverjet's always reads 5");

  Rig small(21, 2);  // no register 0x0004: exception 02
  const rtukit::Status missing = ij::identify(*small.master, UnitId{21});
  EXPECT_EQ(missing.code(), Errc::refused);
  EXPECT_NE(std::string(missing.reason()).find("answers Modbus exception 02 (illegal data address)"),
            std::string::npos)
      << missing.reason();

  other.silent = true;  // no answer is not "another device"
  EXPECT_EQ(ij::identify(*other.master, UnitId{21}).code(), Errc::timeout);
}

TEST(InverjetStart, TheRulesBetweenTheOptions) {
  const auto refusal = [](ij::StartOptions o) { return std::string(ij::check_start_options(o).reason()); };
  EXPECT_EQ(refusal({.free = true, .timer = true}), "choose one of --free, --timer DURATION, --plan N");
  EXPECT_EQ(refusal({}), "choose one of --free, --timer DURATION, --plan N");
  EXPECT_EQ(refusal({.plan = true, .speed = true}),
            "a training plan sets its own speed (no --speed or --remember with --plan)");
  EXPECT_EQ(refusal({.plan = true, .remember = true}),
            "a training plan sets its own speed (no --speed or --remember with --plan)");
  EXPECT_EQ(refusal({.free = true, .from = true}), "--from goes with --plan");
  EXPECT_EQ(refusal({.timer = true}), "--timer needs --speed");
  EXPECT_TRUE(ij::check_start_options({.timer = true, .speed = true, .remember = true}).ok());
  EXPECT_TRUE(ij::check_start_options({.plan = true, .from = true}).ok());
  EXPECT_TRUE(ij::check_start_options({.free = true, .remember = true}).ok());
}

TEST(InverjetStart, DurationsAndTheRequestsRules) {
  const Outcome<uint16_t> t = ij::parse_run_duration("30:00", "timer", ij::timer_range());
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(*t, 1800);
  EXPECT_EQ(ij::parse_run_duration("100m", "timer", ij::timer_range()).error().reason(),
            "timer 100m (6000 s) is out of range 1..5999 s (99:59)");
  EXPECT_EQ(ij::parse_run_duration("0s", "timer", ij::timer_range()).error().reason(),
            "timer 0s (0 s) is out of range 1..5999 s (99:59)");
  EXPECT_TRUE(ij::parse_run_duration("0s", "--from", ij::from_range()).ok());
  const std::string bare(ij::parse_run_duration("30", "timer", ij::timer_range()).error().reason());
  EXPECT_NE(bare.find("write 30:00 (mm:ss), 30m or 90s"), std::string::npos) << bare;

  ij::StartRequest timer{.mode = ij::StartMode::timer, .duration_s = 600};
  EXPECT_EQ(ij::check_start(timer).code(), Errc::invalid_argument);  // no speed
  timer.speed = 80;
  EXPECT_TRUE(ij::check_start(timer).ok());
  EXPECT_EQ(ij::start_text(timer), "timer mode, 10:00 at 80 %");
  timer.duration_s = 0;
  EXPECT_EQ(ij::check_start(timer).reason(), "timer: \"duration\" must be 00:01..99:59");
  ij::StartRequest plan{.mode = ij::StartMode::plan, .plan = 5};
  EXPECT_EQ(ij::check_start(plan).reason(), "plan: \"plan\" 1..4 is required");
  plan.plan = 2;
  plan.from_s = 12 * 60;
  EXPECT_TRUE(ij::check_start(plan).ok());
  EXPECT_EQ(ij::start_text(plan), "plan P2 from 12:00");
  plan.speed = 50;
  EXPECT_EQ(ij::check_start(plan).code(), Errc::invalid_argument);
  EXPECT_EQ(ij::start_text({}), "free mode (speed and time from memory)");
  EXPECT_EQ(ij::start_text({.speed = 60}), "free mode at 60 %");
}

// The settings by key: the checks before anything is sent.
TEST(InverjetConfig, EachKeyItsRow_RefusalsSayWhy) {
  const ij::ReadNumber read = [](std::string_view text, std::string_view what, int64_t min,
                                 int64_t max) -> Outcome<int64_t> {
    const int64_t n = std::stoll(std::string(text));
    if (n < min || n > max)
      return rtukit::Status(Errc::invalid_argument,
                            fmt::format("{} {} is out of range {}..{}", what, n, min, max));
    return n;
  };
  Outcome<ij::ConfigChange> baud = ij::parse_config("baud", "19200", read);
  ASSERT_TRUE(baud.ok());
  EXPECT_EQ(baud->row, &ij::kMap.row(ij::reg::baud));
  EXPECT_EQ(baud->raw, ij::code_of_baud(19200));
  EXPECT_EQ(baud->value, 19200U);
  EXPECT_EQ(ij::parse_config("baud", "115200", read).error().reason(),
            "baud 115200: the Inverjet runs at 1200, 2400, 4800, 9600 or 19200");
  EXPECT_EQ(ij::parse_config("mask", "9", read).error().reason(), "control mask 9 is out of range 0..7");
  EXPECT_EQ(ij::parse_config("address", "255", read).error().reason(),
            "inverjet unit 255 is out of range 1..254");
  Outcome<ij::ConfigChange> pairing = ij::parse_config("pairing", "wifi", read);
  ASSERT_TRUE(pairing.ok()) << pairing.error().reason();
  EXPECT_EQ(pairing->row, &ij::kMap.row(ij::reg::pairing));
  EXPECT_EQ(pairing->raw, 1);
  EXPECT_FALSE(ij::parse_config("pairing", "bluetooth", read).ok());
  EXPECT_EQ(ij::parse_config("colour", "red", read).error().reason(),
            "config colour: expected show, address, baud, mask or pairing");
}

TEST(InverjetVerbs, AnExceptionsReason_APlanAsJson_APlanFileThatIsNone) {
  EXPECT_EQ(ij::exception_reason(rtukit::Status(Error::exception(0x02))), "a reserved register");
  EXPECT_EQ(ij::exception_reason(rtukit::Status(Error::exception(0x03))), "a value out of range");
  EXPECT_EQ(ij::exception_reason(rtukit::Status(Error::exception(0x04), "control mask bit 1 is set")),
            "control mask bit 1 is set");
  EXPECT_EQ(ij::exception_reason(rtukit::Status(Error::exception(0x04))), "");
  EXPECT_EQ(ij::exception_reason(rtukit::Status(Errc::timeout)), "");

  const std::vector<ij::Segment> plan{{25, 90}, {55, 300}};
  EXPECT_EQ(ij::plan_json(plan).dump(),
            R"([{"speed":25,"end":"01:30","end_s":90},{"speed":55,"end":"05:00","end_s":300}])");
  const Outcome<std::vector<ij::Segment>> back = ij::parse_plan(ij::plan_json(plan).dump());
  ASSERT_TRUE(back.ok()) << back.error().reason();
  EXPECT_EQ(back->size(), 2U);
  const Outcome<std::vector<ij::Segment>> zero = ij::read_plan_file("/dev/zero");  // never read forever
  ASSERT_FALSE(zero.ok());
  EXPECT_EQ(zero.error().code(), Errc::invalid_argument);
  EXPECT_TRUE(std::string(zero.error().reason()).starts_with("cannot read plan file '/dev/zero': "))
      << zero.error().reason();
}

// ---------------------------------------------------------------- Rehand 6600

rh::Snapshot chair() {
  rh::Snapshot s;
  s.regs[rh::reg::kBattery] = 80;
  s.regs[rh::reg::kCharging] = 1;
  s.regs[rh::reg::kSpeed] = 6;
  s.regs[rh::reg::kClutch] = 1;
  s.regs[rh::reg::kMotion] = 2;
  s.regs[rh::reg::kMainLight] = 1;
  for (uint16_t i = 0; i < 6; ++i) s.regs[rh::reg::kActuatorPosition + i] = static_cast<uint16_t>(100 * i);
  s.valid = true;
  return s;
}

TEST(RehandViews, ValuesByName_SpeedInEitherUnit_ALineOfTheChair) {
  const rh::Snapshot s = chair();
  EXPECT_EQ(rh::value_text(s, "clutch"), "drive");
  EXPECT_EQ(rh::value_text(s, "motion"), "forward");
  EXPECT_EQ(rh::value_text(s, "battery"), "80 %");
  EXPECT_EQ(rh::speed_text(s, false), "6 km/h");
  EXPECT_EQ(rh::speed_text(s, true), "3.7 mph");
  EXPECT_EQ(rh::actuators(s), "0 100 200 300 400 500");
  EXPECT_EQ(
      rh::line(s, false),
      "battery 80%+ | forward 6 km/h | light on | seat still stand still legs still | act 0 100 200 300 "
      "400 500 | error none");
}

TEST(RehandViews, ThePanelWrapsTheAdvice_HighlightsOnlyAnError) {
  rh::Snapshot s = chair();
  const std::string calm = rh::panel(s, false, bracket);
  EXPECT_TRUE(
      calm.starts_with("battery   80 % (charging)   clutch drive\nmotion    forward   speed 6 km/h\n"))
      << calm;
  EXPECT_EQ(calm.find('['), std::string::npos) << calm;
  EXPECT_TRUE(calm.ends_with("error     none\n")) << calm;
  s.regs[rh::reg::kErrorCode] = 0x10C3;
  const std::string alarm = rh::panel(s, true, bracket);
  EXPECT_TRUE(alarm.starts_with("[!!! 10C3 Seat lift Error : every function is disabled !!!]\n")) << alarm;
  EXPECT_NE(alarm.find("error     [10C3 Seat lift Error]\nadvice    the seat-lift actuator"),
            std::string::npos)
      << alarm;
  EXPECT_NE(alarm.find("speed 3.7 mph"), std::string::npos) << alarm;
  expect_at_most_80_columns(alarm);
  EXPECT_EQ(rh::wrapped("head  ", "one two"), "head  one two\n");
  const std::string many = rh::wrapped(
      "advice    ", std::string(30, 'a') + " " + std::string(30, 'b') + " " + std::string(30, 'c'));
  EXPECT_EQ(many, "advice    " + std::string(30, 'a') + " " + std::string(30, 'b') + "\n          " +
                      std::string(30, 'c') + "\n");
}

// The display's postures come from the device layer's posture table: the
// host daemon had its own copy, which said leg rotation moves actuator 4
// only, so the display never showed actuator 5's limit or over-current.
TEST(RehandViews, ThePosturesAreTheModelsTable_LegRotationShowsActuators4And5) {
  rh::Snapshot s = chair();
  s.regs[rh::reg::actuator_state(4)] = rh::kActuatorMoving;
  s.regs[rh::reg::actuator_state(5)] = rh::kOverCurrent;
  const auto held = [](uint16_t command) -> uint16_t { return command == rh::reg::kLegRotate ? 1 : 0; };
  const nlohmann::ordered_json postures = rh::postures_view(s, held);
  ASSERT_EQ(postures.size(), rh::kPostures.size());
  for (size_t i = 0; i < rh::kPostures.size(); ++i) {
    std::vector<int> listed;
    for (const auto& a : postures[i]["actuators"]) listed.push_back(a["n"].get<int>());
    const auto driven = rh::kPostures[i].driven();
    EXPECT_EQ(listed, std::vector<int>(driven.begin(), driven.end())) << postures[i]["key"];
  }
  const nlohmann::ordered_json& leg = postures[4];
  EXPECT_EQ(leg["key"], "leg_rotate");
  ASSERT_EQ(leg["actuators"].size(), 2U);
  EXPECT_EQ(leg["actuators"][1]["n"], 5);
  EXPECT_EQ(leg["actuators"][1]["state"], "over-current") << leg.dump();
  EXPECT_EQ(leg["actuators"][1]["position"], 400);
  EXPECT_TRUE(leg["moving"]) << "held, and actuator 4 moves";
  EXPECT_EQ(leg["held"], "up") << leg.dump();
  EXPECT_FALSE(postures[5]["moving"]) << "leg extension shares actuator 5 but is not held";
  EXPECT_EQ(postures[0]["status"], "still");
  EXPECT_EQ(leg["badge"], "over-current") << "a fault shows first";
}

// The one word the display shows per posture: a limit one actuator reached
// while the posture still moves is not shown ("lower limit" showed while
// the seat still came down); once nothing moves, the limit is.
TEST(RehandViews, APostureStillMovingShowsMovingNotALimit) {
  rh::Snapshot s = chair();
  s.regs[rh::reg::actuator_state(4)] = rh::kActuatorMoving;
  s.regs[rh::reg::actuator_state(5)] = rh::kLowerLimit;
  const auto held = [](uint16_t command) -> uint16_t { return command == rh::reg::kLegRotate ? 2 : 0; };
  nlohmann::ordered_json leg = rh::postures_view(s, held)[4];
  EXPECT_EQ(leg["badge_kind"], "moving") << leg.dump();
  EXPECT_EQ(leg["badge"], "moving") << leg.dump();
  s.regs[rh::reg::actuator_state(4)] = rh::kLowerLimit;  // the end: nothing moves
  leg = rh::postures_view(s, held)[4];
  EXPECT_EQ(leg["badge_kind"], "limit") << leg.dump();
  EXPECT_EQ(leg["badge"], "lower limit") << leg.dump();
  s.regs[rh::reg::actuator_state(4)] = 0;
  s.regs[rh::reg::actuator_state(5)] = 0;
  EXPECT_EQ(rh::postures_view(s, held)[4]["badge"], "still");
}

// Stand/sit's progress is the mean of the actuators it drives (1, 2, 4);
// the distances by name; a signed row signed.
TEST(RehandViews, StandProgressDistancesAndSignedNumbers) {
  rh::Snapshot s = chair();  // positions 0, 100, 200, 300, 400, 500
  EXPECT_EQ(rh::stand_progress(s), (0 + 100 + 300) / 30);
  for (unsigned n = 1; n <= 6; ++n) s.regs[rh::reg::actuator_position(n)] = 1000;
  EXPECT_EQ(rh::stand_progress(s), 100);
  s.regs[rh::reg::kDistanceRear] = 1200;
  s.regs[rh::reg::kDistanceRight] = 30;
  const nlohmann::ordered_json d = rh::distances_view(s);
  EXPECT_EQ(d["rear"], 1200);
  EXPECT_EQ(d["right"], 30);
  s.regs[rh::find_register("joystick_x")->address] = static_cast<uint16_t>(-40);
  const nlohmann::ordered_json n = rh::status_numbers(s);
  EXPECT_EQ(n["joystick_x"], -40) << "a signed row is signed, not 65496";
  EXPECT_EQ(n["battery"], 80);
  EXPECT_FALSE(n.contains("reserved_27"));
}

// The daemon's state document's chair part, from one HostState: the
// advice with an error, signed rows signed, presses by their owner's name,
// the driver by its phone id, the chosen drive mode by its row's name.
TEST(RehandViews, TheStateDocumentIsOneHostState) {
  rh::HostState st;
  st.snapshot = chair();
  st.connected = true;
  st.snapshot.regs[rh::reg::kJoystickX] = static_cast<uint16_t>(-25);
  st.active_error = 0x10C3;
  st.presses.push_back({.client = 7, .id = 1, .command = rh::reg::kPhoneForward, .value = 1});
  st.driver = 7;
  st.drive_mode = 2;
  st.speed_level = 1;
  st.emergency = true;
  st.disabled.drive = "a phone is driving";
  const rh::ClientNames names{
      .owner = [](rh::Session::ClientId c) { return c == 7 ? "Anna's phone" : "display"; },
      .phone = [](rh::Session::ClientId c) { return c == 7 ? "p-7" : ""; }};
  nlohmann::ordered_json v = rh::state_view(st, names);
  EXPECT_TRUE(v["connected"]);
  EXPECT_EQ(v["error"], 0x10C3);
  EXPECT_EQ(v["error_text"], "10C3 Seat lift Error");
  EXPECT_NE(v["error_advice"].get<std::string>().find("check"), std::string::npos) << v["error_advice"];
  EXPECT_EQ(v["values"]["joystick_x"], -25);
  EXPECT_EQ(v["text"]["battery"], rh::format_value(*rh::find_register("battery"), 80));
  EXPECT_FALSE(v["text"].contains("reserved_27"));
  EXPECT_EQ(v["drive_mode"], "indoor");
  EXPECT_EQ(v["speed_level"], 1);
  ASSERT_EQ(v["presses"].size(), 1U);
  EXPECT_EQ(v["presses"][0]["command"], "phone_forward");
  EXPECT_EQ(v["presses"][0]["owner"], "Anna's phone");
  EXPECT_EQ(v["driver"], "p-7");
  EXPECT_TRUE(v["emergency"]);
  EXPECT_FALSE(v["stop"]);
  EXPECT_EQ(v["disabled"]["drive"], "a phone is driving");
  EXPECT_EQ(v["postures"].size(), std::size(rh::kPostures));
  // No error: no advice; no poll read yet: not connected, whatever the link.
  st.active_error = 0;
  st.snapshot.valid = false;
  v = rh::state_view(st, names);
  EXPECT_EQ(v["error_advice"], "");
  EXPECT_FALSE(v["connected"]) << "a link without a reading shows nothing live";
  st.driver.reset();
  EXPECT_EQ(rh::state_view(st, names)["driver"], "");
}

TEST(RehandViews, TheJsonValuesOfTableOne) {
  rh::Snapshot s = chair();
  nlohmann::ordered_json v = rh::snapshot_values(s, false);
  EXPECT_EQ(v["battery"]["value"], 80);
  EXPECT_EQ(v["clutch"]["text"], "drive (1)");
  EXPECT_FALSE(v.contains("speed_mph"));
  EXPECT_FALSE(v.contains("reserved"));
  EXPECT_EQ(v["error_text"]["text"], "none");
  EXPECT_EQ(v["error_advice"]["value"], "");
  s.regs[rh::reg::kErrorCode] = 0x10C3;
  v = rh::snapshot_values(s, true);
  EXPECT_EQ(v["speed_mph"]["value"], 3.7);
  EXPECT_EQ(v["speed_mph"]["unit"], "mph");
  EXPECT_EQ(v["error_text"]["value"], "10C3 Seat lift Error");
  EXPECT_NE(v["error_advice"]["value"].get<std::string>().find("; check: "), std::string::npos);
}

TEST(RehandVerbs, CommandsByName_TheirDirections_AHoldsLength) {
  const Outcome<const rh::Register*> lift = rh::command_register("seat-lift", rh::Kind::hold);
  ASSERT_TRUE(lift.ok());
  EXPECT_EQ((*lift)->address, rh::reg::kSeatLift);
  const std::string fly(rh::command_register("fly", rh::Kind::hold).error().reason());
  EXPECT_TRUE(fly.starts_with("'fly' is not a hold command (")) << fly;
  EXPECT_NE(fly.find("seat_lift"), std::string::npos) << fly;
  EXPECT_TRUE(std::string(rh::command_register("stand", rh::Kind::pulse).error().reason())
                  .starts_with("'stand' is not a pulse command ("));
  EXPECT_TRUE(rh::command_register("light", rh::Kind::pulse).ok());

  EXPECT_EQ(*rh::command_value(**lift, "up"), 1);
  EXPECT_EQ(*rh::command_value(**lift, "2"), 2);
  EXPECT_EQ(rh::command_value(**lift, "").error().reason(),
            "hold seat_lift needs a direction: up (1) or down (2) (nothing sent)");
  EXPECT_EQ(rh::command_value(**lift, "7").error().reason(),
            "hold seat_lift: '7' is not one of its directions: up (1) or down (2) (nothing sent)");
  const rh::Register& forward = **rh::command_register("phone_forward", rh::Kind::hold);
  EXPECT_EQ(*rh::command_value(forward, ""), 1);  // one direction: none to name

  EXPECT_EQ(*rh::parse_hold_duration("500ms"), 500ms);
  EXPECT_EQ(*rh::parse_hold_duration("2s"), 2000ms);
  EXPECT_EQ(*rh::parse_hold_duration("1.5"), 1500ms);
  EXPECT_EQ(rh::parse_hold_duration("0s").error().reason(),
            "duration '0s': e.g. 2s, 500ms, 1m (at most 10 minutes)");
  // The one duration form of every front-end too (hold --for 1m was refused).
  EXPECT_EQ(*rh::parse_hold_duration("1m"), 60000ms);
  EXPECT_EQ(*rh::parse_hold_duration("1m30s"), 90000ms);
  EXPECT_EQ(*rh::parse_hold_duration("1:30"), 90000ms);
  EXPECT_EQ(*rh::parse_hold_duration("10m"), 600000ms);
  EXPECT_FALSE(rh::parse_hold_duration("11m").ok());
  EXPECT_FALSE(rh::parse_hold_duration("0:00").ok());
  EXPECT_FALSE(rh::parse_hold_duration("601s").ok());
}

TEST(RehandVerbs, SettingsByTheirRows_ErrorsAsJson) {
  const Outcome<rh::SettingChange> outdoor = rh::parse_setting("drive-mode", "outdoor");
  ASSERT_TRUE(outdoor.ok());
  EXPECT_EQ(outdoor->row->address, rh::reg::kDriveMode);
  EXPECT_EQ(outdoor->raw, 3);
  EXPECT_EQ(rh::parse_setting("speed-level", "6").error().reason(), "speed_level: 6 is outside 1..5");
  EXPECT_EQ(rh::parse_setting("drive_mode", "fast").error().reason(),
            "'fast' is not a drive_mode (normal, indoor, outdoor)");
  EXPECT_EQ(rh::parse_setting("host-fault", "0")->row->address, rh::reg::kHostFault);
  EXPECT_EQ(rh::parse_setting("seat_lift", "1").error().reason(),
            "set seat_lift: expected drive-mode, speed-level or host-fault");
  const nlohmann::ordered_json e = rh::error_json(0x10C3);
  EXPECT_EQ(e["code"], "10C3");
  EXPECT_EQ(e["text"], "10C3 Seat lift Error");
  EXPECT_EQ(e.begin().key(), "code");
  EXPECT_NE(e["advice"].get<std::string>().find("; check: "), std::string::npos);
}

TEST(RehandVerbs, TheHandshakeTellsTheControllerFromAnotherDevice) {
  Rig controller(rh::kDefaultAddress);
  controller.bank.holding[rh::reg::kDeviceId] = rh::kDeviceId;
  EXPECT_TRUE(rh::handshake(*controller.master, UnitId{rh::kDefaultAddress}).ok());
  EXPECT_EQ(controller.bank.holding[rh::reg::kHostReady], 0);  // a one-shot read writes nothing

  Rig other(rh::kDefaultAddress);
  other.bank.holding[rh::reg::kDeviceId] = 0x42;
  const rtukit::Status id = rh::handshake(*other.master, UnitId{rh::kDefaultAddress});
  EXPECT_EQ(id.code(), Errc::refused);
  EXPECT_EQ(id.reason(), "handshake: device ID 0x42, expected 0x68 (not a Rehand 6600 controller?)");

  Rig none(rh::kDefaultAddress, 0);  // nothing at 0x0000: exception 02
  const rtukit::Status exception = rh::handshake(*none.master, UnitId{rh::kDefaultAddress});
  EXPECT_EQ(exception.code(), Errc::refused);
  EXPECT_EQ(exception.reason(), "handshake: Modbus exception 02");

  other.silent = true;
  const rtukit::Status silent = rh::handshake(*other.master, UnitId{rh::kDefaultAddress});
  EXPECT_EQ(silent.code(), Errc::timeout);
  EXPECT_EQ(silent.reason(), "handshake: no answer (timeout)");
}

// ---------------------------------------------------------------- the verb tables

// A context whose link is the rig's master, counting how often it is opened.
struct Where {
  explicit Where(Rig& rig, uint8_t unit) {
    context.unit = UnitId{unit};
    context.open = [this, &rig]() -> Master& {
      ++opened;
      return *rig.master;
    };
  }
  profile::VerbContext context;
  int opened = 0;
};

Outcome<profile::VerbResult> run(const std::vector<profile::Verb>& table,
                                 Outcome<profile::VerbResult> (*runner)(const profile::Verb&,
                                                                        const profile::VerbArgs&,
                                                                        profile::VerbContext&),
                                 std::string_view name, const profile::VerbArgs& args, Where& where) {
  const profile::Verb* verb = profile::find_verb(table, name);
  EXPECT_NE(verb, nullptr) << name;
  return runner(*verb, args, where.context);
}

TEST(InverjetVerbTable, HelpsSayTheRowsRanges_AndThePairingNames) {
  const auto& table = ij::verb_table();
  std::vector<std::string> names;
  for (const profile::Verb& v : table) names.emplace_back(v.name);
  EXPECT_EQ(names, (std::vector<std::string>{"status", "watch", "start", "pause", "resume", "stop", "speed",
                                             "plan show", "plan set", "plan clear", "config"}));
  const profile::Verb& start = *profile::find_verb(table, "start");
  ASSERT_EQ(start.args.size(), 6U);
  EXPECT_NE(start.args[2].help.find(fmt::format("1..{}", ij::kPlanCount)), std::string::npos);
  EXPECT_NE(start.args[3].help.find(fmt::format("0..{} %", ij::kMaxSpeed)), std::string::npos);
  EXPECT_NE(start.args[1].help.find("99:59"), std::string::npos);
  std::string pairing;
  for (const profile::Named& n : ij::kMap.row(ij::reg::pairing).names) pairing += std::string(n.name) + "|";
  EXPECT_NE(profile::find_verb(table, "config")->args[0].help.find(pairing), std::string::npos);
  EXPECT_NE(profile::find_verb(table, "plan clear")->help.find(ij::factory_plan_text()), std::string::npos);
  // The docs' table: one row per verb, a cell never split by a '|'.
  const std::string md = profile::verbs_markdown("inverjet", table);
  EXPECT_NE(md.find("| `rtukit inverjet speed SPEED` | set the running speed | SPEED: 0..100 % |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("off or wifi or remote or 0..2"), std::string::npos) << md;
}

TEST(InverjetVerbTable, ARefusedArgumentNeverOpensTheLink) {
  Rig jet(21);
  jet.bank.holding[ij::reg::kPoleCount] = ij::kMap.row(ij::reg::pole_count).writable_range.min;
  Where where(jet, 21);
  const auto& table = ij::verb_table();
  for (const auto& [name, args] : std::vector<std::pair<std::string, profile::VerbArgs>>{
           {"start", {{"plan", "1"}, {"speed", "30"}}},
           {"start", {{"timer", "100m"}, {"speed", "30"}}},
           {"start", {}},
           {"speed", {{"speed", "101"}}},
           {"plan show", {{"n", "5"}}},
           {"plan set", {{"n", "1"}, {"file", "/nonexistent/plan.csv"}}},
           {"config", {{"what", "baud"}, {"value", "115200"}}},
           {"config", {{"what", "pairing"}}}}) {
    const Outcome<profile::VerbResult> r = run(table, ij::run_verb, name, args, where);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_TRUE(r.error().code() == Errc::invalid_argument || r.error().code() == Errc::io_error)
        << name << ": " << r.error().reason();
  }
  EXPECT_EQ(where.opened, 0);
}

TEST(InverjetVerbTable, AnotherDeviceIsRefused_TheMachineAnswersThroughTheVerbs) {
  Rig other(21);  // pole count 0: not an Inverjet
  Where there(other, 21);
  const auto& table = ij::verb_table();
  Outcome<profile::VerbResult> r = run(table, ij::run_verb, "stop", {}, there);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code(), Errc::refused);
  EXPECT_NE(r.error().reason().find("not an Inverjet"), std::string::npos) << r.error().reason();
  EXPECT_EQ(there.opened, 1);

  Rig jet(21);
  jet.bank.holding[ij::reg::kPoleCount] = ij::kMap.row(ij::reg::pole_count).writable_range.min;
  Where here(jet, 21);
  r = run(table, ij::run_verb, "config", {}, here);
  ASSERT_TRUE(r.ok()) << r.error().reason();
  EXPECT_TRUE(r->action.empty());  // a reading
  EXPECT_EQ(r->values["pole_count"]["value"], 5);
  EXPECT_NE(r->text.find("pole_count     5"), std::string::npos) << r->text;
  // A write says what it did, in the document's "action" too.
  r = run(table, ij::run_verb, "config", {{"what", "mask"}, {"value", "0"}}, here);
  ASSERT_TRUE(r.ok()) << r.error().reason();
  EXPECT_EQ(r->action, "config mask");
}

// `watch` is a live verb: the machine identified first, then a frame per
// refresh. Nothing there at the first refresh ends the view; a link lost
// later keeps it, each frame marked not ok with the reason.
TEST(InverjetVerbTable, WatchIsALiveViewThatOutlivesALostLink) {
  Rig jet(21);
  jet.bank.holding[ij::reg::kPoleCount] = ij::kMap.row(ij::reg::pole_count).writable_range.min;
  Where where(jet, 21);
  const profile::Verb& watch = *profile::find_verb(ij::verb_table(), "watch");
  EXPECT_EQ(watch.live_interval_ms, 500U);
  Outcome<profile::VerbResult> r = ij::run_verb(watch, {}, where.context);
  ASSERT_TRUE(r.ok()) << r.error().reason();
  ASSERT_TRUE(r->refresh);
  Outcome<profile::LiveFrame> f = r->refresh(0);
  ASSERT_TRUE(f.ok()) << f.error().reason();
  EXPECT_TRUE(f->ok);
  EXPECT_TRUE(f->line.starts_with("off")) << f->line;
  EXPECT_NE(f->panel.find("speed"), std::string::npos) << f->panel;
  EXPECT_FALSE(f->panel.ends_with("\n"));
  EXPECT_TRUE(f->values.contains("state"));
  jet.silent = true;
  f = r->refresh(1);
  ASSERT_TRUE(f.ok());  // the view goes on, stale
  EXPECT_FALSE(f->ok);
  EXPECT_EQ(f->why, "no response");
  EXPECT_EQ(f->kind, "timeout");
  // Nothing answering when it starts: no view, the reason instead.
  r = ij::run_verb(watch, {}, where.context);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code(), Errc::timeout);
  EXPECT_EQ(where.opened, 2);
}

// A stop asked for before the first press (Ctrl-C during the handshake)
// never presses: the hold ends interrupted and the command register is never
// written, not even for one lease.
TEST(RehandVerbTable, AHoldStoppedBeforeItsFirstPressNeverPresses) {
  Rig chair(1);
  chair.bank.holding[rh::reg::kDeviceId] = rh::kDeviceId;
  std::vector<std::vector<uint8_t>> requests;  // read after the verb: its controller's thread has ended
  Where where(chair, 1);
  where.context.response_timeout = 100ms;
  where.context.open_link = [&] {
    return std::make_unique<MemoryLink>(SteadyClock::instance(), [&](std::span<const uint8_t> request) {
      requests.emplace_back(request.begin(), request.end());
      std::array<uint8_t, kMaxRtuAduSize> out{};
      const size_t n = chair.engine.handle_rtu(request, out).length;
      return MemoryLink::Reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 1ms};
    });
  };
  std::vector<std::string> shown;  // the countdown is shown right after each press
  where.context.progress = [&](std::string_view t) { shown.emplace_back(t); };
  int waits = 0;
  where.context.wait = [&](std::chrono::milliseconds) {
    ++waits;
    return false;  // the person already asked to stop
  };
  const Outcome<profile::VerbResult> r = run(rh::verb_table(), rh::run_verb, "hold",
                                             {{"cmd", "seat_lift"}, {"value", "up"}, {"for", "2s"}}, where);
  ASSERT_TRUE(r.ok()) << r.error().reason();
  EXPECT_TRUE(r->interrupted);
  EXPECT_GE(waits, 1);
  for (const std::string& t : shown) EXPECT_FALSE(t.starts_with("holding")) << "pressed: " << t;
  bool handshake = false;
  for (const auto& q : requests) {
    ASSERT_GE(q.size(), 4U);
    const uint16_t address = static_cast<uint16_t>(q[2] << 8 | q[3]);
    handshake = handshake || (q[1] == 0x03 && address == rh::reg::kDeviceId);
    // The first handshake zeroes every hold command (what an earlier run may
    // have left); the press itself, a word that is not 0, is never written.
    EXPECT_NE(q[1], 0x10) << "no multiple write";
    if (q[1] == 0x06)
      EXPECT_FALSE(address == rh::reg::kSeatLift && (q[4] << 8 | q[5]) != 0) << "the seat lift was pressed";
  }
  EXPECT_TRUE(handshake);  // the controller was reached: only the press was withheld
}

TEST(RehandVerbTable, ErrorsAsTheChairShowsThem_WithoutALink) {
  Rig none(1);
  Where where(none, 1);
  const auto& table = rh::verb_table();
  Outcome<profile::VerbResult> r = run(table, rh::run_verb, "errors", {{"code", "10C3"}}, where);
  ASSERT_TRUE(r.ok()) << r.error().reason();
  EXPECT_EQ(r->text, fmt::format("{}: {}", rh::error_text(0x10C3), rh::error_advice(0x10C3)));
  EXPECT_EQ(r->extra["errors"].size(), 1U);
  // Four hex digits are the code as the chair shows it; else a number (0x10C3, 65535).
  r = run(table, rh::run_verb, "errors", {{"code", "0x10C3"}}, where);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->extra["errors"][0]["code"].get<std::string>(),
            rh::error_json(0x10C3)["code"].get<std::string>());
  r = run(table, rh::run_verb, "errors", {}, where);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->extra["errors"].size(), rh::error_codes().size());
  EXPECT_FALSE(run(table, rh::run_verb, "errors", {{"code", "fly"}}, where).ok());
  EXPECT_EQ(where.opened, 0);
  EXPECT_FALSE(profile::find_verb(table, "errors")->uses_link);
}

// `status` through the table: the handshake first; another device or no
// answer is the chair's 1010 (its no_answer words a link nobody answers).
// The commands check their arguments before anything is opened.
TEST(RehandVerbTable, StatusHandshakesFirst_CommandsCheckArgumentsBeforeOpening) {
  Rig chair(1);
  chair.bank.holding[rh::reg::kDeviceId] = rh::kDeviceId;
  chair.bank.holding[rh::reg::kDeviceId + 1] = 77;  // not read as the ID: the next register
  Where where(chair, 1);
  const auto& table = rh::verb_table();
  Outcome<profile::VerbResult> r = run(table, rh::run_verb, "status", {{"mph", "true"}}, where);
  ASSERT_TRUE(r.ok()) << r.error().reason();
  EXPECT_EQ(r->values["device_id"]["raw"], rh::kDeviceId);
  EXPECT_NE(r->text.find("mph"), std::string::npos) << r->text;
  EXPECT_TRUE(r->action.empty());  // a reading
  chair.bank.holding[rh::reg::kDeviceId] = 0x42;
  r = run(table, rh::run_verb, "status", {}, where);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code(), Errc::refused);
  EXPECT_TRUE(r.error().reason().starts_with(rh::error_text(rh::kMasterCommunicationError)))
      << r.error().reason();
  EXPECT_NE(r.error().reason().find("another device answers there"), std::string::npos);
  chair.silent = true;
  r = run(table, rh::run_verb, "status", {}, where);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code(), Errc::timeout);
  const std::string said = rh::device_entry().no_answer(r.error());
  EXPECT_TRUE(
      said.starts_with("1010 Master Error: handshake: no answer (timeout); check that the controller"))
      << said;
  // pulse and set would run the host controller on open_link (unset here:
  // calling it would fail the test): a bad argument never gets there.
  const int opened = where.opened;
  for (const auto& [verb, args] : std::vector<std::pair<std::string, profile::VerbArgs>>{
           {"pulse", {{"cmd", "stand"}}},
           {"hold", {{"cmd", "seat_lift"}}},
           {"hold", {{"cmd", "seat_lift"}, {"value", "up"}, {"for", "11min"}}},
           {"hold", {{"cmd", "light"}, {"value", "up"}}},
           {"set", {{"what", "speed-level"}, {"value", "6"}}},
           {"set", {{"what", "drive-mode"}, {"value", "fast"}}}}) {
    r = run(table, rh::run_verb, verb, args, where);
    ASSERT_FALSE(r.ok()) << verb;
    EXPECT_EQ(r.error().code(), Errc::invalid_argument) << r.error().reason();
  }
  EXPECT_EQ(where.opened, opened);
}

}  // namespace
}  // namespace rtukit
