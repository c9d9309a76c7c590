// `rtukit sim inverjet`: the simulated machine on a pty, serial port or TCP,
// with a console on stdin. The simulator itself is a library class
// (devices/inverjet/simulator.hpp); this file wires options, stdin and signals.
#include <fmt/core.h>
#include <poll.h>
#include <unistd.h>

#include <asio.hpp>
#include <cstdio>
#include <thread>

#include "commands.hpp"
#include "common.hpp"
#include "console.hpp"
#include "rtukit/devices/rehand6600/simulator.hpp"

namespace rtukit::cli {
namespace {

RequestLog request_logger() {
  return [](std::span<const uint8_t> rx, std::span<const uint8_t> tx) {
    fmt::print("rx {} -> {}\n", hex(rx), tx.empty() ? std::string("(silence)") : "tx " + hex(tx));
    std::fflush(stdout);
  };
}

// Runs a simulator until SIGINT/SIGTERM or `quit` on its console.
template <class Sim>
int serve(asio::io_context& ctx, Sim& s, bool with_console) {
  if (with_console) fmt::print("console: type 'help' for commands\n");
  std::fflush(stdout);
  ignore_tty_stops();
  asio::signal_set signals(ctx, SIGINT, SIGTERM, SIGHUP);
  signals.async_wait([&ctx](const std::error_code&, int) { ctx.stop(); });
  std::unique_ptr<StdinConsole> console;
  if (with_console) {
    console = std::make_unique<StdinConsole>(
        ctx, [&s, &ctx](const std::string& line, const std::function<void(std::string)>& reply) {
          const std::string text = s.command(line);
          if (!text.empty()) reply(text.back() == '\n' ? text : text + "\n");
          if (s.quit_requested()) ctx.stop();
        });
  }
  ctx.run();
  console.reset();
  return kOk;
}

struct SimArgs {
  std::string listen;
  std::string unit;
  std::string baud;
  std::string parity = "N";
  unsigned stop_bits = 1;
  bool rs485 = false;
  std::string state_file;
  bool no_state = false;
  double time_scale = 1.0;
  bool verbose = false;
  bool no_console = false;
};

struct ChairSimArgs {
  std::string listen;
  std::string unit = "1";
  uint32_t baud = rehand6600::kDefaultBaud;
  uint32_t watchdog_ms = 500;
  double time_scale = 1.0;
  bool verbose = false;
  bool no_console = false;
};

int run_sim_rehand6600(const ChairSimArgs& a) {
  std::string why;
  Result<io::PortSpec> spec = io::parse_port(a.listen, true, &why);
  if (!spec.ok()) throw Failure{kUsage, fmt::format("bad --listen '{}': {}", a.listen, why)};
  spec->serial.baud = a.baud;
  if (Error e = spec->serial.validate(&why)) throw Failure{kUsage, why};
  rehand6600::SimulatorOptions o;
  o.listen = *spec;
  o.unit = static_cast<uint8_t>(parse_number(a.unit, "unit", 1, 247));
  o.watchdog_ms = a.watchdog_ms;
  o.time_scale = a.time_scale;
  if (a.verbose) o.log = request_logger();
  asio::io_context ctx;
  auto sim = rehand6600::Simulator::start(ctx, o, &why);
  if (!sim.ok()) {
    throw Failure{sim.error() == Errc::invalid_argument ? kUsage : kIoError,
                  why.empty() ? std::string(sim.error().name()) : why};
  }
  rehand6600::Simulator& s = **sim;
  fmt::print("Rehand 6600 simulator: unit {}, {} baud, watchdog {} ms, time x{:g}\nlistening on {}\n", o.unit,
             a.baud, a.watchdog_ms, a.time_scale, s.where());
  return serve(ctx, s, !a.no_console);
}

}  // namespace

// Until the devices move onto the simulator host (profile kit merge).
void add_legacy_sim_commands(CLI::App& app, Action& action) {
  CLI::App* sim = app.get_subcommand("sim");
  auto c = std::make_shared<ChairSimArgs>();
  CLI::App* chair =
      sim->add_subcommand("rehand6600", "the Rehand 6600 wheelchair controller, with a console on stdin");
  chair
      ->add_option("--listen,-l", c->listen,
                   "pty | pty:/path/link | /dev/ttyX | tcp://HOST:PORT | rtu+tcp://HOST:PORT")
      ->required();
  chair->add_option("--unit,-u", c->unit, "slave address")->capture_default_str();
  chair->add_option("--baud,-b", c->baud, "baud rate of a serial port (D-1: 115200)")->capture_default_str();
  chair->add_option("--watchdog-ms", c->watchdog_ms, "communication watchdog (D-5); 0 disables")
      ->capture_default_str();
  chair->add_option("--time-scale", c->time_scale, "device seconds per real second")->capture_default_str();
  chair->add_flag("--verbose,-v", c->verbose, "log every request and response in hex");
  chair->add_flag("--no-console", c->no_console, "do not read commands from stdin");
  chair->callback([&action, c] { action = [c] { return run_sim_rehand6600(*c); }; });
}

}  // namespace rtukit::cli
