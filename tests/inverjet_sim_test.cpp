// The simulated Inverjet as users meet it: the `rtukit sim inverjet` process
// on a pty, driven by the typed client (in this process), by the rtukit CLI,
// by its console (stdin), and by peers we did not write (pymodbus, libmodbus).
// Device time runs scaled (--time-scale), so minutes pass in a second; tests
// poll for conditions (eventually), never sleep for device time.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "process.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/port.hpp"
#include "rtukit/io/serial_config.hpp"
#include "wire.hpp"

using namespace rtukit;
using namespace rtukit::test;
using namespace std::chrono_literals;
using nlohmann::json;

namespace {

const std::string kRtukit = RTUKIT_BIN;

// One simulator process on a fresh pty, with its own state file.
class InverjetSim : public ::testing::Test {
 protected:
  void SetUp() override { start(); }

  void start(const std::string& scale = "20", std::vector<std::string> extra = {}) {
    sim_.reset();
    std::vector<std::string> argv{kRtukit,       "sim",          "inverjet",          "--listen",
                                  "pty:" + tty_, "--state-file", dir_ / "state.json", "--time-scale",
                                  scale};
    argv.insert(argv.end(), extra.begin(), extra.end());
    sim_ = std::make_unique<Process>(argv, /*stdin_pipe=*/true);
    ASSERT_TRUE(sim_->wait_for_output("listening on")) << sim_->output();
  }
  RunResult cli(std::vector<std::string> args, bool with_port = true) {
    return run_cli(kRtukit, std::move(args), with_port ? tty_ : std::string());
  }
  // The status document's values, flattened: a register's raw value, a
  // derived item's value (docs/json.md).
  json status(const std::string& unit = "21") {
    const RunResult r = cli({"inverjet", "status", "--json", "--unit", unit});
    EXPECT_EQ(r.code, 0) << r.output;
    return r.code == 0 ? flat(json::parse(r.output)) : json{};
  }
  static json flat(const json& document) {
    json out;
    for (const auto& [key, entry] : document.at("values").items())
      out[key] = entry.contains("raw") ? entry["raw"] : entry["value"];
    return out;
  }
  std::unique_ptr<Master> master() {
    auto spec = io::parse_port(tty_, false);
    return std::make_unique<Master>(io::make_link(*spec), MasterOptions{.response_timeout = 1000ms});
  }

  TempDir dir_;
  std::string tty_ = dir_ / "tty";
  std::unique_ptr<Process> sim_;
};

// ------------------------------------------------------------ seed frames, raw bytes on the pty

// Writes `request` to the pty as is and returns what comes back (hex), the
// way a logic analyser would see it: up to the first whole frame (its CRC
// right), or all that came within `wait` when none did. `wait` bounds an
// answer that is late (a busy machine); silence is asserted with it too,
// and a late answer would then show in the next exchange's bytes, in front
// of that one's frame (the test below asks again right after a silence).
std::string exchange(int fd, const std::string& request, std::chrono::milliseconds wait = 2000ms) {
  const auto out = bytes(request);
  if (::write(fd, out.data(), out.size()) != static_cast<ssize_t>(out.size())) return "write failed";
  std::vector<uint8_t> in;
  const auto whole = [&in] {
    return in.size() >= 5 && rtukit::crc16(std::span<const uint8_t>(in.data(), in.size() - 2)) ==
                                 (in[in.size() - 2] | in[in.size() - 1] << 8);
  };
  const auto end = std::chrono::steady_clock::now() + wait;
  while (std::chrono::steady_clock::now() < end && !whole()) {
    uint8_t buf[256];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n > 0) in.insert(in.end(), buf, buf + n);
    std::this_thread::sleep_for(5ms);
  }
  return hex(in);
}

TEST_F(InverjetSim, SeedFramesByteForByte_OverThePty) {
  start("1");  // real time: the 3-s initial state lasts while we look
  const int fd = ::open(tty_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  ASSERT_GE(fd, 0);
  ASSERT_FALSE(io::make_raw(fd));
  EXPECT_EQ(exchange(fd, "15 03 00 00 00 01 87 1E"), "15 03 02 00 15 49 88");
  EXPECT_EQ(exchange(fd, "15 03 00 21 00 04 17 17"), "15 03 08 00 00 00 00 00 00 00 00 D4 27");
  EXPECT_EQ(exchange(fd, "15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F"), "15 10 00 21 00 04 92 D4");
  EXPECT_EQ(exchange(fd, "15 03 00 21 00 04 17 17"), "15 03 08 00 00 00 06 00 50 07 08 5F C0");
  EXPECT_EQ(exchange(fd, "15 10 00 21 00 02 00 00 00 01 25 40"), "15 10 00 21 00 02 12 D6");  // short form
  EXPECT_EQ(exchange(fd, "15 10 00 21 00 02 04 00 00 00 06 F1 89"),
            "15 10 00 21 00 02 12 D6");                                           // standard form
  EXPECT_EQ(exchange(fd, "15 06 00 00 00 0C 8A DB"), "15 06 00 00 00 0C 8A DB");  // answered from 0x15...
  EXPECT_EQ(exchange(fd, "15 03 00 00 00 01 87 1E"), "");                         // ...which is gone
  EXPECT_EQ(exchange(fd, "0C 03 00 00 00 01 85 17"), "0C 03 02 00 0C 95 80");     // (no late 0x15 answer first)
  ::close(fd);
}

// ------------------------------------------------------------ typed client

TEST_F(InverjetSim, Client_TimerRunCountsDownToEnded) {
  auto m = master();
  inverjet::Client jet(*m);
  ASSERT_FALSE(jet.start_timer(60, 20));
  Result<inverjet::MachineStatus> s = jet.status();
  ASSERT_TRUE(s.ok()) << s.error().name();
  EXPECT_EQ(s->family(), inverjet::Family::timer);
  EXPECT_EQ(s->speed, 60);
  EXPECT_LE(s->run_time, 20);
  EXPECT_TRUE(s->fault_names().empty());
  EXPECT_EQ(s->display_software, 0x00010002u);
  // 20 device seconds at x20: about a second.
  ASSERT_TRUE(eventually([&] { return jet.status()->state == 10; }, 10s));
  EXPECT_EQ(jet.status()->run_time, 0);
  EXPECT_EQ(jet.status()->state_name(), "timer ended");
}

TEST_F(InverjetSim, Client_PauseFreezesResumeCountsStopTurnsOff) {
  auto m = master();
  inverjet::Client jet(*m);
  ASSERT_FALSE(jet.start_timer(50, 600));
  ASSERT_TRUE(eventually([&] { return jet.status()->run_time < 598; }));
  ASSERT_FALSE(jet.pause());
  const uint16_t t1 = jet.status()->run_time;
  EXPECT_EQ(jet.status()->state, 9);
  // That a pause freezes the timer, to the second, is checked on virtual
  // time (InverjetOnVirtualTime.*); here: the same verbs over the process.
  EXPECT_EQ(jet.status()->run_time, t1);
  EXPECT_EQ(jet.resume(), Errc::ok);
  EXPECT_TRUE(eventually([&] { return jet.status()->run_time < t1; }));
  ASSERT_FALSE(jet.set_speed(80));
  EXPECT_EQ(jet.status()->speed, 80);
  ASSERT_FALSE(jet.stop());
  EXPECT_EQ(jet.status()->state, 0);
  EXPECT_EQ(jet.resume(), Errc::invalid_argument);  // nothing paused
  const Status e = jet.pause();                     // nothing runs: the machine says 04
  EXPECT_TRUE(e.is_exception());
  EXPECT_EQ(e.error().exception_code(), 0x04);
  EXPECT_EQ(e.reason(), "not possible while off");  // the client says why
}

TEST_F(InverjetSim, Client_PlansRoundTripAndStartPartWay) {
  auto m = master();
  inverjet::Client jet(*m);
  const std::vector<inverjet::Segment> three{{30, 60}, {60, 120}, {40, 180}};
  ASSERT_FALSE(jet.write_plan(2, three));
  EXPECT_EQ(*jet.read_plan(2), three);
  std::vector<inverjet::Segment> fifty;
  for (uint16_t k = 0; k < 50; ++k)
    fifty.push_back({static_cast<uint16_t>(k * 2), static_cast<uint16_t>(100 * (k + 1))});
  ASSERT_FALSE(jet.write_plan(3, fifty));
  EXPECT_EQ(*jet.read_plan(3), fifty);
  // Over a longer plan, a shorter one ends where it should (terminator written).
  ASSERT_FALSE(jet.write_plan(3, three));
  EXPECT_EQ(*jet.read_plan(3), three);
  ASSERT_FALSE(jet.start_plan(2, 90));
  Result<inverjet::MachineStatus> s = jet.status();
  EXPECT_EQ(s->mode, 2);
  EXPECT_EQ(s->family(), inverjet::Family::training);
  EXPECT_EQ(s->speed, 60);  // segment 2 (60..120 s)
  EXPECT_GE(s->run_time, 90);
  EXPECT_EQ(jet.start_plan(2, 180), Errc::invalid_argument);  // nothing left to run
  ASSERT_FALSE(jet.clear_plan(2));
  EXPECT_EQ(*jet.read_plan(2), (std::vector<inverjet::Segment>{{20, 60}}));
  ASSERT_FALSE(jet.stop());
}

TEST_F(InverjetSim, Client_BadArgumentsSendNothing_MaskedControlAnswers04) {
  auto m = master();
  inverjet::Client jet(*m);
  const std::vector<inverjet::Segment> decreasing{{30, 120}, {60, 60}};
  const Status why = inverjet::validate_plan(decreasing);
  EXPECT_EQ(why, Errc::invalid_argument);
  EXPECT_NE(why.reason().find("segment 2"), std::string::npos) << why.reason();
  const uint64_t before = m->stats().requests;
  EXPECT_EQ(jet.write_plan(1, decreasing), Errc::invalid_argument);
  EXPECT_EQ(jet.set_speed(101), Errc::invalid_argument);
  EXPECT_EQ(jet.start_timer(50, 6000), Errc::invalid_argument);
  EXPECT_EQ(jet.set_baud(115200), Errc::invalid_argument);
  EXPECT_EQ(m->stats().requests, before);
  ASSERT_FALSE(jet.set_control_mask(2));
  const Status e = jet.start_free(40);
  EXPECT_TRUE(e.is_exception());
  EXPECT_EQ(e.error().exception_code(), 0x04);
  EXPECT_NE(e.reason().find("control mask bit 1"), std::string::npos) << e.reason();  // the client says why
  ASSERT_FALSE(jet.set_control_mask(0));
  EXPECT_FALSE(jet.start_free(40));
  ASSERT_FALSE(jet.stop());
}

// ------------------------------------------------------------ CLI

TEST_F(InverjetSim, Cli_StartWatchStop) {
  RunResult r = cli({"inverjet", "start", "--timer", "10:00", "--speed", "70"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("timer mode, 10:00 at 70 %"), std::string::npos) << r.output;
  r = cli({"inverjet", "watch", "--count", "3", "--interval", "100"});
  ASSERT_EQ(r.code, 0) << r.output;
  size_t lines = 0;
  for (size_t at = 0; (at = r.output.find("speed  70 %", at)) != std::string::npos; ++at) ++lines;
  EXPECT_EQ(lines, 3u) << r.output;
  EXPECT_NE(r.output.find("remaining"), std::string::npos) << r.output;
  r = cli({"inverjet", "watch", "--count", "2", "--interval", "100", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(flat(json::parse(r.output.substr(0, r.output.find('\n'))))["family"], "timer");
  const json s = status();
  EXPECT_EQ(s["speed"], 70);
  EXPECT_EQ(s["family"], "timer");
  EXPECT_LE(s["run_time"].get<int>(), 600);
  r = cli({"inverjet", "stop"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(status()["phase"], "off");
  r = cli({"inverjet", "status"});
  EXPECT_NE(r.output.find("state     off (0)"), std::string::npos) << r.output;
}

// The live view as an installer leaves it running: in the fault screen of a
// timer run the time stays "remaining"; when the link drops the view says
// since when it is stale instead of scrolling bare errors, and keeps going.
TEST_F(InverjetSim, Watch_FaultScreenKeepsRemaining_LinkLossIsStale) {
  ASSERT_EQ(cli({"inverjet", "start", "--timer", "20:00", "--speed", "60"}).code, 0);
  Process watch({kRtukit, "inverjet", "watch", "--port", tty_, "--interval", "100", "--count", "60",
                 "--timeout", "150"});
  ASSERT_TRUE(watch.wait_for_output("timer running")) << watch.output();
  ASSERT_TRUE(sim_->send("fault motor-drive\n"));
  ASSERT_TRUE(watch.wait_for_output("fault screen")) << watch.output();
  const std::string out = watch.output();
  const size_t line_start = out.rfind('\n', out.find("fault screen")) + 1;
  const std::string fault_line = out.substr(line_start, out.find('\n', line_start) - line_start);
  EXPECT_NE(fault_line.find("remaining"), std::string::npos) << fault_line;
  EXPECT_EQ(fault_line.find("elapsed"), std::string::npos) << fault_line;
  sim_.reset();  // the machine goes away
  ASSERT_TRUE(watch.wait_for_output("stale since")) << watch.output();
  EXPECT_TRUE(watch.running()) << watch.output();  // still watching, waiting for the link
  watch.stop();
}

// On a terminal (a pty from `script`): the panel redraws in place, fits 80
// columns, the fault is red, and NO_COLOR turns colour off.
TEST_F(InverjetSim, WatchPanelOnATerminal_80Columns_FaultInRed_NoColor) {
  ASSERT_EQ(cli({"inverjet", "start", "--free", "--speed", "50"}).code, 0);
  ASSERT_TRUE(sim_->send("fault motor-drive\n"));
  ASSERT_TRUE(sim_->wait_for_output("state fault screen (17)")) << sim_->output();
  const std::string watch = kRtukit + " inverjet watch --port " + tty_ + " --count 1";
  const RunResult coloured = run({"script", "-qec", "env -u NO_COLOR " + watch, "/dev/null"});
  ASSERT_EQ(coloured.code, 0) << coloured.output;
  EXPECT_NE(coloured.output.find("\x1b[H\x1b[2J"), std::string::npos);  // redraw in place
  EXPECT_NE(coloured.output.find("\x1b[1;31mmotor drive (0x0080)"), std::string::npos) << coloured.output;
  const RunResult plain = run({"script", "-qec", "env NO_COLOR=1 " + watch, "/dev/null"});
  ASSERT_EQ(plain.code, 0) << plain.output;
  EXPECT_NE(plain.output.find("motor drive (0x0080)"), std::string::npos) << plain.output;
  EXPECT_EQ(plain.output.find("\x1b[1;31m"), std::string::npos) << plain.output;
  std::string line;
  for (std::istringstream in(plain.output.substr(plain.output.find("\x1b[2J") + 7));
       std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    EXPECT_LE(line.size(), 80u) << line;
  }
}

// --trace shows each frame both ways with a timestamp, --log appends the same to a file.
TEST_F(InverjetSim, TraceAndLogShowEveryFrame) {
  const std::string log = dir_ / "frames.log";
  RunResult r = cli({"read", "--unit", "21", "0x21", "4", "--trace", "--log", log});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find(" > 15 03 00 21 00 04 17 17\n"), std::string::npos) << r.output;  // seed frame
  EXPECT_NE(r.output.find(" < 15 03 08 "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(ok, "), std::string::npos) << r.output;
  const std::string logged = read_file(log);
  EXPECT_NE(logged.find(" > 15 03 00 21 00 04 17 17\n"), std::string::npos) << logged;
  r = cli({"read", "--unit", "22", "0x21", "1", "--trace", "--timeout", "100", "--retries", "1"});
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("(attempt 2)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" < nothing (timeout, "), std::string::npos) << r.output;
  r = cli({"read", "--unit", "21", "0", "--log", dir_ / "no-such-dir/x.log"});
  EXPECT_EQ(r.code, 4) << r.output;
  EXPECT_NE(r.output.find("--log "), std::string::npos) << r.output;
}

// Every device command answers --json with one document (docs/json.md).
TEST_F(InverjetSim, CommandsAnswerJson) {
  RunResult r = cli({"inverjet", "start", "--free", "--speed", "40", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  json j = json::parse(r.output);
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["action"], "start");
  EXPECT_EQ(j["device"], "inverjet");
  EXPECT_TRUE(j["time"].get<std::string>().ends_with("Z"));
  j = json::parse(cli({"inverjet", "speed", "55", "--json"}).output);
  EXPECT_EQ(j["values"]["speed"]["value"], 55);
  EXPECT_EQ(j["values"]["speed"]["unit"], "%");
  EXPECT_EQ(json::parse(cli({"inverjet", "stop", "--json"}).output)["action"], "stop");
  // A failure is a document too (and still one line on stderr, and the exit code).
  r = cli({"inverjet", "status", "--json", "--unit", "99", "--timeout", "100"});
  EXPECT_EQ(r.code, 3);
  const std::string last = r.output.substr(r.output.find('{'));
  j = json::parse(last.substr(0, last.find('\n')));
  EXPECT_EQ(j["ok"], false);
  EXPECT_EQ(j["error"]["kind"], "no_response");
  EXPECT_EQ(j["error"]["exit"], 3);
}

TEST_F(InverjetSim, Cli_PlanSetShow_CsvAndJson) {
  std::ofstream(dir_ / "plan.csv")
      << "# warm-up, sprint, cool-down\nspeed,end\n30,05:00\n80, 6:00\n\n40,10m\n";
  RunResult r = cli({"inverjet", "plan", "set", "1", dir_ / "plan.csv"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("3 segment(s) written, ends at 10:00"), std::string::npos) << r.output;
  r = cli({"inverjet", "plan", "show", "1", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(json::parse(r.output)["segments"],
            json::parse(R"([{"speed":30,"end":"05:00","end_s":300},{"speed":80,"end":"06:00","end_s":360},
                            {"speed":40,"end":"10:00","end_s":600}])"));
  // What `plan show --json` prints is a plan file too.
  std::ofstream(dir_ / "shown.json") << r.output;
  ASSERT_EQ(cli({"inverjet", "plan", "set", "2", dir_ / "shown.json"}).code, 0);
  EXPECT_EQ(json::parse(cli({"inverjet", "plan", "show", "2", "--json"}).output)["segments"],
            json::parse(r.output)["segments"]);
  std::ofstream(dir_ / "plan.json") << R"([{"speed": 25, "end": "01:30"}, {"speed": 55, "end": "5m"}])";
  ASSERT_EQ(cli({"inverjet", "plan", "set", "4", dir_ / "plan.json"}).code, 0);
  r = cli({"inverjet", "plan", "show", "4"});
  EXPECT_NE(r.output.find("speed,end\n25,01:30\n55,05:00\n"), std::string::npos) << r.output;
  // What `plan show` prints reads back with `plan set`.
  std::ofstream(dir_ / "shown.csv") << r.output;
  EXPECT_EQ(cli({"inverjet", "plan", "set", "3", dir_ / "shown.csv"}).code, 0);
  EXPECT_EQ(cli({"inverjet", "plan", "clear", "4"}).code, 0);
  EXPECT_EQ(json::parse(cli({"inverjet", "plan", "show", "4", "--json"}).output)["segments"],
            json::parse(R"([{"speed":20,"end":"01:00","end_s":60}])"));
}

TEST_F(InverjetSim, Cli_BadInput_ExitCodesAndOneLine) {
  struct Case {
    std::vector<std::string> args;
    int code;
    std::string says;
    bool with_port = true;
  };
  std::ofstream(dir_ / "decreasing.csv") << "speed,end\n30,02:00\n40,01:00\n";
  std::ofstream(dir_ / "fast.csv") << "101,01:00\n";
  std::ofstream(dir_ / "broken.json") << R"([{"speed": 20, "end": "01:00"},)";
  const std::vector<Case> cases = {
      {{"inverjet", "speed", "101"}, 2, "speed (%) 101 is out of range 0..100"},
      {{"inverjet", "start", "--timer", "100m", "--speed", "50"}, 2, "out of range 1..5999 s"},
      // A bare number has no unit: refused with the forms that work (a timer of "30" once ran 30 s).
      {{"inverjet", "start", "--timer", "30", "--speed", "50"}, 2, "write 30:00 (mm:ss), 30m or 90s"},
      {{"inverjet", "start", "--timer", "100:00", "--speed", "50"}, 2, "out of range 1..5999 s"},
      {{"inverjet", "start", "--timer", "ten", "--speed", "50"}, 2, "for example 30:00, 30m, 90s"},
      {{"inverjet", "start", "--free", "--timer", "1:00"}, 2, "choose one of"},
      {{"inverjet", "plan", "set", "1", dir_ / "decreasing.csv"}, 2, "line 3: end 01:00 is not after 02:00"},
      {{"inverjet", "plan", "set", "1", dir_ / "fast.csv"}, 2, "line 1: speed 101 % is out of range"},
      {{"inverjet", "plan", "set", "1", dir_ / "broken.json"}, 2, "not a valid JSON array"},
      // A file the OS cannot give: an I/O error, exit 4, as `map check` (it was 2).
      {{"inverjet", "plan", "set", "1", dir_ / "missing.csv"}, 4, "cannot read plan file"},
      {{"inverjet", "plan", "set", "1", "/dev/zero"}, 2, "not a regular file"},  // never read forever
      {{"inverjet", "plan", "show", "5"}, 2, "plan 5 is out of range 1..4"},
      {{"inverjet", "status", "--unit", "255"}, 2, "unit 255 is out of range 1..254"},
      {{"inverjet", "config", "baud", "115200"}, 2, "19200"},
      {{"inverjet", "resume"}, 2, "nothing is paused"},
      {{"inverjet", "pause"}, 1, "Modbus exception 04"},
      {{"inverjet", "status", "--unit", "22", "--timeout", "200"}, 3, "no response"},
      {{"inverjet", "status", "--port", dir_ / "no-such-tty"}, 4, "No such file or directory", false},
  };
  for (const Case& c : cases) {
    const RunResult r = cli(c.args, c.with_port);
    EXPECT_EQ(r.code, c.code) << c.args[1] << " " << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;  // one line
  }
  EXPECT_EQ(status()["state"], 0);  // nothing was half-applied
}

// A --state-file that is not this device's state file (issue 13, files) is
// never overwritten: the simulator refuses to start with one line and exit
// 5, leaves the file as it was, and never blocks on a FIFO. --force-state
// replaces it.
// The panel and the bridge fail at start, one line and exit 4, on a port
// that does not exist or is not a serial port (issue 28: they ran on,
// polling nothing). A broker that does not answer at start is no failure:
// the bridge keeps retrying, and says so on stderr instead of in silence.
TEST_F(InverjetSim, PanelAndBridge_FailAtStartOnABadPort_BridgeSaysItRetriesTheBroker) {
  const std::string regular = dir_ / "not-a-tty";
  std::ofstream(regular) << "x";
  const std::string broker = "mqtt://127.0.0.1:" + std::to_string(free_tcp_port());
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases = {
      {{"inverjet", "panel", "--http", "127.0.0.1:0", "--port", dir_ / "nothing"},
       "rtukit: inverjet panel: port " + dir_ / "nothing" + " 9600 8N1: No such file or directory\n"},
      {{"inverjet", "panel", "--http", "127.0.0.1:0", "--port", regular},
       "rtukit: inverjet panel: port " + regular + " 9600 8N1: not a serial port\n"},
      {{"inverjet", "bridge", "--id", "pool1", "--mqtt", broker, "--port", dir_ / "nothing"},
       "rtukit: inverjet bridge: port " + dir_ / "nothing" + " 9600 8N1: No such file or directory\n"},
      {{"inverjet", "bridge", "--id", "pool1", "--mqtt", broker, "--port", regular},
       "rtukit: inverjet bridge: port " + regular + " 9600 8N1: not a serial port\n"},
  };
  for (const Case& c : cases) {
    const RunResult r = cli(c.args, false);
    EXPECT_EQ(r.code, 4) << r.output;
    EXPECT_EQ(r.output, c.says);
  }
  Process bridge(
      {kRtukit, "inverjet", "bridge", "--id", "pool1", "--mqtt", broker, "--user", "jet", "--port", tty_});
  ASSERT_TRUE(bridge.wait_for_output("retrying every 1 s")) << bridge.output();
  EXPECT_NE(bridge.output().find("inverjet bridge: the broker at 127.0.0.1:" + broker.substr(17) +
                                 " does not answer (Connection refused); retrying every 1 s, then less often "
                                 "(every 30 s at most)\n"),
            std::string::npos)
      << bridge.output();
  EXPECT_TRUE(bridge.running());
  bridge.stop();
}

// `inverjet status` (every inverjet command) first checks that the slave is
// an Inverjet, as the Rehand commands check the device ID 0x68: its motor
// pole count (holding 0x0004) always reads 5. A generic slave at unit 21
// (reads 0) and one without that register (exception 02) are refused with
// one line and exit 5, the CLI's "not the expected device"; nothing is written.
TEST(InverjetIdentity, AnotherDeviceAtTheAddressIsRefused_Exit5) {
  TempDir dir;
  const std::string tty = dir / "tty";
  Process slave({kRtukit, "slave", "--listen", "pty:" + tty, "--unit", "21"});
  ASSERT_TRUE(slave.wait_for_output("listening on")) << slave.output();
  const std::string not_jet =
      "rtukit: Inverjet unit 21 on " + tty +
      " 9600 8N1: not an Inverjet: its motor pole count (holding 0x0004) reads 0 where "
      "an Inverjet's always reads 5; check --port and --unit\n";
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"inverjet", "status"}, {"inverjet", "watch", "--count", "1"}, {"inverjet", "stop"}}) {
    const RunResult r = run_cli(kRtukit, args, tty);
    EXPECT_EQ(r.code, 5) << args[1] << ": " << r.output;
    EXPECT_EQ(r.output, not_jet) << args[1];
  }
  const RunResult j = run_cli(kRtukit, {"inverjet", "status", "--json"}, tty);
  EXPECT_EQ(j.code, 5) << j.output;
  EXPECT_NE(j.output.find(R"("ok":false,"error":{"exit":5,"kind":"refused")"), std::string::npos) << j.output;
  // Nothing was written: the holding registers still read 0.
  EXPECT_EQ(run_cli(kRtukit, {"read", "--unit", "21", "0x21", "4"}, tty).output,
            "33 (0x0021): 0\n34 (0x0022): 0\n35 (0x0023): 0\n36 (0x0024): 0\n");
  // A slave without register 0x0004 answers exception 02.
  Process small({kRtukit, "slave", "--listen", "pty:" + dir / "tty2", "--unit", "21", "--registers", "2"});
  ASSERT_TRUE(small.wait_for_output("listening on")) << small.output();
  const RunResult r = run_cli(kRtukit, {"inverjet", "status"}, dir / "tty2");
  EXPECT_EQ(r.code, 5) << r.output;
  EXPECT_NE(
      r.output.find("not an Inverjet: its motor pole count (holding 0x0004) answers Modbus exception 02 "
                    "(illegal data address) where an Inverjet's always reads 5"),
      std::string::npos)
      << r.output;
}

TEST(InverjetSimStateFile, AFileThatIsNotOursIsRefused_ForceStateReplacesIt) {
  TempDir dir;
  const std::string other = dir / "settings.json", tty = dir / "tty";
  const std::string theirs = "{\"theme\": \"dark\", \"volume\": 7}\n";
  std::ofstream(other) << theirs;
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0644), 0);
  const auto sim = [&](const std::string& state, std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{kRtukit,      "sim",          "inverjet",     "--listen",
                                  "pty:" + tty, "--no-console", "--state-file", state};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return argv;
  };
  for (const std::string& state : {other, dir / "fifo", std::string("/dev/null")}) {
    const RunResult r = run(sim(state), 5000ms);
    EXPECT_EQ(r.code, 5) << state << ": " << r.output;
    EXPECT_NE(r.output.find("is not a inverjet state file"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("--force-state"), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  EXPECT_EQ(read_file(other), theirs);
  EXPECT_FALSE(path_exists(tty));  // refused before listening

  Process forced(sim(other, {"--force-state"}));
  ASSERT_TRUE(forced.wait_for_output("listening on")) << forced.output();
  EXPECT_NE(forced.output().find("replacing it (--force-state)"), std::string::npos) << forced.output();
  EXPECT_TRUE(eventually([&] { return read_file(other).find("\"rtukit-state\"") != std::string::npos; }));
}

TEST_F(InverjetSim, Cli_Registers_PrintsTheTable) {
  const RunResult r = cli({"inverjet", "registers"}, false);
  ASSERT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("| 0x0022 | `state` | state machine | RW |"), std::string::npos) << r.output;
  const RunResult j = cli({"inverjet", "registers", "--json"}, false);
  EXPECT_EQ(json::parse(j.output)["registers"].size(), 13u + 8u + 11u);  // the map-file format
}

// ------------------------------------------------------------ console, persistence, address

TEST_F(InverjetSim, Console_FaultShowsIn0008AndDrivesState17) {
  // The device clock all but stopped (a device second per 100 s): a mosfet
  // set to 95 degC cools below its 80-degC reset point in 14.5 device
  // seconds, 0.7 s of wall time at x20, less than a status read may take
  // under a sanitizer on a busy machine. Nothing here waits for device time.
  start("0.01");
  ASSERT_EQ(cli({"inverjet", "start", "--free", "--speed", "50"}).code, 0);
  ASSERT_TRUE(sim_->send("fault motor-drive\n"));
  ASSERT_TRUE(sim_->wait_for_output("faults: motor drive (0x0080), state fault screen (17)"))
      << sim_->output();
  json s = status();
  EXPECT_EQ(s["faults"], 0x80);
  EXPECT_EQ(s["state"], 17);
  const json doc = json::parse(cli({"inverjet", "status", "--json"}).output);
  EXPECT_EQ(doc["values"]["faults"]["value"], json::array({"motor drive"}));
  EXPECT_EQ(doc["values"]["state"]["value"], "fault screen");
  EXPECT_EQ(doc["device"], "inverjet");
  EXPECT_EQ(doc["unit"], 21);
  const RunResult r = cli({"inverjet", "start", "--free", "--speed", "50"});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("exception 04"), std::string::npos) << r.output;
  ASSERT_TRUE(sim_->send("fault 1\nfault clear\n"));
  ASSERT_TRUE(sim_->wait_for_output("faults: none (0x0000), state off (0)")) << sim_->output();
  EXPECT_EQ(status()["state"], 0);
  ASSERT_TRUE(sim_->send("temp mosfet 95\n"));
  EXPECT_TRUE(eventually([&] { return status()["faults"] == 0x08; })) << sim_->output();
  ASSERT_TRUE(sim_->send("status\nbogus\n"));
  EXPECT_TRUE(sim_->wait_for_output("unknown command 'bogus'")) << sim_->output();
  EXPECT_NE(sim_->output().find("machine fault bits"), std::string::npos);
}

TEST_F(InverjetSim, SettingsSurviveARestart_AddressMovesAfterTheResponse) {
  std::ofstream(dir_ / "plan.csv") << "35,02:00\n45,04:00\n";
  ASSERT_EQ(cli({"inverjet", "plan", "set", "2", dir_ / "plan.csv"}).code, 0);
  ASSERT_EQ(cli({"inverjet", "start", "--timer", "25:00", "--speed", "65", "--remember"}).code, 0);
  ASSERT_EQ(cli({"inverjet", "config", "mask", "4"}).code, 0);
  ASSERT_EQ(cli({"inverjet", "config", "baud", "19200"}).code, 0);  // a pty carries any rate
  EXPECT_TRUE(sim_->wait_for_output("baud rate changed to 19200")) << sim_->output();
  RunResult r = cli({"inverjet", "config", "address", "12"});  // seed 3.2.1: answered from 21
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("address 21 -> 12 (talk to --unit 12 from now on)"), std::string::npos) << r.output;
  EXPECT_EQ(cli({"inverjet", "status", "--timeout", "200"}).code, 3);  // 21 is gone
  EXPECT_EQ(status("12")["work_mode"], 0);

  start();  // a new process on the same state file, no --unit: the saved address
  EXPECT_NE(sim_->output().find("unit 12, 19200 baud"), std::string::npos) << sim_->output();
  r = cli({"inverjet", "config", "show", "--json", "--unit", "12"});
  ASSERT_EQ(r.code, 0) << r.output;
  const json c = flat(json::parse(r.output));
  EXPECT_EQ(c["address"], 12);
  EXPECT_EQ(c["control_mask"], 4);
  EXPECT_EQ(c["baud"], 4);
  EXPECT_EQ(c["timer_speed"], 65);
  EXPECT_EQ(c["timer_time"], 1500);
  r = cli({"inverjet", "plan", "show", "2", "--json", "--unit", "12"});
  EXPECT_EQ(
      json::parse(r.output)["segments"],
      json::parse(R"([{"speed":35,"end":"02:00","end_s":120},{"speed":45,"end":"04:00","end_s":240}])"));
  EXPECT_EQ(status("12")["state"], 0);  // D-12: a restart is a power-on

  // Damaged: cut in half, as a failing disk leaves it. Still ours, so it is
  // replaced (a file that is not ours is refused: InverjetSimStateFile).
  const std::string saved = read_file(dir_ / "state.json");
  std::ofstream(dir_ / "state.json", std::ios::trunc) << saved.substr(0, saved.size() / 2);
  start();
  EXPECT_NE(sim_->output().find("is damaged"), std::string::npos) << sim_->output();
  EXPECT_EQ(status("21")["state"], 0);  // factory settings: unit 21
}

// ------------------------------------------------------------ peers we did not write

TEST_F(InverjetSim, PymodbusClient_TimerRun) {
  start("10");
  const RunResult r = run({"/usr/bin/python3", std::string(PEERS_DIR) + "/inverjet_pymodbus_run.py", tty_});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

TEST_F(InverjetSim, LibmodbusClient_TimerRun) {
  start("10");
  const RunResult r = run({INVERJET_LIBMODBUS_RUN_BIN, tty_});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

// ------------------------------------------------------------ the link: baud changes, the pty's path

// A baud-rate write (0x0001) is answered at the old rate, then the line
// changes. On a serial path (here a socat pty pair, as a USB adapter whose
// tcdrain returns before its FIFO is empty) the reconfiguration once
// flushed output too and threw the answer away: 6-8 answers in 20 lost.
TEST(InverjetSimLink, EveryBaudRateWriteIsAnswered_OnASerialPath) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  Process sim({kRtukit, "sim", "inverjet", "--listen", pair.a(), "--no-state", "--no-console"});
  ASSERT_TRUE(sim.wait_for_output("listening on")) << sim.output();
  // A pty carries any rate, so the master stays at 9600 while the simulator
  // switches between 19200 (code 4) and 9600 (code 3).
  Master m(io::make_link(*io::parse_port(pair.b(), false)),
           MasterOptions{.response_timeout = 1000ms, .retries = 0});
  int answered = 0;
  for (int i = 0; i < 200; ++i) {
    const Error e = m.write_single_register(UnitId{21}, 0x0001, i % 2 == 0 ? 4 : 3);
    if (e.ok()) ++answered;
  }
  EXPECT_EQ(answered, 200) << sim.output().substr(0, 2000);
  std::array<uint16_t, 1> baud{};
  ASSERT_TRUE(m.read_holding_registers(UnitId{21}, 0x0001, baud).ok());
  EXPECT_EQ(baud[0], 3);
}

// A second simulator on the same pty path never takes the first one's link:
// exit 2 and one line; the first stays reachable; once it is gone the path
// is free again, also when its owner was killed and left its link behind.
TEST(InverjetSimLink, ASecondSimulatorOnTheSamePathIsRefused_AStaleLinkIsReplaced) {
  TempDir dir;
  const std::string tty = dir / "tty";
  auto sim = [&](bool console = false) {
    std::vector<std::string> argv{kRtukit, "sim", "inverjet", "--listen", "pty:" + tty, "--no-state"};
    if (!console) argv.push_back("--no-console");
    return std::make_unique<Process>(argv);
  };
  auto reachable = [&] {
    return run_cli(kRtukit, {"read", "--unit", "21", "0", "1", "--timeout", "1000"}, tty).code == 0;
  };
  auto first = sim();
  ASSERT_TRUE(first->wait_for_output("listening on")) << first->output();
  ASSERT_TRUE(reachable());

  auto second = sim();
  EXPECT_EQ(second->wait(), 2) << second->output();
  const std::string said = second->output();
  EXPECT_NE(said.find(tty + " is in use by pid " + std::to_string(first->pid())), std::string::npos) << said;
  EXPECT_NE(said.find("rtukit sim inverjet"), std::string::npos) << said;
  EXPECT_EQ(std::count(said.begin(), said.end(), '\n'), 1) << said;
  EXPECT_TRUE(first->running());
  EXPECT_TRUE(reachable()) << "the second simulator took the link";

  first->stop();  // SIGTERM: it removes its link and its lock
  EXPECT_FALSE(path_exists(tty));
  auto third = sim();
  ASSERT_TRUE(third->wait_for_output("listening on")) << third->output();
  EXPECT_TRUE(reachable());

  ::kill(third->pid(), SIGKILL);  // no clean-up: the link stays, pointing at nothing
  EXPECT_EQ(third->wait(), 128 + SIGKILL);
  struct stat st {};
  EXPECT_EQ(::lstat(tty.c_str(), &st), 0);
  auto fourth = sim();
  ASSERT_TRUE(fourth->wait_for_output("listening on")) << fourth->output();
  EXPECT_TRUE(reachable());
}

// A link that is not ours but points at a live pty (a socat pair) is not
// taken either.
TEST(InverjetSimLink, ALinkToAnotherProgramsLivePtyIsNotTaken) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  const RunResult r =
      run({kRtukit, "sim", "inverjet", "--listen", "pty:" + pair.a(), "--no-state", "--no-console"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(pair.a() + " is in use: it points at /dev/pts/"), std::string::npos) << r.output;
  EXPECT_FALSE(path_exists(pair.a() + ".lock"));
  // socat's pair still works: our slave on one end, our master on the other
  Process slave({kRtukit, "slave", "--listen", pair.a(), "--unit", "1"});
  ASSERT_TRUE(slave.wait_for_output("listening on")) << slave.output();
  EXPECT_EQ(run_cli(kRtukit, {"read", "--unit", "1", "0", "1"}, pair.b()).code, 0);
}

}  // namespace
