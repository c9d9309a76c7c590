// One device layer (issue 27): a fact of a device is written once, in its
// table, and every front-end reads it from there.
//  - Link rows (kLinkAddress, kLinkBaud): the unit range, the factory address
//    and the baud rate come from the rows; a write to them moves the device
//    after the response, for a built-in model and for a map file alike.
//  - The CLI's device verbs, the sniffer and the simulator take the range
//    the row allows (the Inverjet answers at 1..254, the Rehand at 1..247).
//  - `set pairing` and `config pairing` take the row's value names.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>

#include "process.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/profile/device.hpp"
#include "rtukit/devices/profile/map_file.hpp"
#include "rtukit/devices/profile/reading.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/devices/registry.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"

using namespace rtukit;
using namespace rtukit::test;

namespace {

const std::string kBin = RTUKIT_BIN;
const std::string kMeter = std::string(EXAMPLES_DIR) + "/maps/energy-meter.yaml";

}  // namespace

TEST(LinkRows, TheRangeAndDefaultsComeFromTheRows) {
  const profile::UnitRange jet = profile::unit_range(inverjet::kProfile);
  EXPECT_EQ(jet.min, 1);
  EXPECT_EQ(jet.max, 254);
  EXPECT_EQ(jet.fallback, 21);
  EXPECT_EQ(profile::link_defaults(inverjet::kProfile).baud, 9600u);
  const profile::Row& baud = inverjet::kMap.row(inverjet::reg::baud);
  EXPECT_EQ(profile::baud_of(baud, 4), 19200u);  // D-4
  EXPECT_EQ(profile::raw_of_baud(baud, 1200), 0);
  EXPECT_EQ(profile::raw_of_baud(baud, 38400), -1);
  // The Rehand keeps its address out of its registers: Profile::link decides.
  const profile::UnitRange chair = profile::unit_range(rehand6600::kProfile);
  EXPECT_EQ(chair.max, 247);
  EXPECT_EQ(chair.fallback, 1);
  EXPECT_EQ(profile::link_defaults(rehand6600::kProfile).baud, 115200u);
}

// A unit as typed is checked against the device's own range, in the kit
// and in the registry's NAME@UNIT (the sniffer's --device).
TEST(LinkRows, AUnitAsTypedIsTheDevicesRange_NameAtUnitTheRegistrys) {
  EXPECT_EQ(*profile::device_unit(inverjet::kProfile, ""), 21);
  EXPECT_EQ(*profile::device_unit(inverjet::kProfile, "250"), 250);
  EXPECT_EQ(profile::device_unit(rehand6600::kProfile, "250").error().reason(),
            "rehand6600 unit 250 is out of range 1..247");
  const auto at = devices::find_at("inverjet@250");
  ASSERT_TRUE(at.ok()) << at.error().reason();
  EXPECT_EQ(at->entry, devices::find("inverjet"));
  EXPECT_EQ(at->unit.value, 250);
  EXPECT_EQ(devices::find_at("inverjet").error().reason(), "'inverjet': write NAME@UNIT (inverjet@21)");
  const std::string unknown(devices::find_at("fly@2").error().reason());
  EXPECT_TRUE(unknown.starts_with("no such device 'fly' (")) << unknown;
  EXPECT_NE(unknown.find("rehand6600"), std::string::npos) << unknown;
  EXPECT_EQ(devices::find_at("rehand6600@0").error().reason(), "rehand6600 unit 0 is out of range 1..247");
  EXPECT_EQ(profile::split_at_unit("maps/m@x.yaml@5")->first, "maps/m@x.yaml");
}

TEST(LinkRows, AWriteMovesTheDeviceAfterTheResponse_ARefusedOneDoesNot) {
  inverjet::Machine m(0);
  EXPECT_EQ(m.stored_link().unit, 21);
  const uint16_t address = 0x0000;
  const std::array<uint16_t, 2> both{7, 4};
  ASSERT_EQ(m.write_holding_registers(address, both), Errc::ok);
  const profile::LinkChange change = m.take_link_change();
  ASSERT_TRUE(change.address);
  EXPECT_EQ(*change.address, 7);
  ASSERT_TRUE(change.baud);
  EXPECT_EQ(*change.baud, 19200u);
  EXPECT_FALSE(m.take_link_change()) << "taken once";
  EXPECT_EQ(m.stored_link().unit, 7);
  EXPECT_EQ(m.stored_link().baud, 19200u);
  // The same values again: no change to apply.
  ASSERT_EQ(m.write_holding_registers(address, both), Errc::ok);
  EXPECT_FALSE(m.take_link_change());
  // Outside the row's range: 03, nothing changes.
  const std::array<uint16_t, 1> zero{0};
  EXPECT_EQ(m.write_holding_registers(address, zero), Errc::illegal_data_value);
  EXPECT_FALSE(m.take_link_change());
  EXPECT_EQ(m.override_link(uint8_t{255}, std::nullopt).code(), Errc::invalid_argument);
  EXPECT_EQ(m.override_link(std::nullopt, 38400u).code(), Errc::invalid_argument);
  EXPECT_EQ(m.stored_link().unit, 7);
  EXPECT_TRUE(m.override_link(uint8_t{254}, 1200u).ok());
  EXPECT_EQ(m.stored_link().unit, 254);
  EXPECT_EQ(m.stored_link().baud, 1200u);
}

// A map file's address and baud rows, flagged link-address and link-baud,
// act like the Inverjet's: the generic model needs no code for it.
TEST(LinkRows, AMapFilesLinkRowsTakeEffect) {
  auto map = profile::load_map(kMeter);
  ASSERT_TRUE(map.ok()) << map.error().reason();
  const profile::Profile& p = (*map)->profile();
  EXPECT_EQ(profile::link_defaults(p).unit, 1);
  EXPECT_EQ(profile::link_defaults(p).baud, 9600u);
  auto model = profile::make_register_device(p);
  const std::array<uint16_t, 1> five{5};
  ASSERT_EQ(model->write_holding_registers(0x0000, five), Errc::ok);
  const profile::LinkChange change = model->take_link_change();
  ASSERT_TRUE(change.address);
  EXPECT_EQ(*change.address, 5);
  EXPECT_FALSE(change.baud);
}

TEST(LinkRows, AMapFileThatSaysTwoThingsIsRefused) {
  const auto check = [](const std::string& yaml) {
    auto map = profile::parse_map(yaml, "m.yaml");
    return map.ok() ? std::string("ok") : std::string(map.error().reason());
  };
  const std::string head = "format: rtukit-map\ndevice:\n  name: x\n";
  const std::string address_row =
      "  - {key: address, address: 0, role: setting, range: [1, 247], default: 3, flags: [link-address]}\n";
  EXPECT_EQ(check(head + "registers:\n" + address_row), "ok");
  EXPECT_NE(check(head + "  unit: 4\nregisters:\n" + address_row).find("m.yaml:4: device.unit 4 disagrees"),
            std::string::npos)
      << check(head + "  unit: 4\nregisters:\n" + address_row);
  EXPECT_NE(
      check(head + "registers:\n" + address_row +
            "  - {key: a2, address: 1, role: setting, range: [1, 247], default: 3, flags: [link-address]}\n")
          .find("a second link-address row"),
      std::string::npos);
  EXPECT_NE(check(head + "registers:\n" +
                  "  - {key: baud, address: 1, role: setting, encoding: choice, values: {0: fast}, "
                  "flags: [link-baud]}\n")
                .find("link-baud value 0 is named 'fast', not a rate"),
            std::string::npos);
  EXPECT_NE(check(head + "registers:\n" +
                  "  - {key: address, address: 0, role: status, range: [1, 247], flags: [link-address]}\n")
                .find("one writable holding register"),
            std::string::npos);
}

// `rtukit inverjet get --unit 250` and `inverjet status --unit 250` both
// work (the row allows 1..254; the CLI once capped `get` at 247), and so does
// the sniffer's inverjet@250; the Rehand's 250 is refused by its own range.
TEST(DeviceLayerCli, TheUnitRangeIsTheRowsEverywhere) {
  TempDir dir;
  const std::string tty = dir / "tty";
  Process sim(
      {kBin, "sim", "inverjet", "--listen", "pty:" + tty, "--unit", "250", "--no-state", "--no-console"});
  ASSERT_TRUE(sim.wait_for_output("listening on")) << sim.output();
  EXPECT_NE(sim.output().find("unit 250"), std::string::npos) << sim.output();

  const RunResult get = run_cli(kBin, {"inverjet", "get", "--unit", "250", "state"}, tty);
  EXPECT_EQ(get.code, 0) << get.output;
  EXPECT_NE(get.output.find("state"), std::string::npos) << get.output;
  const RunResult status = run_cli(kBin, {"inverjet", "status", "--unit", "250"}, tty);
  EXPECT_EQ(status.code, 0) << status.output;
  const RunResult beyond = run_cli(kBin, {"inverjet", "get", "--unit", "255", "state"}, tty);
  EXPECT_EQ(beyond.code, 2) << beyond.output;
  EXPECT_NE(beyond.output.find("inverjet unit 255 is out of range 1..254"), std::string::npos)
      << beyond.output;

  // The sniffer: a device's unit is checked against that device's range
  // (a port that does not exist then fails as a port: exit 4, not 2).
  const RunResult sniff_jet = run({kBin, "sniff", "--port", dir / "absent", "--device", "inverjet@250"});
  EXPECT_EQ(sniff_jet.code, 4) << sniff_jet.output;
  const RunResult sniff_chair = run({kBin, "sniff", "--port", dir / "absent", "--device", "rehand6600@250"});
  EXPECT_EQ(sniff_chair.code, 2) << sniff_chair.output;
  EXPECT_NE(sniff_chair.output.find("rehand6600 unit 250 is out of range 1..247"), std::string::npos)
      << sniff_chair.output;
  const RunResult chair = run_cli(kBin, {"rehand6600", "status", "--unit", "250"}, tty);
  EXPECT_EQ(chair.code, 2) << chair.output;
}

// `set pairing` (the generic register verb) and `config pairing` (the
// Inverjet's own) take the same words: the row's value names.
TEST(DeviceLayerCli, SetPairingAndConfigPairingAgree) {
  TempDir dir;
  const std::string tty = dir / "tty";
  Process sim({kBin, "sim", "inverjet", "--listen", "pty:" + tty, "--no-state", "--no-console"});
  ASSERT_TRUE(sim.wait_for_output("listening on")) << sim.output();
  const auto pairing = [&] {
    const RunResult r = run_cli(kBin, {"inverjet", "get", "pairing", "--json"}, tty);
    EXPECT_EQ(r.code, 0) << r.output;
    return r.code == 0 ? nlohmann::json::parse(r.output)["values"]["pairing"]["value"].get<std::string>()
                       : std::string();
  };
  for (const char* word : {"wifi", "off", "remote"}) {
    const RunResult set = run_cli(kBin, {"inverjet", "set", "pairing", word}, tty);
    EXPECT_EQ(set.code, 0) << word << ": " << set.output;
    EXPECT_EQ(pairing(), word);
    const RunResult config = run_cli(kBin, {"inverjet", "config", "pairing", word}, tty);
    EXPECT_EQ(config.code, 0) << word << ": " << config.output;
    EXPECT_EQ(pairing(), word);
  }
  const RunResult set_bad = run_cli(kBin, {"inverjet", "set", "pairing", "bluetooth"}, tty);
  const RunResult config_bad = run_cli(kBin, {"inverjet", "config", "pairing", "bluetooth"}, tty);
  EXPECT_EQ(set_bad.code, 2) << set_bad.output;
  EXPECT_EQ(config_bad.code, 2) << config_bad.output;
  EXPECT_NE(set_bad.output.find("off, wifi, remote"), std::string::npos) << set_bad.output;
  EXPECT_NE(config_bad.output.find("off, wifi, remote"), std::string::npos) << config_bad.output;
}

// A map-file device through the same verbs: `set --map` by key, and a
// write to its link-address row moves the simulator to the new address.
TEST(DeviceLayerCli, AMapDeviceIsWrittenByKey_ItsAddressRowMovesIt) {
  TempDir dir;
  const std::string tty = dir / "tty";
  Process sim({kBin, "sim", "map", kMeter, "--listen", "pty:" + tty, "--no-state", "--no-console"});
  ASSERT_TRUE(sim.wait_for_output("listening on")) << sim.output();
  const RunResult period = run_cli(kBin, {"map", "set", "--map", kMeter, "demand_period", "30:00"}, tty);
  ASSERT_EQ(period.code, 0) << period.output;
  const RunResult read = run_cli(kBin, {"read", "--map", kMeter, "demand_period"}, tty);
  EXPECT_NE(read.output.find("demand_period = 30:00"), std::string::npos) << read.output;

  const RunResult move = run_cli(kBin, {"map", "set", "--map", kMeter, "address", "9"}, tty);
  ASSERT_EQ(move.code, 0) << move.output;
  EXPECT_TRUE(sim.wait_for_output("address changed: 1 -> 9")) << sim.output();
  const RunResult at9 = run_cli(kBin, {"read", "--map", kMeter, "--unit", "9", "address"}, tty);
  EXPECT_EQ(at9.code, 0) << at9.output;
  EXPECT_NE(at9.output.find("address = 9"), std::string::npos) << at9.output;
  const RunResult at1 =
      run_cli(kBin, {"read", "--map", kMeter, "--unit", "1", "address", "--timeout", "300"}, tty);
  EXPECT_EQ(at1.code, 3) << "the old address no longer answers: " << at1.output;
}

// The Inverjet's status view: one meaning of the run time for the CLI's
// status document, the bridge's state topic and the panel (issue 27: the
// CLI and the bridge once disagreed at the fault screen and in plans).
TEST(InverjetView, OneMeaningOfTheTime_InEveryDocument) {
  using namespace rtukit::inverjet;
  MachineStatus timer;
  timer.state = state_value(Family::timer, Phase::running);
  timer.run_time = 600;
  timer.mosfet_c = 25.0;
  EXPECT_EQ(time_counts(timer), TimeCounts::remaining);
  const nlohmann::json doc = state_document(timer);
  EXPECT_EQ(doc["mode"], "timer");
  EXPECT_EQ(doc["remaining_s"], 600);
  EXPECT_TRUE(doc["elapsed_s"].is_null());
  const nlohmann::json values = status_values(timer);
  EXPECT_EQ(values["run_time_counts"]["value"], "remaining");
  EXPECT_EQ(values["mosfet_temperature"]["raw"], 250) << "through the row's scale";

  // The fault screen: the state no longer tells; a watcher that saw the
  // timer run remembers it, one that saw nothing says so.
  MachineStatus fault = timer;
  fault.state = state_value(Family::none, Phase::fault);
  EXPECT_EQ(time_counts(fault), TimeCounts::unknown);
  EXPECT_TRUE(state_document(fault)["remaining_s"].is_null());
  EXPECT_TRUE(state_document(fault)["elapsed_s"].is_null());
  EXPECT_EQ(state_document(fault)["time_counts"], "at the fault");
  EXPECT_EQ(status_values(fault)["run_time_counts"]["value"], "at the fault");
  Family seen = remember_family(timer, Family::none);
  seen = remember_family(fault, seen);
  EXPECT_EQ(seen, Family::timer);
  EXPECT_EQ(state_document(fault, seen)["remaining_s"], 600);
  MachineStatus off;
  EXPECT_EQ(remember_family(off, seen), Family::none);

  // A plan's time counts up, also at its fault screen.
  MachineStatus plan = fault;
  plan.mode = 2;
  EXPECT_EQ(plan_of(plan), 2u);
  EXPECT_EQ(time_counts(plan), TimeCounts::elapsed);
  EXPECT_EQ(state_document(plan)["mode"], "plan 2");
  EXPECT_EQ(state_document(plan)["elapsed_s"], 600);
}

// What the swimmer's screen shows, decided in the device layer (issue 38):
// a jet that stands shows 0 %, whatever the speed register holds; the fault
// screen gives each fault's advice and refuses a start; an off machine has
// no mode.
TEST(InverjetView, TheScreensFactsComeFromTheDeviceLayer) {
  using namespace rtukit::inverjet;
  MachineStatus s;
  s.mode = 0;
  s.speed = 70;
  s.state = state_value(Family::free, Phase::running);
  nlohmann::json doc = state_document(s);
  EXPECT_EQ(doc["jet_speed"], 70);
  EXPECT_EQ(doc["mode"], "free");
  EXPECT_EQ(
      doc["allowed"],
      (nlohmann::json{{"start", true}, {"pause", true}, {"resume", false}, {"stop", true}, {"speed", true}}));

  s.state = state_value(Family::free, Phase::paused);
  EXPECT_EQ(state_document(s)["jet_speed"], 0) << "a paused jet stands";
  EXPECT_EQ(state_document(s)["allowed"]["resume"], true);
  EXPECT_EQ(state_document(s)["allowed"]["pause"], false);

  s.state = state_value(Family::none, Phase::fault);
  s.faults = (1U << 1) | (1U << 8);
  doc = state_document(s);
  EXPECT_EQ(doc["speed"], 70) << "the set speed stays the register's";
  EXPECT_EQ(doc["jet_speed"], 0) << "the fault screen's motor is at 0 rpm: 70 % would be a lie";
  EXPECT_EQ(doc["allowed"]["start"], false) << "B-3: nothing starts the motor from the fault screen";
  EXPECT_EQ(doc["allowed"]["stop"], true);
  ASSERT_EQ(doc["fault_advice"].size(), 2u);
  EXPECT_EQ(doc["fault_advice"][0]["fault"], "output over-current");
  EXPECT_NE(doc["fault_advice"][0]["advice"].get<std::string>().find("propeller"), std::string::npos);
  EXPECT_EQ(doc["fault_advice"][1]["fault"], "driver-board communication");
  EXPECT_NE(doc["fault_advice"][1]["advice"].get<std::string>().find("driver board"), std::string::npos);
  EXPECT_EQ(fault_advice(15), "a fault we cannot name: call service");
  for (const auto& bit : fault_names()) EXPECT_NE(fault_advice(bit.value), fault_advice(15)) << bit.name;

  MachineStatus off;
  off.speed = 40;
  EXPECT_EQ(state_document(off)["mode"], "off") << "not \"free\" while nothing runs";
  EXPECT_EQ(state_document(off)["allowed"]["stop"], false);
  EXPECT_EQ(state_document(off)["jet_speed"], 0);

  const nlohmann::json limits = limits_document();
  EXPECT_EQ(limits["plans"], kPlanCount);
  EXPECT_EQ(limits["segments"], kSegmentsPerPlan);
  EXPECT_EQ(limits["speed"]["max"], kMaxSpeed);
  EXPECT_EQ(limits["time_max"], "99:59");
}

// A failed command's kind is the device layer's, so no page or automation
// reads it from message text (issue 38: the panel did, by regex).
TEST(InverjetView, AFailedCommandSaysWhatKindItIs) {
  using namespace rtukit::inverjet;
  const auto described = [](const rtukit::Status& e) {
    nlohmann::json r;
    describe_failure(e, r);
    EXPECT_EQ(r["ok"], false);
    EXPECT_FALSE(r["advice"].get<std::string>().empty());
    return r;
  };
  const Error x04(Errc::server_device_failure);
  nlohmann::json r = described(rtukit::Status(x04, std::string(kFaultScreenReason) + " (voltage)"));
  EXPECT_EQ(r["code"], "fault");
  EXPECT_EQ(r["error"], "Modbus exception 04 (server device failure): the machine shows a fault (voltage)");
  EXPECT_EQ(described(rtukit::Status(x04, std::string(kMaskedReason) + " (bit 1)"))["code"], "masked");
  EXPECT_EQ(described(rtukit::Status(x04, std::string(kWrongStateReason) + " off"))["code"], "wrong_state");
  EXPECT_EQ(described(rtukit::Status(x04, "who knows"))["code"], "refused");
  EXPECT_EQ(described(rtukit::Status(Errc::invalid_argument, std::string(kNothingPausedReason)))["code"],
            "wrong_state");
  EXPECT_EQ(described(rtukit::Status(Errc::invalid_argument, "speed 101 is out of range"))["code"],
            "invalid");
  EXPECT_EQ(described(rtukit::Status(Error(Errc::illegal_data_value)))["code"], "invalid");
  EXPECT_EQ(described(rtukit::Status(Error(Errc::server_device_busy)))["code"], "busy");
  EXPECT_EQ(described(rtukit::Status(Error(Errc::timeout)))["code"], "no_answer");
  EXPECT_EQ(described(rtukit::Status(Error(Errc::bad_crc)))["code"], "no_answer");
  nlohmann::json busy;
  describe_busy("busy: 16 waiting", busy);
  EXPECT_EQ(busy["code"], "busy");
  EXPECT_EQ(busy["error"], "busy: 16 waiting");
}

// The example third device (examples/devices/thermostat: a table, a pure
// model and a registry entry, registered by one rtukit_add_device() line)
// through every verb, the simulator and the sniffer, with nothing written
// for it in cli/ or programs/.
TEST(DeviceLayerCli, TheExampleThirdDevice_EveryVerbTheSimulatorAndTheSniffer) {
  using namespace std::chrono_literals;
#ifndef RTUKIT_EXAMPLE_DEVICE
  GTEST_SKIP() << "built without RTUKIT_EXAMPLE_DEVICE";
#else
  const RunResult devices = run({kBin, "devices", "--json"});
  ASSERT_EQ(devices.code, 0) << devices.output;
  const auto list = nlohmann::json::parse(devices.output)["devices"];
  ASSERT_EQ(list.size(), 3u) << devices.output;
  EXPECT_EQ(list[2]["name"], "thermostat");
  EXPECT_EQ(list[2]["unit"], 7);  // from its link-address row
  EXPECT_EQ(list[2]["baud"], 19200);

  const RunResult reference = run({kBin, "thermostat", "registers"});
  EXPECT_NE(reference.output.find("| 0x0003 | `setpoint` | set temperature"), std::string::npos)
      << reference.output;

  TempDir dir;
  // The bus's name socket goes under $XDG_RUNTIME_DIR: this test's folder,
  // for the test only.
  const ScopedEnv runtime_dir("XDG_RUNTIME_DIR", dir.path());
  const std::string name = "thermo-" + std::to_string(::getpid());
  Process bus({kBin, "bus", "--ports", "2", "--links", (dir / "dev") + "," + (dir / "host"), "--baud",
               "19200", "--name", name});
  ASSERT_TRUE(bus.wait_for_output("listening on")) << bus.output();
  Process sim({kBin, "sim", "thermostat", "--listen", dir / "dev", "--no-state", "--no-console",
               "--time-scale", "600"});
  ASSERT_TRUE(sim.wait_for_output("listening on")) << sim.output();
  EXPECT_NE(sim.output().find("unit 7, 19200 baud"), std::string::npos) << sim.output();
  Process sniff({kBin, "sniff", "--bus", name, "--device", "thermostat@7"});
  ASSERT_TRUE(sniff.wait_for_output("Ctrl-C")) << sniff.output();

  const std::string host = dir / "host";
  const RunResult set = run_cli(kBin, {"thermostat", "set", "setpoint", "25.5"}, host);
  ASSERT_EQ(set.code, 0) << set.output;
  EXPECT_NE(set.output.find("setpoint = 25.5 degC"), std::string::npos) << set.output;
  const RunResult refused = run_cli(kBin, {"thermostat", "set", "setpoint", "40"}, host);
  EXPECT_EQ(refused.code, 2) << refused.output;  // the row's range, before the bus
  const RunResult mode = run_cli(kBin, {"thermostat", "set", "mode", "boost"}, host);
  ASSERT_EQ(mode.code, 0) << mode.output;
  // The model runs on device time (x600): the room warms toward 25.5 degC.
  EXPECT_TRUE(eventually(
      [&] {
        const RunResult s = run_cli(kBin, {"thermostat", "status", "--json"}, host);
        if (s.code != 0) return false;
        const auto doc = nlohmann::json::parse(s.output, nullptr, false);
        return doc.is_object() && doc["values"]["temperature"]["value"].get<double>() > 18.5 &&
               doc["values"]["heating"]["value"] == 100;
      },
      20s));
  const RunResult get = run_cli(kBin, {"thermostat", "get", "mode", "setpoint"}, host);
  EXPECT_NE(get.output.find("mode     = boost (2)"), std::string::npos) << get.output;
  const RunResult watch =
      run_cli(kBin, {"thermostat", "watch", "temperature", "--count", "2", "--interval", "100"}, host);
  EXPECT_EQ(watch.code, 0) << watch.output;
  EXPECT_NE(watch.output.find("temperature = "), std::string::npos) << watch.output;
  // The sniffer names the registers by the table.
  EXPECT_TRUE(eventually([&] { return sniff.output().find("setpoint") != std::string::npos; }, 10s))
      << sniff.output();
  // Its link row moves it, as for the built-in devices.
  const RunResult move = run_cli(kBin, {"thermostat", "set", "address", "9"}, host);
  ASSERT_EQ(move.code, 0) << move.output;
  EXPECT_TRUE(sim.wait_for_output("address changed: 7 -> 9")) << sim.output();
  EXPECT_EQ(run_cli(kBin, {"thermostat", "get", "--unit", "9", "mode"}, host).code, 0);
#endif
}

// ------------------------------------------------------------ the docs generator reads the registry

TEST(DocsFromTheRegistry, EachSectionIsRewrittenFromItsTable_AMissingOneIsNamed) {
  const profile::DeviceEntry* rehand = devices::find("rehand6600");
  ASSERT_NE(rehand, nullptr);
  std::vector<std::string> names;
  for (const profile::DocSection& s : profile::doc_sections(*rehand)) names.emplace_back(s.name);
  EXPECT_EQ(names, (std::vector<std::string>{"registers", "commands", "errors", "stopping"}));
  EXPECT_EQ(rehand->doc, "docs/rehand6600.md");

  const profile::DeviceEntry* jet = devices::find("inverjet");
  ASSERT_NE(jet, nullptr);
  const std::string stale =
      "# Inverjet\nintro\n<!-- BEGIN GENERATED: rtukit inverjet registers -->\nold table\n"
      "<!-- END GENERATED: rtukit inverjet registers -->\nafter\n"
      "<!-- BEGIN GENERATED: rtukit inverjet commands -->\nold commands\n"
      "<!-- END GENERATED: rtukit inverjet commands -->\n";
  const Outcome<std::string> now = profile::regenerate_doc(*jet, stale);
  ASSERT_TRUE(now.ok()) << now.error().reason();
  EXPECT_EQ(now->find("old table"), std::string::npos);
  EXPECT_NE(now->find("| 0x0022 | `state` | state machine | RW |"), std::string::npos);
  // The commands, from the verb table the CLI builds its subcommands from.
  EXPECT_EQ(now->find("old commands"), std::string::npos);
  EXPECT_NE(now->find("| `rtukit inverjet speed SPEED` | set the running speed |"), std::string::npos);
  EXPECT_EQ(now->rfind("# Inverjet\nintro\n", 0), 0u);
  EXPECT_NE(now->find("<!-- END GENERATED: rtukit inverjet registers -->\nafter\n"), std::string::npos);
  EXPECT_EQ(profile::regenerate_doc(*jet, *now).value(), *now);  // stable

  const Outcome<std::string> missing = profile::regenerate_doc(*rehand, stale);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(std::string(missing.error().reason()).find("rtukit rehand6600 registers"), std::string::npos)
      << missing.error().reason();
}

// Issue 38: `inverjet set state fault_screen` answered "fault_screen is not
// one of off, ..., fault_screen". A name the row reads but a write may not
// give says so, and the list a refusal gives holds only what a write takes.
TEST(WriteByKey, ANameAWriteMayNotGiveIsReadOnly_NotMissing) {
  namespace ij = rtukit::inverjet;
  Outcome<profile::KeyWrite> w = profile::plan_key_write(ij::kProfile, "state", "fault_screen");
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(
      w.error().reason(),
      "state: fault_screen (17) is read only: the device sets it itself; a write takes off, free_initial, "
      "free_starting, free_running, free_paused, free_ended, timer_initial, timer_starting, timer_running, "
      "timer_paused, timer_ended, training_initial, training_starting, training_running, training_paused, "
      "training_ended, operation_menu");
  w = profile::plan_key_write(ij::kProfile, "state", "17");
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().reason().find("state: 17 (fault_screen) is read only"), std::string_view::npos)
      << w.error().reason();
  w = profile::plan_key_write(ij::kProfile, "state", "flying");
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().reason().find("'flying' is not a state (off, "), std::string_view::npos)
      << w.error().reason();
  EXPECT_EQ(w.error().reason().find("fault_screen"), std::string_view::npos) << w.error().reason();
  EXPECT_TRUE(profile::plan_key_write(ij::kProfile, "state", "operation_menu").ok());
}
