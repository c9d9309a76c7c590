// wire_bench: how close a master gets to the physical limit of a serial line.
//
// On the virtual bus (`rtukit bus`, paced at its baud rate), a simulator
// answers and a master polls as fast as it can for a while: ours, a
// libmodbus master and a pymodbus master, one after the other in the same
// run, on the same bus. The physical limit of one transaction is the
// request's and the answer's characters plus the two t3.5 silences the
// Modbus serial line rule requires (before the answer, before the next
// request); the figure is transactions/s as a fraction of 1 / that time.
//
// Second table: the gateway. A Rehand 6600 simulator on the bus at 115200
// baud, `rtukit gateway` owning the bus, and 1, 16 or 64 TCP clients (our
// Master, one thread each) polling the same read as fast as they can,
// without and with `--cache-ms`: requests served per second and the bus's
// own transactions, both as a fraction of the bus limit, with per-client
// latency.
//
// Third table: a dead unit beside a live one (issue 28, item 6). The same
// gateway; one client polls unit 1 (the simulator) as fast as it can, alone,
// then with a second client polling a unit nobody answers (every 100 ms,
// as a SCADA poller does), with the gateway's quarantine off
// (--quarantine-after 0) and on (its defaults): the live unit's served rate
// against its rate alone.
//
//   build/default/bench/wire_bench [--seconds S] [--dead-seconds S] [--markdown]
//                                  [--only wire|gateway|dead-unit]
#include <modbus/modbus.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "../tests/process.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/port.hpp"

using namespace rtukit;
using namespace rtukit::test;
using namespace std::chrono_literals;

namespace {

struct Workload {
  const char* name;
  const char* device;  // rtukit sim DEVICE
  uint8_t unit;
  uint16_t address, count;
};

struct Row {
  std::string workload;
  uint32_t baud;
  double limit, ours, libmodbus, pymodbus;
  unsigned ours_failed, libmodbus_failed, pymodbus_failed;  // transactions that failed (each costs a timeout)
};

using Clock = std::chrono::steady_clock;

double run_ours(const std::string& port, uint32_t baud, const Workload& w, double seconds, unsigned& failed) {
  io::PortSpec spec = *io::parse_port(port, false);
  spec.serial.baud = baud;
  Master m(io::make_link(spec), MasterOptions{.response_timeout = 1000ms});
  std::vector<uint16_t> regs(w.count);
  unsigned ok = 0;
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  const auto t0 = Clock::now();
  while (Clock::now() < until) {
    const Error e = m.read_holding_registers(UnitId{w.unit}, w.address, regs);
    if (e.ok()) {
      ++ok;
    } else {
      ++failed;
      std::fprintf(stderr, "ours: transaction %u failed: %s\n", ok + failed, std::string(e.name()).c_str());
    }
  }
  return ok / std::chrono::duration<double>(Clock::now() - t0).count();
}

double run_libmodbus(const std::string& port, uint32_t baud, const Workload& w, double seconds,
                     unsigned& failed) {
  modbus_t* ctx = modbus_new_rtu(port.c_str(), static_cast<int>(baud), 'N', 8, 1);
  if (!ctx) return 0;
  modbus_set_slave(ctx, w.unit);
  modbus_set_response_timeout(ctx, 1, 0);
  if (modbus_connect(ctx) != 0) {
    modbus_free(ctx);
    return 0;
  }
  std::vector<uint16_t> regs(w.count);
  unsigned ok = 0;
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  const auto t0 = Clock::now();
  while (Clock::now() < until)
    if (modbus_read_registers(ctx, w.address, w.count, regs.data()) == w.count)
      ++ok;
    else
      ++failed;
  const double rate = ok / std::chrono::duration<double>(Clock::now() - t0).count();
  modbus_close(ctx);
  modbus_free(ctx);
  return rate;
}

double run_pymodbus(const std::string& port, uint32_t baud, const Workload& w, double seconds,
                    unsigned& failed) {
  const std::string script =
      "import time\n"
      "from pymodbus.client import ModbusSerialClient\n"
      "c = ModbusSerialClient(port='" +
      port + "', baudrate=" + std::to_string(baud) +
      ", timeout=1)\n"
      "c.connect()\n"
      "ok = bad = 0\n"
      "t0 = time.monotonic()\n"
      "while time.monotonic() - t0 < " +
      std::to_string(seconds) +
      ":\n"
      "    r = c.read_holding_registers(" +
      std::to_string(w.address) + ", " + std::to_string(w.count) + ", slave=" + std::to_string(w.unit) +
      ")\n"
      "    if r.isError(): bad += 1\n"
      "    else: ok += 1\n"
      "print('rate', ok / (time.monotonic() - t0), 'failed', bad)\n";
  const RunResult r = run({"/usr/bin/python3", "-c", script},
                          std::chrono::milliseconds(static_cast<long>(seconds * 1000) + 20000));
  const size_t at = r.output.find("rate ");
  const size_t bad = r.output.find("failed ");
  if (bad != std::string::npos) failed = static_cast<unsigned>(std::stoul(r.output.substr(bad + 7)));
  return at == std::string::npos ? 0 : std::stod(r.output.substr(at + 5));
}

struct GatewayRow {
  unsigned clients;
  unsigned cache_ms;
  double limit, served, on_bus;  // per second
  double p50_ms, p99_ms;         // the median client's p50, the worst client's p99
  unsigned failed;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p / 100 * static_cast<double>(v.size())))];
}

std::string fmt_number(double a, double b, const char* format) {
  char text[64];
  std::snprintf(text, sizeof text, format, a, b);
  return text;
}

// A virtual bus with the Rehand 6600 simulator on its "dev" port; a gateway
// or a master takes the "host" port. What both gateway benches stand on.
struct RehandOnBus {
  explicit RehandOnBus(uint32_t baud)
      : bus({RTUKIT_BIN, "bus", "--ports", "2", "--links", (dir / "dev") + "," + (dir / "host"), "--baud",
             std::to_string(baud)}),
        sim_ok(bus.wait_for_output("listening on")) {
    if (sim_ok)
      sim = std::make_unique<Process>(std::vector<std::string>{RTUKIT_BIN, "sim", "rehand6600", "--listen",
                                                               dir / "dev", "--baud", std::to_string(baud),
                                                               "--no-state", "--no-console"});
  }
  bool ready() { return sim_ok && sim && sim->wait_for_output("listening on"); }
  TempDir dir;  // first: the bus and the simulator use it
  Process bus;
  bool sim_ok;
  std::unique_ptr<Process> sim;
};

GatewayRow run_gateway(unsigned clients, unsigned cache_ms, double seconds) {
  const std::string rtukit = RTUKIT_BIN;
  const uint32_t baud = 115200;
  const uint16_t count = 48;  // the Rehand 6600's table 1
  GatewayRow row{clients, cache_ms, 0, 0, 0, 0, 0, 0};
  row.limit = 1e6 / ((8 + 5 + 2.0 * count) * 10e6 / baud + 2 * RtuTiming::for_serial(baud, 10).t35_us);
  RehandOnBus rig(baud);
  if (!rig.ready()) return row;
  const TempDir& dir = rig.dir;
  const std::string where = "tcp://127.0.0.1:" + std::to_string(free_tcp_port());
  std::vector<std::string> argv{rtukit,
                                "gateway",
                                "--port",
                                dir / "host",
                                "--baud",
                                std::to_string(baud),
                                "--listen",
                                where,
                                "--timeout",
                                "1000",
                                "--max-connections",
                                "200",
                                "--max-per-source",
                                "0"};  // one address
  if (cache_ms) argv.insert(argv.end(), {"--cache-ms", std::to_string(cache_ms)});
  Process gateway(argv);
  if (!gateway.wait_for_output("listening on")) return row;

  std::vector<std::vector<double>> latencies(clients);
  std::atomic<unsigned> failed{0};
  std::vector<std::thread> threads;
  const auto t0 = Clock::now();
  const auto until = t0 + std::chrono::duration<double>(seconds);
  for (unsigned c = 0; c < clients; ++c)
    threads.emplace_back([&, c] {
      Master m(io::make_link(*io::parse_port(where, false)), MasterOptions{.response_timeout = 10000ms});
      std::vector<uint16_t> regs(count);
      while (Clock::now() < until) {
        const auto start = Clock::now();
        if (m.read_holding_registers(UnitId{1}, 0, regs).ok())
          latencies[c].push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        else
          ++failed;
      }
    });
  for (auto& t : threads) t.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  ::kill(gateway.pid(), SIGTERM);
  gateway.wait();
  // "gateway: N requests, M bus transactions, ..."
  const std::string out = gateway.output();
  const size_t at = out.rfind(" requests, ");
  const double on_bus = at == std::string::npos ? 0 : std::stod(out.substr(at + 11));
  size_t served = 0;
  std::vector<double> p50s, p99s;
  for (const auto& l : latencies) {
    served += l.size();
    p50s.push_back(percentile(l, 50));
    p99s.push_back(percentile(l, 99));
  }
  row.served = static_cast<double>(served) / elapsed;
  row.on_bus = on_bus / elapsed;
  row.p50_ms = percentile(p50s, 50);
  row.p99_ms = *std::max_element(p99s.begin(), p99s.end());
  row.failed = failed;
  return row;
}

struct DeadUnitRow {
  bool dead_poller;
  int quarantine_after;  // -1: the gateway's default
  double seconds;
  double live;         // unit 1's answers per second over the whole window
  double live_steady;  // ... from `steady_from` seconds on (0: not measured)
  double steady_from;
  unsigned dead_on_bus;   // the dead unit's requests that reached the bus ("unanswered (0B)")
  unsigned dead_at_once;  // ... answered 0B at once ("quarantined (0B at once)")
  unsigned live_failed;
};

// The number before `label` in the gateway's exit line ("..., 3 probes, ...").
unsigned count_before(const std::string& out, const std::string& label) {
  const size_t at = out.rfind(label);
  if (at == std::string::npos) return 0;
  size_t start = out.rfind(' ', at - 1);
  start = start == std::string::npos ? 0 : start + 1;
  return static_cast<unsigned>(std::stoul(out.substr(start, at - start)));
}

DeadUnitRow run_dead_unit(bool dead_poller, int quarantine_after, double seconds, double steady_from) {
  const std::string rtukit = RTUKIT_BIN;
  const uint32_t baud = 115200;
  const uint16_t count = 48;
  const uint8_t dead_unit = 99;  // nobody on the bus answers it
  DeadUnitRow row{dead_poller, quarantine_after, seconds, 0, 0, steady_from, 0, 0, 0};
  RehandOnBus rig(baud);
  if (!rig.ready()) return row;
  const TempDir& dir = rig.dir;
  const std::string where = "tcp://127.0.0.1:" + std::to_string(free_tcp_port());
  std::vector<std::string> argv{
      rtukit,     "gateway", "--port",    dir / "host", "--baud", std::to_string(baud),
      "--listen", where,     "--timeout", "1000"};
  if (quarantine_after >= 0)
    argv.insert(argv.end(), {"--quarantine-after", std::to_string(quarantine_after)});
  Process gateway(argv);
  if (!gateway.wait_for_output("listening on")) return row;

  std::vector<Clock::time_point> answered;  // unit 1's answers
  std::atomic<unsigned> failed{0};
  const auto t0 = Clock::now();
  const auto until = t0 + std::chrono::duration<double>(seconds);
  std::thread live([&] {
    Master m(io::make_link(*io::parse_port(where, false)), MasterOptions{.response_timeout = 10000ms});
    std::vector<uint16_t> regs(count);
    while (Clock::now() < until) {
      if (m.read_holding_registers(UnitId{1}, 0, regs).ok())
        answered.push_back(Clock::now());
      else
        ++failed;
    }
  });
  std::thread dead;
  if (dead_poller)
    dead = std::thread([&] {
      Master m(io::make_link(*io::parse_port(where, false)), MasterOptions{.response_timeout = 10000ms});
      std::vector<uint16_t> regs(count);
      while (Clock::now() < until) {
        (void)m.read_holding_registers(UnitId{dead_unit}, 0, regs);
        std::this_thread::sleep_for(100ms);
      }
    });
  live.join();
  if (dead.joinable()) dead.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  ::kill(gateway.pid(), SIGTERM);
  gateway.wait();
  const std::string out = gateway.output();
  row.dead_on_bus = count_before(out, " unanswered (0B)");
  row.dead_at_once = count_before(out, " quarantined (0B at once)");
  row.live = static_cast<double>(answered.size()) / elapsed;
  if (steady_from > 0 && elapsed > steady_from) {
    const auto from =
        t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(steady_from));
    const auto n =
        std::count_if(answered.begin(), answered.end(), [&](Clock::time_point t) { return t >= from; });
    row.live_steady = static_cast<double>(n) / (elapsed - steady_from);
  }
  row.live_failed = failed;
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 5;
  double dead_seconds = 90;
  bool markdown = false;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--seconds") && i + 1 < argc) seconds = std::stod(argv[++i]);
    if (!std::strcmp(argv[i], "--dead-seconds") && i + 1 < argc) dead_seconds = std::stod(argv[++i]);
    if (!std::strcmp(argv[i], "--markdown")) markdown = true;
    if (!std::strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
  }
  const std::string rtukit = RTUKIT_BIN;
  const Workload workloads[] = {{"Inverjet state registers (FC03 0x0021 x4)", "inverjet", 21, 0x21, 4},
                                {"Rehand 6600 table 1 (FC03 0x0000 x48)", "rehand6600", 1, 0, 48}};
  std::vector<Row> rows;
  // The Inverjet runs at 1200..19200 baud; the Rehand 6600's own rate is 115200.
  const std::pair<const Workload*, uint32_t> runs[] = {
      {&workloads[0], 9600}, {&workloads[1], 9600}, {&workloads[0], 19200}, {&workloads[1], 115200}};
  for (const auto& [wp, baud] : runs) {
    if (!only.empty() && only != "wire") break;
    const Workload& w = *wp;
    {
      TempDir dir;
      Process bus({rtukit, "bus", "--ports", "2", "--links", (dir / "dev") + "," + (dir / "host"), "--baud",
                   std::to_string(baud)});
      if (!bus.wait_for_output("listening on")) return 1;
      Process sim({rtukit, "sim", w.device, "--listen", dir / "dev", "--baud", std::to_string(baud),
                   "--no-state", "--no-console"});
      if (!sim.wait_for_output("listening on")) return 1;
      const double char_us = 10e6 / baud;
      const double t35 = RtuTiming::for_serial(baud, 10).t35_us;
      const double chars = 8 + 5 + 2.0 * w.count;
      const double limit = 1e6 / (chars * char_us + 2 * t35);
      Row r{w.name, baud, limit, 0, 0, 0, 0, 0, 0};
      r.ours = run_ours(dir / "host", baud, w, seconds, r.ours_failed);
      r.libmodbus = run_libmodbus(dir / "host", baud, w, seconds, r.libmodbus_failed);
      r.pymodbus = run_pymodbus(dir / "host", baud, w, seconds, r.pymodbus_failed);
      rows.push_back(r);
      std::fprintf(stderr, "%s at %u: limit %.1f/s, ours %.1f, libmodbus %.1f, pymodbus %.1f\n", w.name, baud,
                   limit, r.ours, r.libmodbus, r.pymodbus);
    }
  }
  if (only.empty() || only == "wire")
    std::printf(
        markdown
            ? "| workload | baud | limit tx/s | rtukit | libmodbus | pymodbus |\n|---|---|---|---|---|---|\n"
            : "%-44s %7s %10s %16s %16s %16s\n",
        "workload", "baud", "limit tx/s", "rtukit", "libmodbus", "pymodbus");
  // "33.6 (97.9 %)", with the failed transactions when there were any.
  const auto cell = [](double rate, double limit, unsigned failed) {
    char text[64];
    std::snprintf(text, sizeof text, failed ? "%.1f (%.1f %%, %u failed)" : "%.1f (%.1f %%)", rate,
                  100 * rate / limit, failed);
    return std::string(text);
  };
  for (const Row& r : rows)
    std::printf(markdown ? "| %s | %u | %.1f | %s | %s | %s |\n" : "%-44s %7u %10.1f %16s %16s %16s\n",
                r.workload.c_str(), r.baud, r.limit, cell(r.ours, r.limit, r.ours_failed).c_str(),
                cell(r.libmodbus, r.limit, r.libmodbus_failed).c_str(),
                cell(r.pymodbus, r.limit, r.pymodbus_failed).c_str());
  if (only == "wire") return 0;

  std::vector<GatewayRow> gateway_rows;
  for (const unsigned cache_ms : {0u, 100u}) {
    if (only == "dead-unit") break;
    for (const unsigned clients : {1u, 16u, 64u}) {
      gateway_rows.push_back(run_gateway(clients, cache_ms, seconds));
      const GatewayRow& g = gateway_rows.back();
      std::fprintf(stderr,
                   "gateway, %u clients, cache %u ms: %.1f/s served, %.1f/s on the bus (limit %.1f)\n",
                   g.clients, g.cache_ms, g.served, g.on_bus, g.limit);
    }
  }
  if (only != "dead-unit")
    std::printf(markdown ? "\n| clients | --cache-ms | served req/s | bus tx/s | p50 ms | p99 ms | failed "
                           "|\n|---|---|---|---|---|---|---|\n"
                         : "\n%7s %10s %22s %22s %8s %8s %6s\n",
                "clients", "--cache-ms", "served req/s", "bus tx/s", "p50 ms", "p99 ms", "failed");
  for (const GatewayRow& g : gateway_rows) {
    // Served: a share of the bus limit, or a multiple of it once coalescing serves more.
    const double share = g.served / g.limit;
    const std::string served = share < 2 ? fmt_number(g.served, 100 * share, "%.1f (%.1f %%)")
                                         : fmt_number(g.served, share, "%.0f (%.0fx the limit)");
    std::printf(markdown ? "| %u | %u | %s | %.1f (%.1f %%) | %.2f | %.2f | %u |\n"
                         : "%7u %10u %22s %12.1f (%5.1f %%) %8.2f %8.2f %6u\n",
                g.clients, g.cache_ms, served.c_str(), g.on_bus, 100 * g.on_bus / g.limit, g.p50_ms, g.p99_ms,
                g.failed);
  }
  if (only == "gateway") return 0;

  // The dead unit: the live unit alone, then beside a poller of a dead unit,
  // quarantine off and on. The quarantined row runs longer: its first
  // seconds hold the 3 timeouts that find the dead unit and the first,
  // closely spaced probes (1, 2, 4, 8, 16 s apart, then 30 s).
  std::vector<DeadUnitRow> dead_rows;
  dead_rows.push_back(run_dead_unit(false, -1, seconds, 0));
  dead_rows.push_back(run_dead_unit(true, 0, seconds, 0));
  dead_rows.push_back(run_dead_unit(true, -1, dead_seconds, std::min(30.0, dead_seconds / 2)));
  for (const DeadUnitRow& d : dead_rows)
    std::fprintf(stderr, "dead unit: poller %d, quarantine-after %d: live %.1f/s (steady %.1f/s)\n",
                 d.dead_poller, d.quarantine_after, d.live, d.live_steady);
  const double alone = dead_rows.front().live;
  std::printf(markdown ? "\n| dead-unit poller | gateway | window s | live unit served req/s | of alone | "
                         "dead unit: on the bus / 0B at once | live failed |\n|---|---|---|---|---|---|---|\n"
                       : "\n%-16s %-26s %8s %34s %8s %20s %12s\n",
              "dead-unit poller", "gateway", "window s", "live unit served req/s", "of alone",
              "dead: bus / at once", "live failed");
  for (const DeadUnitRow& d : dead_rows) {
    const std::string gw =
        d.quarantine_after == 0 ? "--quarantine-after 0" : "quarantine (defaults: 3, 1 s..30 s)";
    std::string served = fmt_number(d.live, 0, "%.1f");
    if (d.live_steady > 0)
      served += fmt_number(d.steady_from, d.live_steady, "; from %.0f s on: %.1f") +
                fmt_number(100 * d.live_steady / alone, 0, " (%.1f %%)");
    const std::string ratio = fmt_number(100 * d.live / alone, 0, "%.1f %%");
    const std::string dead = d.dead_poller
                                 ? std::to_string(d.dead_on_bus) + " / " + std::to_string(d.dead_at_once)
                                 : std::string("-");
    std::printf(
        markdown ? "| %s | %s | %.0f | %s | %s | %s | %u |\n" : "%-16s %-26s %8.0f %34s %8s %20s %12u\n",
        d.dead_poller ? "every 100 ms" : "none", d.dead_poller ? gw.c_str() : "defaults", d.seconds,
        served.c_str(), ratio.c_str(), dead.c_str(), d.live_failed);
  }
  return 0;
}
