// `rtukit bus`: a virtual multi-drop RS-485 line on ptys, paced at its baud
// rate, with collisions and fault injection.
#include <fmt/core.h>

#include <csignal>
#include <cstdio>
#include <functional>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/driver/virtual_bus.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/io/atomic_file.hpp"
#include "rtukit/term/tap_client.hpp"
#include "rtukit/term/tap_server.hpp"

namespace rtukit::cli {
namespace {

struct BusArgs {
  unsigned ports = 2;
  std::vector<std::string> links;
  uint32_t baud = 9600;
  std::string parity = "N";
  unsigned stop_bits = 1;
  double ber = 0, drop = 0, stray = 0, latency_ms = 0;
  bool echo = false;
  std::vector<unsigned> echo_ports;
  uint64_t seed = 1;
  std::string tap;
  bool overwrite = false;
  std::string name;
};

int run_bus(const BusArgs& a) {
  if (a.links.size() > a.ports)
    throw Failure{kUsage, fmt::format("{} links for {} ports (--ports N)", a.links.size(), a.ports)};
  VirtualBusOptions o;
  o.ports = a.ports;
  o.links = a.links;
  o.line.baud = a.baud;
  o.line.bits_per_char = 1 + 8 + (parity_letter(a.parity) == 'N' ? 0 : 1) + a.stop_bits;
  o.line.bit_error_rate = a.ber;
  o.line.drop_rate = a.drop;
  o.line.stray_rate = a.stray;
  o.line.latency_us = static_cast<uint32_t>(a.latency_ms * 1000);
  o.line.echo = a.echo;
  for (unsigned p : a.echo_ports) {
    if (p >= a.ports)
      throw Failure{kUsage, fmt::format("--echo-port {}: the bus has ports 0..{}", p, a.ports - 1)};
    o.line.echo_ports |= 1U << p;
  }
  o.line.seed = a.seed;
  std::shared_ptr<std::FILE> tap;
  if (!a.tap.empty()) {
    // An earlier tap is replaced; any other file only with --overwrite.
    Outcome<int> fd = io::create_output_file(a.tap, "# rtukit bus tap", a.overwrite);
    if (!fd.ok()) throw Failure{exit_code(fd.error().error()), fmt::format("--tap {}", fd.error().reason())};
    tap.reset(::fdopen(*fd, "w"), [](std::FILE* f) {
      if (f) std::fclose(f);
    });
    if (!tap) throw Failure{kIoError, fmt::format("--tap {}: cannot write", a.tap)};
    std::fputs(term::tap_header(a.baud, o.line.bits_per_char, 0).c_str(), tap.get());
  }
  asio::io_context ctx;
  // Armed before anything says it is ready: a SIGHUP or SIGTERM that comes
  // right after "listening on" ends the server cleanly too.
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
  std::unique_ptr<term::TapServer> tap_server;
  const VirtualBus* started = nullptr;
  if (!a.name.empty())
    tap_server = std::make_unique<term::TapServer>(ctx, bus_tap_socket(a.name), [&] {
      return term::tap_header(a.baud, o.line.bits_per_char, started ? started->now_us() : 0);
    });
  if (tap || tap_server)
    o.tap = [&tap, &tap_server](const BusCharacter& c) {
      const std::string line = term::tap_line(c);
      if (tap) std::fputs(line.c_str(), tap.get());
      if (tap_server) tap_server->publish(line);
    };
  Outcome<std::unique_ptr<VirtualBus>> bus = VirtualBus::start(ctx, o);
  if (!bus.ok()) throw Failure{exit_code(bus.error().error()), std::string(bus.error().reason())};
  started = bus->get();
  if (tap_server) {
    // "a bus of that name is running" is invalid_argument: a usage error (2), the rest I/O errors (4).
    if (const Status s = tap_server->listen(); !s.ok())
      throw Failure{exit_code(s.error()), fmt::format("--name {}: {}", a.name, s.reason())};
  }
  fmt::print("bus: {} ports at {} baud, {} bits a character ({:.0f} us){}\n", a.ports, a.baud,
             o.line.bits_per_char, 1e6 * o.line.bits_per_char / a.baud,
             a.echo                  ? ", echo"
             : !a.echo_ports.empty() ? ", echo on some ports"
                                     : "");
  const std::vector<std::string> ports = (*bus)->ports();
  for (size_t i = 0; i < ports.size(); ++i) fmt::print("port {}: {}\n", i, ports[i]);
  if (tap_server) fmt::print("tap: rtukit sniff --bus {} ({})\n", a.name, bus_tap_socket(a.name));
  fmt::print("listening on {}\n", ports.front());
  std::fflush(stdout);
  // A test engineer's switches, at run time: SIGUSR1 pulls the cable out
  // (nothing passes) and puts it back; SIGUSR2 stops the configured faults
  // (a clean line) and starts them again.
  asio::signal_set switches(ctx, SIGUSR1, SIGUSR2);
  struct {
    bool cut = false, quiet = false;
  } line_state;
  std::function<void()> await_switch = [&] {
    switches.async_wait([&](const boost::system::error_code& ec, int sig) {
      if (ec) return;
      if (sig == SIGUSR1) line_state.cut = !line_state.cut;
      if (sig == SIGUSR2) line_state.quiet = !line_state.quiet;
      BusConfig faults = line_state.quiet ? BusConfig{} : o.line;
      if (line_state.cut) faults.drop_rate = 1;
      (*bus)->set_faults(faults);
      fmt::print("bus: {}{}\n", line_state.cut ? "line cut: nothing passes" : "line connected",
                 line_state.quiet ? ", faults off" : "");
      std::fflush(stdout);
      await_switch();
    });
  };
  await_switch();
  ctx.run();
  const BusLineStats s = (*bus)->stats();
  fmt::print(stderr, "bus: {} characters, {} collided, {} with bit errors, {} dropped, {} stray\n",
             s.characters, s.collisions, s.bit_errors, s.dropped, s.stray);
  if (tap) std::fflush(tap.get());
  return kOk;
}

}  // namespace

void add_bus_command(CLI::App& app, Action& action) {
  add_command<BusArgs>(
      app, action, "bus", "a virtual RS-485 line on ptys: paced at its baud rate, collisions, faults",
      [](CLI::App& cmd, BusArgs& a) {
        cmd.add_option("--ports", a.ports, "how many ports (devices and masters on the line)")
            ->capture_default_str()
            ->check(CLI::Range(1, 32));
        cmd.add_option("--links", a.links, "symlinks to the ports, in order (comma-separated)")
            ->delimiter(',');
        cmd.add_option("--baud,-b", a.baud, "the line's rate")
            ->capture_default_str()
            ->check(CLI::Range(300, 4000000));
        cmd.add_option("--parity", a.parity, "none, even or odd (N, E, O)")->capture_default_str();
        cmd.add_option("--stop-bits", a.stop_bits, "1 or 2")->capture_default_str()->check(CLI::Range(1, 2));
        auto* f = cmd.add_option_group("Faults (seeded: the same --seed gives the same faults)");
        f->add_option("--ber", a.ber, "bit-error rate per data bit (1e-4)")->check(CLI::Range(0.0, 1.0));
        f->add_option("--drop", a.drop, "share of characters lost (framing errors)")
            ->check(CLI::Range(0.0, 1.0));
        f->add_option("--stray", a.stray, "chance of a stray byte after each transmission")
            ->check(CLI::Range(0.0, 1.0));
        f->add_option("--latency-ms", a.latency_ms, "deliver in ticks of this many ms (a USB adapter: 16)")
            ->check(CLI::Range(0.0, 1000.0));
        f->add_flag("--echo", a.echo, "every sender hears its own bytes (half-duplex adapters)");
        f->add_option("--echo-port", a.echo_ports,
                      "only this port hears its own bytes (a master's echoing adapter); repeatable");
        f->add_option("--seed", a.seed, "seed of the fault generator")->capture_default_str();
        cmd.add_option("--tap", a.tap, "write every character on the line, with its times, to this file");
        cmd.add_flag("--overwrite", a.overwrite, "replace a --tap file that is not a tap");
        cmd.add_option("--name", a.name, "offer the tap live to `rtukit sniff --bus NAME`");
        examples(cmd, {"rtukit bus --ports 3 --links /tmp/bus0,/tmp/bus1,/tmp/bus2 --baud 9600 &",
                       "rtukit sim inverjet --listen /tmp/bus0 & rtukit sim rehand6600 --listen /tmp/bus1 "
                       "--baud 9600 &",
                       "rtukit read --port /tmp/bus2 --unit 21 0x21 4",
                       "rtukit bus --ports 2 --links /tmp/a,/tmp/b --ber 1e-4 --latency-ms 16 --seed 7",
                       "rtukit bus --ports 2 --links /tmp/a,/tmp/b --name lab & rtukit sniff --bus lab",
                       "kill -USR1 %1   # cut the line (nothing passes); again: connected",
                       "kill -USR2 %1   # stop the faults (a clean line); again: faults back"});
      },
      [](const BusArgs& a) { return run_bus(a); });
}

}  // namespace rtukit::cli
