// rtukit vs libmodbus, served to the same load generator in one run.
//
// Servers: `rtukit slave` and tests/peers/libmodbus_server, each a separate
// process. Load generator: libmodbus clients (one thread per connection), so
// neither server is measured with its own client. Rows: FC03 reading 4 and
// 125 registers, over a socat pty pair and over TCP loopback with 1 and 16
// connections. Prints requests/s, p50 and p99 latency and the ratio
// ours/libmodbus (requests/s), and each server's CPU time per request
// (user + system, from /proc/PID/stat over the round).
// Usage: modbus_bench [--seconds S] [--rounds R] [--markdown] [--rtukit PATH]
//   --rtukit: the rtukit binary to serve (another build's, to compare two
//   versions of our server against the same libmodbus in one run).
#include <modbus/modbus.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../tests/process.hpp"

using namespace rtukit::test;
using Clock = std::chrono::steady_clock;

namespace {

struct Figures {
  double rps = 0;
  double p50_us = 0;
  double p99_us = 0;
  long errors = 0;
  double cpu_us = 0;  ///< the server's CPU time per request
};

// User + system CPU time of process `pid` so far, in seconds.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t close = text.rfind(')');  // the command name may hold spaces
  if (close == std::string::npos) return 0;
  std::istringstream fields(text.substr(close + 2));
  std::string f;
  unsigned long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && fields >> f; ++i) {
    if (i == 14) utime = std::stoul(f);
    if (i == 15) stime = std::stoul(f);
  }
  return double(utime + stime) / double(::sysconf(_SC_CLK_TCK));
}

struct Scenario {
  std::string transport;  // "pty" or "tcp"
  int connections = 1;
  int registers = 4;
};

// Runs `connections` libmodbus clients against `target` for `seconds`.
Figures load(const Scenario& s, const std::string& target, double seconds) {
  std::vector<std::vector<double>> lat(s.connections);
  std::atomic<long> errors{0};
  std::atomic<bool> go{false};
  std::vector<std::thread> threads;
  for (int c = 0; c < s.connections; ++c) {
    threads.emplace_back([&, c] {
      modbus_t* ctx = s.transport == "pty" ? modbus_new_rtu(target.c_str(), 115200, 'N', 8, 1)
                                           : modbus_new_tcp("127.0.0.1", std::stoi(target));
      modbus_set_slave(ctx, 1);
      modbus_set_response_timeout(ctx, 1, 0);
      if (modbus_connect(ctx) != 0) {
        ++errors;
        modbus_free(ctx);
        return;
      }
      uint16_t regs[125];
      // Warm up (and wait for the server to be ready).
      for (int i = 0; i < 200 && modbus_read_registers(ctx, 0, s.registers, regs) != s.registers; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      while (!go) std::this_thread::yield();
      const auto end = Clock::now() + std::chrono::duration<double>(seconds);
      lat[c].reserve(200000);
      while (Clock::now() < end) {
        const auto t0 = Clock::now();
        if (modbus_read_registers(ctx, 0, s.registers, regs) != s.registers) {
          ++errors;
          continue;
        }
        lat[c].push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
      }
      modbus_close(ctx);
      modbus_free(ctx);
    });
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  go = true;
  for (auto& t : threads) t.join();
  std::vector<double> all;
  for (auto& v : lat) all.insert(all.end(), v.begin(), v.end());
  Figures f;
  f.errors = errors;
  if (all.empty()) return f;
  std::sort(all.begin(), all.end());
  f.rps = static_cast<double>(all.size()) / seconds;
  f.p50_us = all[all.size() / 2];
  f.p99_us = all[std::min(all.size() - 1, all.size() * 99 / 100)];
  return f;
}

// A server process for one scenario: rtukit's or libmodbus's.
struct Server {
  std::unique_ptr<PtyPair> pair;
  std::unique_ptr<Process> process;
  std::string target;  // what the load generator opens
};

Server start(const std::string& which, const Scenario& s, const TempDir& dir, const std::string& rtukit,
             const std::string& libmodbus_server) {
  Server srv;
  std::string listen;
  if (s.transport == "pty") {
    srv.pair = std::make_unique<PtyPair>(dir);
    listen = srv.pair->a();
    srv.target = srv.pair->b();
  } else {
    listen = std::to_string(free_tcp_port());
    srv.target = listen;
  }
  std::vector<std::string> argv;
  if (which == "rtukit") {
    argv = {
        rtukit, "slave",  "--unit", "1",        "--registers",
        "200",  "--baud", "115200", "--listen", s.transport == "pty" ? listen : "tcp://127.0.0.1:" + listen};
    // Every client of the bench comes from 127.0.0.1: no per-address share.
    if (s.transport != "pty") argv.insert(argv.end(), {"--max-per-source", "0"});
  } else {
    argv = {libmodbus_server, s.transport == "pty" ? "rtu" : "tcp", listen};
    if (s.transport == "pty") argv.push_back("115200");
  }
  srv.process = std::make_unique<Process>(argv);
  const std::string ready = which == "rtukit" ? "listening" : "ready";
  if (!srv.process->wait_for_output(ready)) {
    std::fprintf(stderr, "bench: %s did not start: %s\n", which.c_str(), srv.process->output().c_str());
  }
  return srv;
}

// Both servers run side by side; rounds alternate between them so that
// drift in the machine's load hits both alike. Each figure is the median
// round (by requests/s).
std::pair<Figures, Figures> measure(const Scenario& s, double seconds, int rounds, const std::string& rtukit,
                                    const std::string& libmodbus_server) {
  TempDir dir_ours, dir_theirs;
  Server ours = start("rtukit", s, dir_ours, rtukit, libmodbus_server);
  Server theirs = start("libmodbus", s, dir_theirs, rtukit, libmodbus_server);
  std::vector<Figures> a, b;
  const double each = seconds / rounds;
  const auto measured = [&](Server& server) {
    const double cpu_before = cpu_seconds(server.process->pid());
    Figures f = load(s, server.target, each);
    const double requests = f.rps * each;
    if (requests > 0) f.cpu_us = (cpu_seconds(server.process->pid()) - cpu_before) * 1e6 / requests;
    return f;
  };
  for (int r = 0; r < rounds; ++r) {
    a.push_back(measured(ours));
    b.push_back(measured(theirs));
  }
  auto median = [](std::vector<Figures> v) {
    std::sort(v.begin(), v.end(), [](const Figures& x, const Figures& y) { return x.rps < y.rps; });
    Figures m = v[v.size() / 2];
    for (const auto& f : v) m.errors = std::max(m.errors, f.errors);
    return m;
  };
  return {median(a), median(b)};
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown cpu";
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 6.0;
  int rounds = 5;
  bool markdown = false;
  std::string rtukit = RTUKIT_BIN;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--seconds" && i + 1 < argc) seconds = std::stod(argv[++i]);
    if (std::string(argv[i]) == "--rounds" && i + 1 < argc) rounds = std::max(1, std::stoi(argv[++i]));
    if (std::string(argv[i]) == "--markdown") markdown = true;
    if (std::string(argv[i]) == "--rtukit" && i + 1 < argc) rtukit = argv[++i];
  }
  const std::string libmodbus_server = LIBMODBUS_SERVER_BIN;
  const std::vector<Scenario> scenarios = {
      {"pty", 1, 4},  {"pty", 1, 125},  {"tcp", 1, 4},  {"tcp", 1, 125},
      {"tcp", 16, 4}, {"tcp", 16, 125}, {"tcp", 64, 4},
  };
  char date[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%d", std::gmtime(&now));
  utsname u{};
  uname(&u);
  std::printf(
      "rtukit bench %s on %s, %u cores, %s %s; %.1f s per server and row in %d alternating rounds (median "
      "round shown); load generator: libmodbus %s\n\n",
      date, cpu_model().c_str(), std::thread::hardware_concurrency(), u.sysname, u.release, seconds, rounds,
      LIBMODBUS_VERSION_STRING);
  if (markdown) {
    std::printf(
        "| transport | conns | FC03 regs | rtukit req/s | p50 us | p99 us | CPU us/req | libmodbus req/s | "
        "p50 us | p99 us | CPU us/req | ratio |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  } else {
    std::printf("%-9s %5s %4s | %12s %8s %8s %7s | %12s %8s %8s %7s | %5s\n", "transport", "conns", "regs",
                "rtukit req/s", "p50 us", "p99 us", "cpu us", "libmb req/s", "p50 us", "p99 us", "cpu us",
                "ratio");
  }
  int below = 0;
  for (const auto& s : scenarios) {
    const auto [ours, theirs] = measure(s, seconds, rounds, rtukit, libmodbus_server);
    const double ratio = theirs.rps > 0 ? ours.rps / theirs.rps : 0;
    if (ratio < 1.0) ++below;
    const char* fmt =
        markdown ? "| %s | %d | %d | %.0f | %.0f | %.0f | %.1f | %.0f | %.0f | %.0f | %.1f | %.2f |\n"
                 : "%-9s %5d %4d | %12.0f %8.0f %8.0f %7.1f | %12.0f %8.0f %8.0f %7.1f | %5.2f\n";
    std::printf(fmt, s.transport.c_str(), s.connections, s.registers, ours.rps, ours.p50_us, ours.p99_us,
                ours.cpu_us, theirs.rps, theirs.p50_us, theirs.p99_us, theirs.cpu_us, ratio);
    if (ours.errors || theirs.errors)
      std::printf("  (errors: rtukit %ld, libmodbus %ld)\n", ours.errors, theirs.errors);
    std::fflush(stdout);
  }
  std::printf("\nrows with ratio below 1.0: %d\n", below);
  return 0;
}
