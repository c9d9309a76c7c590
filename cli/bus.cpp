// `rtukit bus`: a virtual multi-drop RS-485 line on ptys, paced at its baud
// rate, with collisions and fault injection.
#include <fmt/core.h>

#include <asio.hpp>
#include <csignal>
#include <cstdio>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/driver/virtual_bus.hpp"

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
  uint64_t seed = 1;
  std::string tap;
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
  o.line.seed = a.seed;
  std::shared_ptr<std::FILE> tap;
  if (!a.tap.empty()) {
    tap.reset(std::fopen(a.tap.c_str(), "w"), [](std::FILE* f) {
      if (f) std::fclose(f);
    });
    if (!tap) throw Failure{kIoError, fmt::format("--tap {}: cannot write", a.tap)};
    std::fprintf(
        tap.get(),
        "# rtukit bus tap: start_us end_us sender(-1 stray) sent heard flags(c collision, d dropped)\n");
    o.tap = [tap](const BusCharacter& c) {
      std::fprintf(tap.get(), "%llu %llu %d %02X %02X%s%s%s\n", static_cast<unsigned long long>(c.start_us),
                   static_cast<unsigned long long>(c.end_us), c.sender, c.sent, c.heard,
                   c.collided || c.dropped ? " " : "", c.collided ? "c" : "", c.dropped ? "d" : "");
    };
  }
  asio::io_context ctx;
  Outcome<std::unique_ptr<VirtualBus>> bus = VirtualBus::start(ctx, o);
  if (!bus.ok()) throw Failure{exit_code(bus.error().error()), std::string(bus.error().reason())};
  fmt::print("bus: {} ports at {} baud, {} bits a character ({:.0f} us){}\n", a.ports, a.baud,
             o.line.bits_per_char, 1e6 * o.line.bits_per_char / a.baud, a.echo ? ", echo" : "");
  const std::vector<std::string> ports = (*bus)->ports();
  for (size_t i = 0; i < ports.size(); ++i) fmt::print("port {}: {}\n", i, ports[i]);
  fmt::print("listening on {}\n", ports.front());
  std::fflush(stdout);
  asio::signal_set signals(ctx, SIGINT, SIGTERM);
  signals.async_wait([&ctx](const std::error_code&, int) { ctx.stop(); });
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
        f->add_flag("--echo", a.echo, "a sender hears its own bytes (half-duplex adapters)");
        f->add_option("--seed", a.seed, "seed of the fault generator")->capture_default_str();
        cmd.add_option("--tap", a.tap, "write every character on the line, with its times, to this file");
        examples(cmd, {"rtukit bus --ports 3 --links /tmp/bus0,/tmp/bus1,/tmp/bus2 --baud 9600 &",
                       "rtukit sim inverjet --listen /tmp/bus0 & rtukit sim rehand6600 --listen /tmp/bus1 "
                       "--baud 9600 &",
                       "rtukit read --port /tmp/bus2 --unit 21 0x21 4",
                       "rtukit bus --ports 2 --links /tmp/a,/tmp/b --ber 1e-4 --latency-ms 16 --seed 7"});
      },
      [](const BusArgs& a) { return run_bus(a); });
}

}  // namespace rtukit::cli
