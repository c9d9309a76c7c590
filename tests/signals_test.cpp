// Servers end cleanly on SIGHUP (the terminal or session closed) and when
// their standard output is a pipe whose reader left (`rtukit slave -v |
// head`), instead of being killed: the loop returns, a pty's link is
// removed, the exit code is 0. Listeners reachable from the network say so;
// an IPv6 address is printed in a form that can be pasted back (issue 13,
// threads and signals).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <regex>

#include "process.hpp"

using namespace rtukit::test;
using namespace std::chrono_literals;

namespace {

const std::string kRtukit = RTUKIT_BIN;

struct Server {
  std::string name;
  std::vector<std::string> argv;
  std::string ready;  ///< printed once it serves
  std::string link;   ///< a pty link it must remove, or empty
};

// Every long-running command, each as a person starts it.
std::vector<Server> servers(TempDir& dir, const std::string& chair_tty) {
  const std::string tty = dir / "tty";
  return {
      {"slave", {kRtukit, "slave", "--listen", "pty:" + tty, "--unit", "1"}, "listening on", tty},
      {"sim inverjet",
       {kRtukit, "sim", "inverjet", "--listen", "pty:" + tty, "--state-file", dir / "jet.json",
        "--no-console"},
       "listening on",
       tty},
      {"sim rehand6600",
       {kRtukit, "sim", "rehand6600", "--listen", "pty:" + tty, "--no-console"},
       "listening on",
       tty},
      {"bus",
       {kRtukit, "bus", "--ports", "2", "--links", tty + "," + (dir / "tty2"), "--baud", "9600"},
       "listening on",
       tty},
      {"gateway",
       {kRtukit, "gateway", "--port", chair_tty, "--listen", "tcp://127.0.0.1:0"},
       "listening on",
       ""},
      {"rehand6600 host",
       {kRtukit, "rehand6600", "host", "--port", chair_tty, "--http", "127.0.0.1:0", "--pairing-file",
        dir / "pairing.json"},
       "rehand6600 host: display",
       ""},
      {"inverjet panel",
       {kRtukit, "inverjet", "panel", "--port", chair_tty, "--http", "127.0.0.1:0"},
       "http://",
       ""},
  };
}

TEST(Signals, SighupEndsEveryServerCleanly) {
  TempDir dir;
  Process chair({kRtukit, "sim", "rehand6600", "--listen", "pty:" + (dir / "chair"), "--no-console"});
  ASSERT_TRUE(chair.wait_for_output("listening on")) << chair.output();
  for (const Server& s : servers(dir, dir / "chair")) {
    Process p(s.argv);
    ASSERT_TRUE(p.wait_for_output(s.ready)) << s.name << ": " << p.output();
    if (!s.link.empty()) ASSERT_TRUE(path_exists(s.link)) << s.name;
    ASSERT_EQ(::kill(p.pid(), SIGHUP), 0);
    EXPECT_EQ(p.wait(5000ms), 0) << s.name << " after SIGHUP: " << p.output();
    if (!s.link.empty()) EXPECT_FALSE(path_exists(s.link)) << s.name << " left its pty link";
  }
}

// `rtukit slave -v | head -n 1`: head takes the "listening on" line and
// ends; the slave's next log line meets a pipe without a reader. It must
// stop as on Ctrl-C (exit 0, link removed), not die of SIGPIPE (141).
TEST(Signals, ABrokenStdoutPipeEndsAServerCleanly) {
  TempDir dir;
  const std::string tty = dir / "tty";
  const std::string jet_state = dir / "jet.json";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"slave", kRtukit + " slave --listen pty:" + tty + " --unit 21 -v"},
      {"sim inverjet",
       kRtukit + " sim inverjet --listen pty:" + tty + " --state-file " + jet_state + " --no-console -v"},
  };
  for (const auto& [name, command] : cases) {
    // pipefail: the pipeline's status is the server's when head's is 0.
    Process pipeline({"bash", "-o", "pipefail", "-c", command + " | head -n 1"});
    ASSERT_TRUE(eventually([&] { return !pipeline.output().empty(); })) << name;
    // The first line it prints after head has gone raises SIGPIPE: a second
    // line while starting (the simulator's banner), else the log line of a
    // request.
    bool ended = false;
    for (int i = 0; i < 50 && !ended; ++i) {
      if (path_exists(tty))
        run({kRtukit, "read", "--port", tty, "--unit", "21", "--timeout", "300", "0x21", "1"}, 3000ms);
      ended = !pipeline.running();
      if (!ended) std::this_thread::sleep_for(50ms);
    }
    ASSERT_TRUE(ended) << name << " still runs with nobody reading its output";
    EXPECT_EQ(pipeline.wait(1000ms), 0) << name << " was killed by the broken pipe: " << pipeline.output();
    EXPECT_FALSE(path_exists(tty)) << name << " left its pty link";
  }
  EXPECT_NE(read_file(jet_state).find("rtukit-state"), std::string::npos);  // its flash was saved
}

TEST(Signals, ListenersOnTheNetworkWarn_Ipv6PrintsAsItIsTyped) {
  TempDir dir;
  {
    Process p({kRtukit, "slave", "--listen", "tcp://0.0.0.0:0", "--unit", "1"});
    ASSERT_TRUE(p.wait_for_output("listening on")) << p.output();
    EXPECT_NE(p.output().find("warning: the slave listens on every network interface"), std::string::npos)
        << p.output();
  }
  {
    Process p({kRtukit, "slave", "--listen", "tcp://127.0.0.1:0", "--unit", "1"});
    ASSERT_TRUE(p.wait_for_output("listening on")) << p.output();
    EXPECT_EQ(p.output().find("warning"), std::string::npos) << p.output();
  }
  // IPv6: the address printed is one --port takes back.
  const int probe = ::socket(AF_INET6, SOCK_STREAM, 0);
  sockaddr_in6 a{};
  a.sin6_family = AF_INET6;
  a.sin6_addr = in6addr_loopback;
  const bool v6 = probe >= 0 && ::bind(probe, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  if (probe >= 0) ::close(probe);
  if (!v6) GTEST_SKIP() << "no IPv6 loopback on this machine";
  Process p({kRtukit, "slave", "--listen", "tcp://[::1]:0", "--unit", "1"});
  ASSERT_TRUE(p.wait_for_output("listening on")) << p.output();
  std::smatch m;
  const std::string out = p.output();
  ASSERT_TRUE(std::regex_search(out, m, std::regex(R"(listening on (tcp://\[::1\]:\d+))"))) << out;
  EXPECT_EQ(out.find("warning"), std::string::npos) << out;
  const RunResult r = run({kRtukit, "read", "--port", m[1].str(), "--unit", "1", "0", "1"});
  EXPECT_EQ(r.code, 0) << m[1].str() << ": " << r.output;
  // The gateway opens its bus before it listens: the slave above is its bus.
  Process exposed({kRtukit, "gateway", "--port", m[1].str(), "--listen", "tcp://[::]:0"});
  ASSERT_TRUE(exposed.wait_for_output("listening on")) << exposed.output();
  EXPECT_NE(exposed.output().find("warning: the gateway listens on every network interface (tcp://[::]:0)"),
            std::string::npos)
      << exposed.output();
  EXPECT_NE(exposed.output().find("listening on tcp://[::]:"), std::string::npos) << exposed.output();
}

}  // namespace
