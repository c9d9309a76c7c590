// `rtukit relay`: a man in the middle of an RTU line (driver/fault_relay.hpp):
// the master opens the relay's pty, the relay opens the device's port and
// passes frames across but those its rules drop, corrupt or delay. Rules come
// from --fault and the console (stdin, a Unix socket) and change while it
// runs; every frame a rule touched is printed (-v: every frame).
#include <fmt/core.h>

#include <cstdio>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/driver/fault_relay.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/term/line_console.hpp"
#include "rtukit/term/stdin_console.hpp"

namespace rtukit::cli {
namespace {

struct RelayArgs {
  LinkOptions link;  ///< only --port and --baud: the relay is no master
  std::string listen, console;
  std::vector<std::string> faults;
  bool no_console = false, verbose = false, rehand_quirk = false;
};

int run_relay(const RelayArgs& a) {
  if (!a.listen.starts_with("pty"))
    throw Failure{kUsage, "--listen takes pty or pty:PATH (what the master opens)"};
  const io::PortSpec device = a.link.spec(/*listening=*/false);
  if (device.kind != io::PortSpec::Kind::serial)
    throw Failure{kUsage,
                  fmt::format("--port {}: the relay opens a serial port or a pty's path", a.link.port)};
  FaultRelayOptions o{
      .device = device.path, .serial = device.serial, .link = a.listen.substr(a.listen.size() > 4 ? 4 : 3)};
  o.quirks.fc03_two_byte_count = a.rehand_quirk;
  if (!a.console.empty() && (!a.console.starts_with("unix:") || a.console.size() <= 5))
    throw Failure{kUsage, fmt::format("--console takes unix:PATH, not '{}'", a.console)};
  for (const std::string& f : a.faults)
    if (Outcome<FaultRule> r = parse_fault_rule(f); !r.ok())
      throw Failure{kUsage, fmt::format("--fault '{}': {}", f, r.error().reason())};

  asio::io_context ctx;
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
  const bool verbose = a.verbose;
  Outcome<std::unique_ptr<FaultRelay>> relay =
      FaultRelay::start(ctx, o, [verbose](const FaultRelay::Record& r) {
        if (!verbose && r.kind == FaultPlan::Decision::Kind::pass) return;
        fmt::print("{}\n", FaultRelay::line_of(r));
        std::fflush(stdout);
      });
  if (!relay.ok()) throw Failure{exit_code(relay.error().error()), std::string(relay.error().reason())};
  for (const std::string& f : a.faults) (void)(*relay)->command(f);
  const term::ConsoleHandler on_line = [&relay](const std::string& line, const term::ConsoleReply& reply) {
    if (!line.empty()) reply((*relay)->command(line));
  };
  std::unique_ptr<term::LineConsole> socket_console;
  if (!a.console.empty()) {
    auto c = term::LineConsole::open(ctx, a.console.substr(5), on_line);
    if (!c.ok())
      throw Failure{c.error().code() == Errc::invalid_argument ? kUsage : kIoError,
                    std::string(c.error().reason())};
    socket_console = std::move(*c);
    fmt::print("console on {}\n", a.console);
  }
  fmt::print("relay: {} <-> {}\nlistening on {}\n", (*relay)->port(), o.device, (*relay)->port());
  std::fflush(stdout);
  std::unique_ptr<term::StdinConsole> console;
  if (!a.no_console) console = std::make_unique<term::StdinConsole>(ctx, on_line);
  ctx.run();
  return kOk;
}

}  // namespace

void add_relay_command(CLI::App& app, Action& action) {
  add_command<RelayArgs>(
      app, action, "relay", "a man in the middle of an RTU line: drop, corrupt or delay chosen frames",
      [](CLI::App& cmd, RelayArgs& a) {
        cmd.add_option("--port,-p", a.link.port, "the device's port (a serial port or a simulator's pty)")
            ->required();
        cmd.add_option("--baud,-b", a.link.baud, "its rate (a pty ignores it)")->capture_default_str();
        cmd.add_option("--listen", a.listen, "pty or pty:PATH: the port the master opens")->required();
        cmd.add_option("--fault", a.faults, "a rule from the start (repeatable; the console takes more)");
        cmd.add_option("--console", a.console, "also take console commands on unix:PATH");
        cmd.add_flag("--no-console", a.no_console, "do not read console commands from stdin");
        cmd.add_flag("--fc03-two-byte-count", a.rehand_quirk, "the Rehand 6600's FC03 reply form (D-2)");
        cmd.add_flag("-v,--verbose", a.verbose, "print every frame, not only those a rule touched");
        cmd.footer(std::string(fault_rule_help()));
        examples(
            cmd,
            {"rtukit sim rehand6600 --listen pty:/tmp/ttyChair &",
             "rtukit relay --port /tmp/ttyChair --listen pty:/tmp/ttyHost --console unix:/tmp/relay.sock &",
             "echo 'drop request fc06 0x0063=0' | socat - UNIX-CONNECT:/tmp/relay.sock"});
      },
      [](const RelayArgs& a) { return run_relay(a); });
}

}  // namespace rtukit::cli
