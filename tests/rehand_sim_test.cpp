// The simulated Rehand 6600 controller as the RK3588 host meets it: the
// `rtukit sim rehand6600` process on a pty, driven by the host controller
// library (in this process), by the rtukit CLI, by its console (stdin), and
// by peers we did not write. The host controller is also run against a
// generic libmodbus slave. Tests poll for conditions, never sleep for them.
#include <gtest/gtest.h>
#include <signal.h>

#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>

#include "process.hpp"
#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/port.hpp"

using namespace rtukit;
using namespace rtukit::test;
using namespace rtukit::rehand6600;
using namespace std::chrono_literals;
using nlohmann::json;

namespace {

const std::string kRtukit = RTUKIT_BIN;

// Events as the host delivered them, for polling from the test thread.
class Recorder {
 public:
  void operator()(const Event& e) {
    std::lock_guard lock(mutex_);
    events_.push_back(e);
  }
  size_t count(Event::Type t, uint16_t code = 0) const {
    std::lock_guard lock(mutex_);
    size_t n = 0;
    for (const Event& e : events_) n += e.type == t && (code == 0 || e.code == code || e.address == code);
    return n;
  }
  std::string reason(Event::Type t) const {
    std::lock_guard lock(mutex_);
    for (const Event& e : events_) {
      if (e.type == t) return e.reason;
    }
    return {};
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Event> events_;
};

std::unique_ptr<Host> make_host(const std::string& port, Recorder& rec) {
  auto spec = io::parse_port(port, false);
  spec->serial.baud = 115200;
  HostOptions o;
  o.response_timeout = 100ms;
  auto host = std::make_unique<Host>(io::make_link(*spec), o);
  host->on_event([&rec](const Event& e) { rec(e); });
  return host;
}

class RehandSim : public ::testing::Test {
 protected:
  void SetUp() override {
    sim_ = std::make_unique<Process>(
        std::vector<std::string>{kRtukit, "sim", "rehand6600", "--listen", "pty:" + tty_},
        /*stdin_pipe=*/true);
    ASSERT_TRUE(sim_->wait_for_output("listening on")) << sim_->output();
  }
  void console(const std::string& line) {
    const size_t before = sim_->output().size();
    ASSERT_TRUE(sim_->send(line + "\n"));
    // Wait for the reply so the next step sees the effect.
    ASSERT_TRUE(eventually([&] { return sim_->output().size() > before; })) << line;
  }
  /// The console's answer to `line`, read up to `last` (its last line's start).
  std::string ask(const std::string& line, const std::string& last) {
    const size_t before = sim_->output().size();
    if (!sim_->send(line + "\n")) return "console closed";
    std::string answer;
    eventually([&] {
      answer = sim_->output().substr(before);
      const size_t at = answer.find(last);
      return at != std::string::npos && answer.find('\n', at) != std::string::npos;
    });
    return answer;
  }
  RunResult cli(std::vector<std::string> args, bool with_port = true) {
    return run_cli(kRtukit, std::move(args), with_port ? tty_ : std::string());
  }

  TempDir dir_;
  std::string tty_ = dir_ / "tty";
  std::unique_ptr<Process> sim_;
};

// ------------------------------------------------------------ host controller

TEST_F(RehandSim, Host_HandshakeWritesBootCompleteAndPolls) {
  Recorder rec;
  auto host = make_host(tty_, rec);
  host->start();
  ASSERT_TRUE(host->wait_connected(3s)) << host->last_failure().reason();
  EXPECT_TRUE(eventually([&] { return rec.count(Event::Type::connected) == 1; }));
  const Snapshot s = host->snapshot();
  EXPECT_EQ(s[reg::kDeviceId], 0x68);
  EXPECT_EQ(s.battery(), 80u);
  EXPECT_TRUE(s.is_static());
  EXPECT_EQ(host->active_error(), 0);
  console("status");
  EXPECT_TRUE(sim_->wait_for_output("host_ready=1")) << sim_->output();
  // It keeps polling: ten more polls arrive (at 20 Hz, half a second; the
  // deadline is for a busy machine, not the rate).
  const uint64_t first = host->snapshot().sequence;
  EXPECT_TRUE(eventually([&] { return host->snapshot().sequence - first >= 10; }, 10s));
}

TEST_F(RehandSim, Host_WrongDeviceId_Raises1010UntilFixed) {
  console("id 0x69");
  Recorder rec;
  auto host = make_host(tty_, rec);
  host->start();
  ASSERT_TRUE(
      eventually([&] { return rec.count(Event::Type::error_raised, kMasterCommunicationError) == 1; }));
  EXPECT_NE(rec.reason(Event::Type::error_raised).find("device ID 0x69"), std::string::npos);
  EXPECT_EQ(host->active_error(), kMasterCommunicationError);
  Status why = host->hold(reg::kSeatLift, 1);
  EXPECT_EQ(why, Errc::refused);
  EXPECT_NE(why.reason().find("1010 Master Error"), std::string::npos) << why.reason();
  console("id 0x68");
  ASSERT_TRUE(host->wait_connected(3s));  // the handshake is retried every second
  EXPECT_TRUE(
      eventually([&] { return rec.count(Event::Type::error_cleared, kMasterCommunicationError) == 1; }));
  EXPECT_EQ(host->active_error(), 0);
}

TEST_F(RehandSim, Host_LinkCut_1010AfterThreeFailures_RecoversWhenBack) {
  Recorder rec;
  auto host = make_host(tty_, rec);
  host->start();
  ASSERT_TRUE(host->wait_connected(3s));
  ::kill(sim_->pid(), SIGSTOP);  // the controller stops answering
  ASSERT_TRUE(
      eventually([&] { return rec.count(Event::Type::error_raised, kMasterCommunicationError) == 1; }, 3s));
  EXPECT_NE(rec.reason(Event::Type::error_raised).find("3 consecutive polls failed"), std::string::npos)
      << rec.reason(Event::Type::error_raised);
  EXPECT_FALSE(host->connected());
  ::kill(sim_->pid(), SIGCONT);
  ASSERT_TRUE(eventually([&] { return host->connected(); }, 5s));
  // Events arrive on the host's thread just after the state changed.
  EXPECT_TRUE(
      eventually([&] { return rec.count(Event::Type::error_cleared, kMasterCommunicationError) == 1; }));
  EXPECT_TRUE(eventually([&] { return rec.count(Event::Type::connected) == 2; }));
}

TEST_F(RehandSim, Host_HornAndViewRisingEdges) {
  Recorder rec;
  auto host = make_host(tty_, rec);
  host->start();
  ASSERT_TRUE(host->wait_connected(3s));
  console("horn on");
  ASSERT_TRUE(eventually([&] { return rec.count(Event::Type::horn) == 1; }));
  ASSERT_TRUE(host->wait_poll(1s));
  EXPECT_EQ(rec.count(Event::Type::horn), 1u);  // held: no new edge
  console("horn off");
  ASSERT_TRUE(eventually([&] { return host->snapshot()[reg::kHornButton] == 0; }));
  console("horn on");
  ASSERT_TRUE(eventually([&] { return rec.count(Event::Type::horn) == 2; }));
  console("view on");
  ASSERT_TRUE(eventually([&] { return rec.count(Event::Type::view) == 1; }));
  EXPECT_GE(rec.count(Event::Type::changed, reg::kViewButton), 1u);
}

TEST_F(RehandSim, Host_LeaseExpiryReleasesAHold_RenewalKeepsIt) {
  Recorder rec;
  auto host = make_host(tty_, rec);
  host->start();
  ASSERT_TRUE(host->wait_connected(3s));
  // Renewed every 100 ms for a second: the seat keeps rising.
  for (int i = 0; i < 10; ++i) {
    ASSERT_FALSE(host->hold(reg::kSeatLift, 1));
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(rec.count(Event::Type::released), 0u);
  EXPECT_EQ(host->snapshot()[reg::kSeatLiftStatus], 1);
  // Not renewed: the library releases it after the 300-ms lease.
  ASSERT_TRUE(eventually([&] { return rec.count(Event::Type::released, reg::kSeatLift) == 1; }, 2s));
  ASSERT_TRUE(eventually([&] { return host->snapshot()[reg::kSeatLiftStatus] == 0; }));
  const uint16_t at = host->snapshot()[reg::kActuatorPosition];
  EXPECT_GE(at, 90);
  // Stopped: five more polls (fresh reads of the controller) see it where it was.
  const uint64_t polled = host->snapshot().sequence;
  ASSERT_TRUE(eventually([&] { return host->snapshot().sequence - polled >= 5; }, 10s));
  EXPECT_EQ(host->snapshot()[reg::kActuatorPosition], at);
}

TEST_F(RehandSim, Host_ErrorOverlayRefusesCommandsButReleasing) {
  Recorder rec;
  auto host = make_host(tty_, rec);
  host->start();
  ASSERT_TRUE(host->wait_connected(3s));
  console("error 10C3");
  ASSERT_TRUE(eventually([&] { return rec.count(Event::Type::error_raised, 0x10C3) == 1; }));
  EXPECT_EQ(rec.reason(Event::Type::error_raised), "10C3 Seat lift Error");
  EXPECT_EQ(host->active_error(), 0x10C3);
  Status why = host->hold(reg::kStandSit, 1);
  EXPECT_EQ(why, Errc::refused);
  EXPECT_NE(why.reason().find("10C3 Seat lift Error"), std::string::npos) << why.reason();
  EXPECT_EQ(host->pulse(reg::kLight), Errc::refused);
  EXPECT_EQ(host->set_speed_level(3), Errc::refused);
  EXPECT_FALSE(host->release(reg::kStandSit));
  EXPECT_FALSE(host->set_host_fault(0x0042));
  console("error clear");
  ASSERT_TRUE(eventually([&] { return rec.count(Event::Type::error_cleared, 0x10C3) == 1; }));
  EXPECT_FALSE(host->pulse(reg::kLight));
  ASSERT_TRUE(eventually([&] { return host->snapshot()[reg::kMainLight] == 1; }));
}

TEST_F(RehandSim, Host_UiRules_ChargingPushAndPhoneOnlyWhileStatic) {
  Recorder rec;
  auto host = make_host(tty_, rec);
  host->start();
  ASSERT_TRUE(host->wait_connected(3s));
  Status why;
  console("charger on");
  ASSERT_TRUE(eventually([&] { return host->snapshot().charging(); }));
  why = host->hold(reg::kPhoneForward, 1);
  EXPECT_EQ(why, Errc::refused);
  EXPECT_EQ(why.reason(), "no driving while charging");
  console("charger off");
  console("clutch push");
  ASSERT_TRUE(eventually([&] { return !host->snapshot().clutch_drive(); }));
  why = host->hold(reg::kPhoneForward, 1);
  EXPECT_EQ(why, Errc::refused);
  EXPECT_NE(why.reason().find("push"), std::string::npos);
  console("clutch drive");
  console("joystick 0 80");
  ASSERT_TRUE(eventually([&] { return !host->snapshot().is_static(); }));
  why = host->hold(reg::kPhoneForward, 1);
  EXPECT_EQ(why, Errc::refused);
  // The local side is not static: its joystick is deflected (the session names the first reason).
  EXPECT_EQ(why.reason(), "the joystick on the chair is in use");
  console("joystick 0 0");
  ASSERT_TRUE(eventually([&] { return host->snapshot().is_static(); }, 5s));
  EXPECT_FALSE(host->hold(reg::kPhoneForward, 1));
  ASSERT_TRUE(eventually([&] {
    (void)host->hold(reg::kPhoneForward, 1);  // the UI renews while the button is held
    return host->snapshot().motion() == 2;
  }));
  host->stop();  // releases every hold
  console("status");
  EXPECT_TRUE(sim_->wait_for_output("held commands: host_ready=1\n")) << sim_->output();
}

// ------------------------------------------------------------ CLI

TEST_F(RehandSim, Cli_StatusHoldPulseSetWatch) {
  RunResult r = cli({"rehand6600", "status", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  const json s = json::parse(r.output);
  EXPECT_EQ(s["device"], "rehand6600");
  EXPECT_EQ(s["unit"], 1);
  EXPECT_EQ(s["values"]["device_id"]["raw"], 0x68);
  EXPECT_EQ(s["values"]["motion"]["value"], "static");
  EXPECT_EQ(s["values"]["battery"]["unit"], "%");
  r = cli({"rehand6600", "hold", "seat_lift", "up", "--for", "1s"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("held seat_lift = up (1)"), std::string::npos) << r.output;
  // Released: the hold wrote 0 before it ended; the controller shows it at
  // its next cycle (a busy machine may delay that cycle, never the 0).
  json after;
  ASSERT_TRUE(eventually(
      [&] {
        after = json::parse(cli({"rehand6600", "status", "--json"}).output)["values"];
        return after["seat_lift_status"]["raw"] == 0;
      },
      10s))
      << after.dump();
  const int risen = after["actuator1_position"]["raw"].get<int>();
  EXPECT_GT(risen, 0);  // it rose (by how much depends on when the machine ran the press)
  const json later = json::parse(cli({"rehand6600", "status", "--json"}).output)["values"];
  EXPECT_EQ(later["actuator1_position"]["raw"].get<int>(), risen);  // and stays where it stopped
  // The release stopped it, not the controller's 500-ms watchdog (what a
  // hold that ended without its 0 would look like here): no trip.
  const std::string status = ask("status", "held commands:");
  EXPECT_NE(status.find(", 0 trip(s)"), std::string::npos) << status;
  r = cli({"rehand6600", "pulse", "light"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("main light on"), std::string::npos) << r.output;
  r = cli({"rehand6600", "set", "drive-mode", "outdoor", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(json::parse(r.output)["values"]["drive_mode"]["value"], "outdoor");
  EXPECT_EQ(json::parse(r.output)["action"], "set");
  EXPECT_EQ(cli({"rehand6600", "set", "speed-level", "4"}).code, 0);
  r = cli({"rehand6600", "watch", "--count", "2", "--interval", "100", "--mph"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 2) << r.output;
  EXPECT_NE(r.output.find("0.0 mph"), std::string::npos) << r.output;
  r = cli({"rehand6600", "errors"}, false);
  EXPECT_NE(r.output.find("| 10C1..10CB | Seat lift | 10C1 Seat lift Error | the seat-lift actuator"),
            std::string::npos)
      << r.output;
}

// The same live-view behaviour as every device: when the controller goes
// away the view says 1010 and since when it is stale, and keeps watching.
TEST_F(RehandSim, Watch_LinkLossIsStaleNotScrolling) {
  Process watch({kRtukit, "rehand6600", "watch", "--port", tty_, "--interval", "100", "--count", "80"});
  ASSERT_TRUE(watch.wait_for_output("battery")) << watch.output();
  sim_.reset();
  ASSERT_TRUE(watch.wait_for_output("stale since")) << watch.output();
  EXPECT_NE(watch.output().find("1010"), std::string::npos) << watch.output();
  EXPECT_TRUE(watch.running());
  watch.stop();
}

TEST_F(RehandSim, Cli_FailuresExitCodes) {
  struct Case {
    std::vector<std::string> args;
    int code;
    std::string says;
  };
  const std::vector<Case> usage = {
      {{"rehand6600", "hold", "fly"}, 2, "'fly' is not a hold command"},
      {{"rehand6600", "hold", "seat_lift", "7"}, 2, "hold seat_lift: '7' is not one of its directions"},
      {{"rehand6600", "hold", "seat_lift", "up", "--for", "0s"}, 2, "duration '0s'"},
      {{"rehand6600", "pulse", "stand"}, 2, "'stand' is not a pulse command"},
      {{"rehand6600", "set", "speed-level", "6"}, 2, "speed_level: 6 is outside 1..5"},
      {{"rehand6600", "set", "drive-mode", "fast"},
       2,
       "'fast' is not a drive_mode (normal, indoor, outdoor)"},
      {{"rehand6600", "set", "drive_mode", "fast"},
       2,
       "'fast' is not a drive_mode (normal, indoor, outdoor)"},
      {{"rehand6600", "status", "--unit", "9"}, 3, "1010 Master Error: handshake: no answer"},
  };
  for (const Case& c : usage) {
    const RunResult r = cli(c.args);
    EXPECT_EQ(r.code, c.code) << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  RunResult r = cli({"rehand6600", "status", "--port", dir_ / "nothing"}, false);
  EXPECT_EQ(r.code, 4) << r.output;
  console("error 10C3");
  r = cli({"rehand6600", "hold", "stand", "stand"});
  EXPECT_EQ(r.code, 5) << r.output;
  EXPECT_NE(r.output.find("10C3 Seat lift Error is active; only releasing is possible"), std::string::npos)
      << r.output;
  console("error clear");
  console("id 0x42");
  // `get` too (issue 38: it read a generic slave's registers as the chair's).
  for (const std::string cmd : {"status", "watch", "get"}) {
    r = cli({"rehand6600", cmd});
    EXPECT_EQ(r.code, 5) << r.output;
    EXPECT_NE(r.output.find("1010 Master Error: handshake: device ID 0x42, expected 0x68"), std::string::npos)
        << r.output;
  }
}

// Device errors carry advice (issue 28): 1010 and each table-3 code say what
// they mean and what to check, wherever they are printed: the failure line,
// a refusal, the status panel and its JSON, `errors CODE`.
TEST_F(RehandSim, DeviceErrorsSayWhatTheyMeanAndWhatToCheck) {
  RunResult r = cli({"rehand6600", "status", "--unit", "9"});
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("1010 Master Error: handshake: no answer (timeout); check that the controller is "
                          "powered on, the UART cable and its connectors, --baud (115200 unless changed) and "
                          "--unit (1)\n"),
            std::string::npos)
      << r.output;
  console("error 10C3");
  const std::string seat_lift =
      "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat "
      "above "
      "or below; actuator 1's cable and connector; whether the actuator states show over-current; when it "
      "clears, "
      "nothing restarts by itself: press the command again";
  r = cli({"rehand6600", "hold", "seat_lift", "up"});
  EXPECT_EQ(r.code, 5) << r.output;
  EXPECT_NE(r.output.find("seat_lift refused: 10C3 Seat lift Error is active; only releasing is possible: " +
                          seat_lift + "\n"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  r = cli({"rehand6600", "status"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("error     10C3 Seat lift Error\nadvice    the seat-lift actuator (actuator 1) or "
                          "its drive reports a fault;\n          check: nothing blocks"),
            std::string::npos)
      << r.output;
  std::string line;
  for (std::istringstream in(r.output); std::getline(in, line);) EXPECT_LE(line.size(), 80u) << line;
  r = cli({"rehand6600", "status", "--json"});
  EXPECT_EQ(json::parse(r.output)["values"]["error_advice"]["value"], seat_lift) << r.output;
  console("error clear");
  r = cli({"rehand6600", "errors", "10C3"}, false);
  EXPECT_EQ(r.output, "10C3 Seat lift Error: " + seat_lift + "\n");
  r = cli({"rehand6600", "errors", "1010"}, false);
  EXPECT_TRUE(
      r.output.starts_with("1010 Master Error: the host gets no valid answer from the controller "
                           "(communication); check: the controller is powered on, the UART cable"))
      << r.output;
  r = cli({"rehand6600", "errors", "--json"}, false);
  const json errors = json::parse(r.output)["errors"];
  EXPECT_EQ(errors.size(), error_codes().size());
  for (const json& e : errors)
    EXPECT_NE(e["advice"].get<std::string>().find("; check: "), std::string::npos) << e;
  console("id 0x42");
  r = cli({"rehand6600", "status"});
  EXPECT_EQ(r.code, 5) << r.output;
  EXPECT_NE(r.output.find("expected 0x68 (not a Rehand 6600 controller?); check --port and --unit: another "
                          "device answers there\n"),
            std::string::npos)
      << r.output;
}

// A hold names its direction (issue 28: `hold seat_lift` alone moved up,
// `hold stand` stood the user up). No direction, or one the command does not
// have, is refused before the port is even opened (exit 2, not 4 on a port
// that does not exist), naming the directions there are; a command with one
// value (phone_horn: on) needs none, and numbers the table lists still work.
TEST_F(RehandSim, Hold_NeedsADirection_NothingSent) {
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> refused = {
      {{"hold", "seat_lift"}, "hold seat_lift needs a direction: up (1) or down (2) (nothing sent)"},
      {{"hold", "stand"}, "hold stand needs a direction: stand (1) or sit (2) (nothing sent)"},
      {{"hold", "backrest", "up"},
       "hold backrest: 'up' is not one of its directions: forward (1) or back (2)"},
      {{"hold", "leg_extend", "out"},
       "hold leg_extend: 'out' is not one of its directions: extend (1) or "
       "retract (2)"},
      {{"hold", "seat_lift", "0"}, "hold seat_lift: '0' is not one of its directions: up (1) or down (2)"},
      {{"hold", "phone_horn", "loud"}, "hold phone_horn: 'loud' is not one of its directions: on (1)"},
  };
  for (const Case& c : refused) {
    std::vector<std::string> args{"rehand6600"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    args.insert(args.end(), {"--port", dir_ / "nothing"});
    const RunResult r = cli(args, false);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  RunResult r = cli({"rehand6600", "hold", "phone_horn", "--for", "200ms"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("held phone_horn = on (1)"), std::string::npos) << r.output;
  r = cli({"rehand6600", "hold", "seat_lift", "2", "--for", "200ms"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("held seat_lift = down (2)"), std::string::npos) << r.output;
}

// Ctrl-C during a hold releases the command and exits 130 (128 + SIGINT),
// not 0: a script learns the hold was cut short.
TEST_F(RehandSim, Hold_CtrlC_Releases_Exit130) {
  const auto held = [&] {
    console("status");
    const std::string out = sim_->output();
    const size_t at = out.rfind("held commands:");
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
  };
  Process hold({kRtukit, "rehand6600", "hold", "seat_lift", "up", "--for", "30s", "--port", tty_});
  ASSERT_TRUE(eventually([&] { return held().find("seat_lift=1") != std::string::npos; })) << sim_->output();
  ::kill(hold.pid(), SIGINT);
  EXPECT_EQ(hold.wait(), 130) << hold.output();
  EXPECT_NE(hold.output().find("held seat_lift = up (1) for "), std::string::npos) << hold.output();
  EXPECT_NE(hold.output().find(", released (interrupted)"), std::string::npos) << hold.output();
  EXPECT_TRUE(eventually([&] { return held().find("seat_lift") == std::string::npos; })) << sim_->output();
}

// On a terminal (a pty from `script`) a hold counts down; in a pipe it
// prints only its result.
TEST_F(RehandSim, Hold_CountsDownOnATerminal_NothingExtraInAPipe) {
  const RunResult piped = cli({"rehand6600", "hold", "seat_lift", "up", "--for", "500ms"});
  ASSERT_EQ(piped.code, 0) << piped.output;
  EXPECT_TRUE(piped.output.starts_with("held seat_lift = up (1) for ")) << piped.output;
  EXPECT_EQ(piped.output.find("left (Ctrl-C releases)"), std::string::npos) << piped.output;
  EXPECT_EQ(piped.output.find('\r'), std::string::npos) << piped.output;
  const RunResult tty = run(
      {"script", "-qec", kRtukit + " rehand6600 hold seat_lift down --for 1s --port " + tty_, "/dev/null"});
  ASSERT_EQ(tty.code, 0) << tty.output;
  EXPECT_NE(tty.output.find("holding seat_lift down (2): 0.9 s left (Ctrl-C releases)"), std::string::npos)
      << tty.output;
  EXPECT_NE(tty.output.find("held seat_lift = down (2) for "), std::string::npos) << tty.output;
}

// ------------------------------------------------------------ peers we did not write

TEST_F(RehandSim, PymodbusClient_ReadsTable1WritesTable2) {
  const RunResult r = run({"/usr/bin/python3", std::string(PEERS_DIR) + "/rehand_pymodbus.py", tty_});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

TEST_F(RehandSim, LibmodbusClient_ReadsTable1WritesTable2) {
  const RunResult r = run({REHAND_LIBMODBUS_BIN, tty_});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

TEST(RehandInterop, HostController_GenericLibmodbusSlaveWithId68) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  ::setenv("LIBMODBUS_SERVER_REG0", "0x68", 1);
  Process server({LIBMODBUS_SERVER_BIN, "rtu", pair.b(), "115200"});
  ::unsetenv("LIBMODBUS_SERVER_REG0");
  ASSERT_TRUE(server.wait_for_output("ready")) << server.output();
  Recorder rec;
  auto host = make_host(pair.a(), rec);
  host->start();
  ASSERT_TRUE(host->wait_connected(5s)) << host->last_failure().reason();
  const Snapshot s = host->snapshot();
  EXPECT_EQ(s[reg::kDeviceId], 0x68);
  EXPECT_EQ(s.battery(), 10u);  // the generic slave holds 10 x address
  // ... so 0x0026 holds 380: an error code table 3 does not list, shown as such.
  EXPECT_EQ(host->active_error(), 380);
  EXPECT_EQ(error_text(host->active_error()), "017C Unknown Error");
  EXPECT_TRUE(eventually([&] { return rec.count(Event::Type::error_raised, 380) == 1; }));
  host->stop();
}

}  // namespace
