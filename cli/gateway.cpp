// `rtukit gateway`: the one process that owns a serial bus; Modbus TCP
// clients (watch windows, scripts, SCADA, the HMI) share it.
#include "rtukit/driver/gateway.hpp"

#include <fmt/core.h>

#include <algorithm>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/io/asio.hpp"

namespace rtukit::cli {
namespace {

struct GatewayArgs {
  LinkOptions link;
  std::vector<std::string> listen{"tcp://127.0.0.1:1502"};
  bool read_only = false;
  std::string allow_units;
  unsigned cache_ms = 0;
  unsigned max_queued = 32;
  unsigned quarantine_after = 3;
  unsigned probe_ms = 1000;
  unsigned probe_max_ms = 30000;
  ServerArgs server;
};

int run_gateway(const GatewayArgs& a) {
  std::vector<io::PortSpec> listen;
  for (const std::string& l : a.listen) {
    Result<io::PortSpec> spec = io::parse_port(l, true);
    if (!spec.ok() || !spec->is_tcp())
      throw Failure{kUsage,
                    fmt::format("--listen '{}': the gateway listens on tcp://HOST:PORT (Modbus TCP) or "
                                "rtu+tcp://HOST:PORT (RTU frames over TCP)",
                                l)};
    warn_if_exposed(*spec, "the gateway");
    listen.push_back(*spec);
  }
  GatewayOptions o;
  o.read_only = a.read_only;
  if (!a.allow_units.empty())
    for (unsigned u : parse_units(a.allow_units, kMaxSerialUnit))
      o.allowed_units.push_back(static_cast<uint8_t>(u));
  o.cache = std::chrono::milliseconds(a.cache_ms);
  o.max_queued_per_client = a.max_queued;
  if (a.probe_ms == 0) throw Failure{kUsage, "--probe-ms: the wait before a probe must be at least 1 ms"};
  o.quarantine_after = a.quarantine_after;
  o.probe_backoff = std::chrono::milliseconds(a.probe_ms);
  o.probe_backoff_max = std::chrono::milliseconds(std::max(a.probe_max_ms, a.probe_ms));
  o.notice = [](std::string_view line) { fmt::print(stderr, "gateway: {}\n", line); };
  o.on_quarantine = [](const GatewayUnitEvent& e) {
    if (e.quarantined)
      fmt::print(stderr,
                 "gateway: unit {} quarantined after {} requests without an answer: answered 0B at once, "
                 "tried again in {} ms\n",
                 e.unit, e.timeouts, e.next_probe.count());
    else
      fmt::print(stderr, "gateway: unit {} answers again: relayed\n", e.unit);
  };
  o.server = a.server.options();
  std::unique_ptr<Master> bus = a.link.make_master();
  asio::io_context ctx;
  // Armed before anything says it is ready: a SIGHUP or SIGTERM that comes
  // right after "listening on" ends the server cleanly too.
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
  Outcome<std::unique_ptr<Gateway>> gw = Gateway::start(ctx, *bus, listen, o);
  // A port that cannot be opened ends the gateway here, with one line and exit 4:
  // "rtukit: gateway: port /dev/ttyUSB9 9600 8N1: No such file or directory".
  if (!gw.ok()) throw Failure{exit_code(gw.error().error()), "gateway: " + std::string(gw.error().reason())};
  std::string where;
  for (const std::string& w : (*gw)->where()) where += (where.empty() ? "" : ", ") + w;
  fmt::print("gateway: {} shared on {}{}{}\n", bus->describe(), where, a.read_only ? " (read-only)" : "",
             a.cache_ms ? fmt::format(" (reads cached {} ms)", a.cache_ms) : std::string());
  fmt::print("listening on {}\n", (*gw)->where().front());
  std::fflush(stdout);
  ctx.run();
  const GatewayStats s = (*gw)->stats();
  gw->reset();
  std::string quarantined;
  for (const uint8_t u : s.quarantined_units)
    quarantined += (quarantined.empty() ? "" : ",") + std::to_string(u);
  fmt::print(
      stderr,
      "gateway: {} requests, {} bus transactions, {} from the cache, {} refused, {} unanswered (0B), {} "
      "with the bus down (0A), {} quarantined (0B at once), {} probes, units quarantined: {}\n",
      s.requests, s.bus_transactions, s.cache_hits, s.refused, s.no_answer, s.bus_down, s.quarantined_answers,
      s.probes, quarantined.empty() ? "none" : quarantined);
  if (a.link.stats) print_stats(*bus);
  return kOk;
}

}  // namespace

void add_gateway_command(CLI::App& app, Action& action) {
  add_command<GatewayArgs>(
      app, action, "gateway", "own a serial bus and share it with Modbus TCP clients",
      [](CLI::App& cmd, GatewayArgs& a) {
        cmd.add_option("--listen,-l", a.listen,
                       "where clients connect: tcp://HOST:PORT (Modbus TCP) or rtu+tcp://HOST:PORT (RTU "
                       "frames over TCP); repeatable; loopback unless told")
            ->capture_default_str();
        cmd.add_flag("--read-only", a.read_only,
                     "relay only requests that change nothing (FC01-04, FC08 echo/register/counters, "
                     "FC0B, FC0C, FC11, FC2B/0E); everything else gets exception 01");
        cmd.add_option(
            "--allow-units", a.allow_units,
            fmt::format("units relayed: 1,21 or 1-10 (default 1-{}); others get 0A", kMaxSerialUnit));
        cmd.add_option("--cache-ms", a.cache_ms,
                       "identical reads within this many ms share one bus transaction")
            ->capture_default_str();
        cmd.add_option("--max-queued", a.max_queued, "requests one client may have waiting (more get 06)")
            ->capture_default_str();
        cmd.add_option("--quarantine-after", a.quarantine_after,
                       "a unit that leaves this many requests in a row unanswered is quarantined: its "
                       "requests get 0B at once, without the bus (0 = never)")
            ->capture_default_str();
        cmd.add_option("--probe-ms", a.probe_ms,
                       "a quarantined unit's next request goes to the bus as a probe after this many ms; "
                       "doubled after each unanswered probe")
            ->capture_default_str();
        cmd.add_option("--probe-max-ms", a.probe_max_ms,
                       "the longest wait between two probes of a unit (at least --probe-ms)")
            ->capture_default_str();
        a.link.add_to(cmd, false);
        a.server.add_to(cmd, /*serial=*/false);  // its listeners are TCP
        examples(
            cmd,
            {"rtukit gateway --port /dev/ttyUSB0 --baud 9600 --listen tcp://127.0.0.1:1502",
             "rtukit inverjet watch --port tcp://127.0.0.1:1502      (as many as you like)",
             "rtukit gateway --port /dev/ttyS3 --baud 115200 --read-only --allow-units 1 --cache-ms 200"});
      },
      [](const GatewayArgs& a) { return run_gateway(a); });
}

}  // namespace rtukit::cli
