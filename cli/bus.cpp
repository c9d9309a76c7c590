// `rtukit bus`: a virtual multi-drop RS-485 line on ptys, paced at its baud
// rate, with collisions and fault injection.
#include <fmt/core.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <functional>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/driver/virtual_bus.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/io/atomic_file.hpp"

namespace rtukit::cli {
namespace {

using Local = asio::local::stream_protocol;

// Offers the tap on a Unix socket to `rtukit sniff --bus NAME`: the header,
// then every character as a tap line, to every connected sniffer. The bus
// never waits for a listener: one that falls 1 MB behind is disconnected.
class TapServer {
 public:
  TapServer(asio::io_context& ctx, std::string path, std::function<std::string()> header)
      : acceptor_(ctx), path_(std::move(path)), header_(std::move(header)) {}
  ~TapServer() {
    if (listening_) ::unlink(path_.c_str());
  }

  /// Throws Failure when the socket cannot be made, or another bus has the name.
  void listen(const std::string& name) {
    const std::string dir = path_.substr(0, path_.rfind('/'));
    if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST)
      throw Failure{kIoError, fmt::format("--name {}: cannot make {}: {}", name, dir, std::strerror(errno))};
    struct stat st {};
    if (::lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != ::getuid())
      throw Failure{kIoError, fmt::format("--name {}: {} is not a directory of ours", name, dir)};
    if (::lstat(path_.c_str(), &st) == 0) {
      if (!S_ISSOCK(st.st_mode))
        throw Failure{kIoError, fmt::format("--name {}: {} exists and is not a socket", name, path_)};
      Local::socket probe(acceptor_.get_executor());
      boost::system::error_code ec;
      probe.connect(Local::endpoint(path_), ec);
      if (!ec)
        throw Failure{kUsage, fmt::format("--name {}: a bus of that name is running ({})", name, path_)};
      ::unlink(path_.c_str());  // left by a bus that was killed
    }
    boost::system::error_code ec;
    acceptor_.open(Local(), ec);
    if (!ec) acceptor_.bind(Local::endpoint(path_), ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) throw Failure{kIoError, fmt::format("--name {}: {}: {}", name, path_, ec.message())};
    listening_ = true;
    accept();
  }

  void publish(const std::string& line) {
    for (auto it = clients_.begin(); it != clients_.end();) {
      Client& c = **it;
      if (c.pending.size() + line.size() > kMaxBehind) {
        boost::system::error_code ignored;
        c.socket.close(ignored);
        it = clients_.erase(it);
        continue;
      }
      c.pending += line;
      flush(*it);
      ++it;
    }
  }

 private:
  static constexpr size_t kMaxBehind = 1 << 20;
  struct Client {
    explicit Client(Local::socket s) : socket(std::move(s)) {}
    Local::socket socket;
    std::string pending, in_flight;
    bool writing = false;
  };

  void accept() {
    acceptor_.async_accept([this](const boost::system::error_code& ec, Local::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) {
        auto c = std::make_shared<Client>(std::move(socket));
        c->pending = header_();
        clients_.push_back(c);
        flush(c);
      }
      accept();
    });
  }

  void flush(const std::shared_ptr<Client>& c) {
    if (c->writing || c->pending.empty() || !c->socket.is_open()) return;
    c->writing = true;
    c->in_flight.swap(c->pending);
    c->pending.clear();
    asio::async_write(c->socket, asio::buffer(c->in_flight),
                      [this, c](const boost::system::error_code& ec, size_t) {
                        c->writing = false;
                        c->in_flight.clear();
                        if (ec) {
                          boost::system::error_code ignored;
                          c->socket.close(ignored);
                          clients_.erase(std::remove(clients_.begin(), clients_.end(), c), clients_.end());
                          return;
                        }
                        flush(c);
                      });
  }

  Local::acceptor acceptor_;
  std::string path_;
  std::function<std::string()> header_;
  std::vector<std::shared_ptr<Client>> clients_;
  bool listening_ = false;
};

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
    std::fputs(tap_header(a.baud, o.line.bits_per_char, 0).c_str(), tap.get());
  }
  asio::io_context ctx;
  std::unique_ptr<TapServer> tap_server;
  const VirtualBus* started = nullptr;
  if (!a.name.empty())
    tap_server = std::make_unique<TapServer>(ctx, bus_tap_socket(a.name), [&] {
      return tap_header(a.baud, o.line.bits_per_char, started ? started->now_us() : 0);
    });
  if (tap || tap_server)
    o.tap = [&tap, &tap_server](const BusCharacter& c) {
      const std::string line = tap_line(c);
      if (tap) std::fputs(line.c_str(), tap.get());
      if (tap_server) tap_server->publish(line);
    };
  Outcome<std::unique_ptr<VirtualBus>> bus = VirtualBus::start(ctx, o);
  if (!bus.ok()) throw Failure{exit_code(bus.error().error()), std::string(bus.error().reason())};
  started = bus->get();
  if (tap_server) tap_server->listen(a.name);
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
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
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
