// A register-map file device end to end: `rtukit map check`, `rtukit sim
// map` served to our CLI (read and watch by name), to pymodbus and to mbpoll
// as masters; the console on a Unix socket; and a simulator sent to the
// background of a real interactive shell on a pty, which must keep serving,
// never be stopped by the shell, and end on SIGTERM.
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "process.hpp"

using namespace rtukit::test;

namespace {

const std::string kBin = RTUKIT_BIN;
const std::string kMap = std::string(EXAMPLES_DIR) + "/maps/energy-meter.yaml";

struct MapSim {
  explicit MapSim(const TempDir& dir, std::vector<std::string> extra = {})
      : tty(dir / "tty"), process([&] {
          std::vector<std::string> argv = {kBin, "sim", "map", kMap, "--listen", "pty:" + tty, "--no-state"};
          argv.insert(argv.end(), extra.begin(), extra.end());
          return argv;
        }()) {
    started = process.wait_for_output("console");
  }
  std::string tty;
  Process process;
  bool started = false;
};

TEST(MapSim, CheckReportsTheMapAndItsErrors) {
  RunResult ok = run({kBin, "map", "check", kMap});
  EXPECT_EQ(ok.code, 0) << ok.output;
  EXPECT_NE(ok.output.find("ok: device 'energy_meter', 15 registers"), std::string::npos) << ok.output;

  TempDir dir;
  std::ofstream(dir / "bad.yaml") << "device:\n  name: x\nregisters:\n  - key: a\n    address: 1\n"
                                     "  - key: b\n    address: 1\n";
  RunResult bad = run({kBin, "map", "check", dir / "bad.yaml"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(
      bad.output.find("bad.yaml:6: register 'b' (0x0001): address 0x0001 is covered by another register"),
      std::string::npos)
      << bad.output;
  RunResult missing = run({kBin, "map", "check", dir / "none.yaml"});
  EXPECT_EQ(missing.code, 4) << missing.output;
}

// A built-in profile exported to the map format loads back as the same map:
// the JSON of the loaded file equals the JSON of the built-in table.
TEST(MapSim, BuiltInProfilesExportAndLoadBackIdentical) {
  TempDir dir;
  for (const std::string device : {"inverjet", "rehand6600"}) {
    RunResult yaml = run({kBin, device, "registers", "--yaml"});
    ASSERT_EQ(yaml.code, 0) << yaml.output;
    std::ofstream(dir / (device + ".yaml")) << yaml.output;
    RunResult check = run({kBin, "map", "check", dir / (device + ".yaml")});
    EXPECT_EQ(check.code, 0) << check.output;
    RunResult original = run({kBin, device, "registers", "--json"});
    RunResult loaded = run({kBin, "map", "registers", dir / (device + ".yaml"), "--json"});
    ASSERT_EQ(loaded.code, 0) << loaded.output;
    EXPECT_EQ(loaded.output, original.output) << device;
  }
}

TEST(MapSim, ReadAndWatchByName) {
  TempDir dir;
  MapSim sim(dir);
  ASSERT_TRUE(sim.started) << sim.process.output();
  RunResult r = run({kBin, "read", "--port", sim.tty, "--map", kMap, "voltage", "demand_period", "relay"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("voltage       = 230.0 V"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("demand_period = 15:00"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("relay         = off"), std::string::npos) << r.output;

  RunResult j = run({kBin, "read", "--port", sim.tty, "--map", kMap, "voltage", "baud", "--json"});
  ASSERT_EQ(j.code, 0) << j.output;
  const nlohmann::json doc = nlohmann::json::parse(j.output);
  EXPECT_EQ(doc["device"], "energy_meter");
  EXPECT_EQ(doc["values"]["voltage"]["value"], 230.0);
  EXPECT_EQ(doc["values"]["voltage"]["unit"], "V");
  EXPECT_EQ(doc["values"]["voltage"]["text"], "230.0 V");
  EXPECT_EQ(doc["values"]["baud"]["value"], "9600");

  RunResult unknown = run({kBin, "read", "--port", sim.tty, "--map", kMap, "volts"});
  EXPECT_EQ(unknown.code, 2);
  EXPECT_NE(unknown.output.find("no register 'volts' in energy_meter (registers: address, baud"),
            std::string::npos)
      << unknown.output;

  RunResult w =
      run({kBin, "map", "watch", "--port", sim.tty, "--map", kMap, "voltage", "--interval", "100", "--count", "2"});
  ASSERT_EQ(w.code, 0) << w.output;
  const size_t first = w.output.find("voltage = 230.0 V");
  ASSERT_NE(first, std::string::npos) << w.output;
  EXPECT_NE(w.output.find("voltage = 230.0 V", first + 1), std::string::npos) << w.output;
}

// Identification and diagnostics (issue 14): a map device and both built-in
// simulators say who they are; the Inverjet's board versions come from its
// input registers.
TEST(MapSim, IdentificationAndDiagnostics) {
  TempDir dir;
  MapSim sim(dir);
  ASSERT_TRUE(sim.started) << sim.process.output();
  RunResult r = run({kBin, "ident", "--port", sim.tty});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("vendor        example\nproduct code  EM-1\nrevision      1.0\n"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("product name  single-phase energy meter"), std::string::npos) << r.output;
  r = run({kBin, "diag", "--port", sim.tty, "echo"});
  EXPECT_EQ(r.code, 0) << r.output;

  Process jet({kBin, "sim", "inverjet", "--listen", "pty:" + (dir / "jet"), "--no-state", "--no-console"});
  ASSERT_TRUE(jet.wait_for_output("listening on")) << jet.output();
  r = run({kBin, "ident", "--port", dir / "jet", "--unit", "21", "--level", "extended", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json doc = nlohmann::json::parse(r.output);
  EXPECT_EQ(doc["objects"]["vendor"], "Inverjet");
  EXPECT_EQ(doc["objects"]["revision"], "V1.2");  // the display board's software (input 0x0000)
  EXPECT_EQ(doc["objects"]["0x82"], "V1.3");      // the driver board's software (input 0x0004)
  EXPECT_EQ(doc["conformity"], "extended");
}

TEST(MapSim, PymodbusMasterSeesTheMapsRules) {
  TempDir dir;
  MapSim sim(dir);
  ASSERT_TRUE(sim.started) << sim.process.output();
  RunResult r = run({"/usr/bin/python3", std::string(PEERS_DIR) + "/map_pymodbus.py", sim.tty});
  EXPECT_EQ(r.code, 0) << r.output << sim.process.output();
  EXPECT_NE(r.output.find("OK"), std::string::npos);
}

TEST(MapSim, MbpollMasterReadsAndWrites) {
  TempDir dir;
  MapSim sim(dir);
  ASSERT_TRUE(sim.started) << sim.process.output();
  const std::vector<std::string> rtu = {"mbpoll", "-m", "rtu",  "-a", "1", "-b",
                                        "9600",   "-P", "none", "-0", "-1"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> v = rtu;
    v.insert(v.end(), extra.begin(), extra.end());
    return v;
  };
  // Input register 0 (voltage), 0-based with -0.
  RunResult in = run(with({"-t", "3", "-r", "0", "-c", "1", sim.tty}));
  ASSERT_EQ(in.code, 0) << in.output;
  EXPECT_NE(in.output.find("[0]: \t2300"), std::string::npos) << in.output;
  RunResult w = run(with({"-t", "4", "-r", "3", sim.tty, "25"}));
  ASSERT_EQ(w.code, 0) << w.output;
  RunResult back = run({kBin, "read", "--port", sim.tty, "--map", kMap, "ct_ratio"});
  EXPECT_NE(back.output.find("ct_ratio = 25"), std::string::npos) << back.output;
  // Out of range: the simulator answers 03, mbpoll reports the failure.
  RunResult bad = run(with({"-t", "4", "-r", "3", sim.tty, "0"}));
  EXPECT_NE(bad.code, 0) << bad.output;
  EXPECT_NE(bad.output.find("Illegal data value"), std::string::npos) << bad.output;
}

TEST(MapSim, ConsoleOnAUnixSocket) {
  TempDir dir;
  const std::string sock = dir / "console.sock";
  MapSim sim(dir, {"--console", "unix:" + sock, "--no-console"});
  ASSERT_TRUE(sim.started) << sim.process.output();
  ASSERT_TRUE(eventually([&] { return path_exists(sock); }));
  RunResult r =
      run({"sh", "-c", "printf 'get voltage ct_ratio\\nhelp\\n' | socat -t 1 - UNIX-CONNECT:" + sock});
  EXPECT_NE(r.output.find("voltage = 230.0 V"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ct_ratio = 1"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("get KEY..."), std::string::npos) << r.output;
  sim.process.stop();
  EXPECT_FALSE(path_exists(sock)) << "the socket is removed at exit";
}

// A real interactive bash on a pty: `rtukit sim map ... &`, then commands in
// the same shell. Bash puts the job in the background process group; reading
// the terminal would stop it (SIGTTIN) and every request would time out.
class InteractiveShell {
 public:
  InteractiveShell() {
    pid_ = ::forkpty(&fd_, nullptr, nullptr, nullptr);
    if (pid_ == 0) {
      ::setenv("PS1", "$ ", 1);
      ::setenv("TERM", "dumb", 1);
      ::execlp("bash", "bash", "--norc", "--noprofile", "-i", static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  ~InteractiveShell() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (fd_ >= 0) ::close(fd_);
  }
  void type(const std::string& line) { (void)!::write(fd_, (line + "\n").data(), line.size() + 1); }
  /// Reads the terminal until `needle` appears after `from`; returns its offset or npos.
  size_t wait_for(const std::string& needle, size_t from = 0, std::chrono::milliseconds timeout = 10000ms) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      if (const size_t at = screen_.find(needle, from); at != std::string::npos) return at;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) > 0) {
        char buf[4096];
        const ssize_t n = ::read(fd_, buf, sizeof buf);
        if (n > 0) screen_.append(buf, static_cast<size_t>(n));
      }
    }
    return std::string::npos;
  }
  const std::string& screen() const { return screen_; }
  bool ok() const { return pid_ > 0 && fd_ >= 0; }

 private:
  pid_t pid_ = -1;
  int fd_ = -1;
  std::string screen_;
};

// `sim` is the simulator command without --listen; `read` a command line
// that reads from it with `TTY` for the port; `expect` what it prints.
void backgrounded_sim_keeps_serving(const std::string& sim, const std::string& read,
                                    const std::string& expect) {
  TempDir dir;
  const std::string tty = dir / "tty";
  const auto with_tty = [&](std::string line) {
    for (size_t at; (at = line.find("TTY")) != std::string::npos;) line.replace(at, 3, tty);
    return line;
  };
  InteractiveShell sh;
  ASSERT_TRUE(sh.ok());
  ASSERT_NE(sh.wait_for("$ "), std::string::npos) << sh.screen();
  sh.type(kBin + " " + sim + " --listen pty:" + tty + " > " + (dir / "sim.log") + " 2>&1 &");
  sh.type("echo sim\"pid=\"$!");  // the typed line (echoed) does not contain the marker
  const size_t at = sh.wait_for("simpid=");
  ASSERT_NE(at, std::string::npos) << sh.screen();
  const pid_t pid = static_cast<pid_t>(std::stol(sh.screen().substr(at + 7)));
  ASSERT_TRUE(eventually([&] { return read_file(dir / "sim.log").find("console") != std::string::npos; }))
      << read_file(dir / "sim.log");

  // Typing in the shell while the job runs: the simulator must not read it,
  // must not be stopped, and must keep answering.
  for (int i = 0; i < 2; ++i) {
    sh.type(kBin + " " + with_tty(read) + "; echo rc$((40+" + std::to_string(i) + "))=$?");
    const size_t rc = sh.wait_for("rc" + std::to_string(40 + i) + "=0", 0, 15000ms);
    EXPECT_NE(rc, std::string::npos) << sh.screen() << read_file(dir / "sim.log");
  }
  sh.type("jobs -l; echo jobs-done");
  ASSERT_NE(sh.wait_for("jobs-done\r\n"), std::string::npos);
  EXPECT_EQ(sh.screen().find("Stopped"), std::string::npos) << sh.screen();
  EXPECT_NE(sh.screen().find(expect), std::string::npos) << sh.screen();

  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  // Gone, or a zombie the shell has not reaped yet: either way it has ended.
  const auto ended = [&] {
    const std::string stat = read_file("/proc/" + std::to_string(pid) + "/stat");
    const size_t paren = stat.rfind(')');
    return stat.empty() || (paren != std::string::npos && stat.size() > paren + 2 && stat[paren + 2] == 'Z');
  };
  EXPECT_TRUE(eventually(ended, 5000ms)) << "SIGTERM must end the simulator";
  EXPECT_TRUE(eventually([&] { return !path_exists(tty); }, 2000ms)) << "the pty link is removed at exit";
}

TEST(MapSim, BackgroundedInAnInteractiveShellKeepsServingAndEndsOnSigterm) {
  backgrounded_sim_keeps_serving("sim map " + kMap + " --no-state",
                                 "read --port TTY --map " + kMap + " voltage", "voltage = 230.0 V");
}

TEST(MapSim, EveryBuiltInSimulatorToo) {
  backgrounded_sim_keeps_serving("sim inverjet --no-state", "inverjet get state --port TTY",
                                 "state = off (0)");
  backgrounded_sim_keeps_serving("sim rehand6600", "read --port TTY --baud 115200 --unit 1 0 1",
                                 "0 (0x0000): 104");
}

}  // namespace
