// `rtukit sim <device>` and `rtukit sim map FILE`: any device profile served
// by the one simulator host (devices/profile/sim_host.hpp). This file wires
// options, the console (stdin and a Unix socket) and signals.
//
// The console never freezes the simulator: stdin is read when it is a pipe,
// a FIFO or a file, and a terminal only while the simulator is in the
// terminal's foreground process group. A simulator sent to the background
// of an interactive shell (`rtukit sim inverjet ... &`) keeps serving, is
// never stopped by the shell (SIGTTIN/SIGTTOU are ignored and the terminal
// is not read), and ends on SIGTERM. `--console unix:PATH` drives it from
// elsewhere (`socat - UNIX-CONNECT:PATH`).
#include <fmt/core.h>

#include <cstdio>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/devices/profile/map_file.hpp"
#include "rtukit/devices/profile/state_file.hpp"
#include "rtukit/devices/registry.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/term/line_console.hpp"
#include "rtukit/term/stdin_console.hpp"

namespace rtukit::cli {
namespace {

struct SimArgs {
  LinkOptions link;
  std::string unit;
  bool baud_given = false;
  std::string state_file;
  bool no_state = false;
  bool force_state = false;
  double time_scale = 1.0;
  bool verbose = false;
  bool no_console = false;
  std::string console;
  std::string map_file;
  ServerArgs server;
  profile::SimSettings settings;  ///< the device's own options (DeviceEntry::sim_options)
};

void add_sim_options(CLI::App& cmd, SimArgs& a, const profile::Profile* profile) {
  a.link.add_to(cmd, /*listening=*/true, profile ? profile::link_defaults(*profile).baud : 9600);
  a.server.add_to(cmd);
  cmd.add_option("--unit,-u", a.unit, "unit address (default: the device's own)");
  cmd.add_option("--state-file", a.state_file,
                 "where persisted registers live (default: ~/.local/state/rtukit/DEVICE.json)");
  cmd.add_flag("--no-state", a.no_state, "keep persisted registers in memory only");
  cmd.add_flag("--force-state", a.force_state,
               "replace a --state-file that is not this device's state file (refused without it)");
  cmd.add_option("--time-scale", a.time_scale, "device seconds per real second (60: a minute per second)")
      ->capture_default_str();
  cmd.add_flag("-v,--verbose", a.verbose, "log each request and response in hex");
  cmd.add_flag("--no-console", a.no_console, "do not read console commands from stdin");
  cmd.add_option("--console", a.console, "also take console commands on unix:PATH");
}

int run_sim(const SimArgs& a, profile::SimDevice device) {
  const profile::Profile& profile = device.model->profile();
  profile::SimOptions o;
  o.listen = a.link.spec(/*listening=*/true);
  warn_if_exposed(o.listen, fmt::format("the {} simulator", profile.name));
  if (!a.unit.empty()) o.unit = device_unit(a.unit, profile).value;
  if (a.baud_given) o.baud = a.link.baud;
  bool persists = false;
  for (const profile::Row& r : profile.rows) persists = persists || r.has(profile::kPersisted);
  if (persists && !a.no_state)
    o.state_file = a.state_file.empty() ? profile::default_state_path(profile.name) : a.state_file;
  o.force_state = a.force_state;
  o.time_scale = a.time_scale;
  o.notice = [](std::string_view line) {
    fmt::print("{}\n", line);
    std::fflush(stdout);
  };
  if (a.verbose) o.log = print_requests();
  o.server = a.server.options();
  std::string console_path;
  if (!a.console.empty()) {
    if (!a.console.starts_with("unix:") || a.console.size() <= 5)
      throw Failure{kUsage, fmt::format("--console takes unix:PATH, not '{}'", a.console)};
    console_path = a.console.substr(5);
  }

  asio::io_context ctx;
  // Armed before anything says it is ready: a SIGHUP or SIGTERM that comes
  // right after "listening on" ends the server cleanly too.
  term::ignore_tty_stops();
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
  Outcome<std::unique_ptr<profile::SimHost>> started = profile::SimHost::start(ctx, std::move(device), o);
  if (!started.ok()) throw Failure{exit_code(started.error().error()), std::string(started.error().reason())};
  profile::SimHost& host = **started;
  fmt::print("{}\n", host.banner());

  const term::ConsoleHandler on_line = [&host, &ctx](const std::string& line,
                                                     const term::ConsoleReply& reply) {
    const std::string text = host.command(line);
    if (!text.empty()) reply(text.back() == '\n' ? text : text + "\n");
    if (host.quit_requested()) ctx.stop();
  };
  std::unique_ptr<term::LineConsole> socket_console;
  if (!console_path.empty()) {
    auto c = term::LineConsole::open(ctx, console_path, on_line);
    if (!c.ok())
      throw Failure{c.error().code() == Errc::invalid_argument ? kUsage : kIoError,
                    std::string(c.error().reason())};
    socket_console = std::move(*c);
    fmt::print("console on unix:{}\n", console_path);
  }
  if (!a.no_console) fmt::print("console: type 'help' for commands\n");
  std::fflush(stdout);

  std::unique_ptr<term::StdinConsole> console;
  if (!a.no_console) console = std::make_unique<term::StdinConsole>(ctx, on_line);
  ctx.run();
  console.reset();
  return kOk;
}

}  // namespace

void add_sim_commands(CLI::App& app, Action& action) {
  auto* sim = app.add_subcommand("sim", "simulate a device on a pty, serial port or TCP");
  sim->require_subcommand(1);
  for (const profile::DeviceEntry* e : devices::registered()) {
    const profile::DeviceEntry& entry = *e;
    const profile::Profile* profile = entry.profile;
    add_command<SimArgs>(
        *sim, action, std::string(profile->name), std::string(profile->title),
        [&entry, profile](CLI::App& cmd, SimArgs& a) {
          add_sim_options(cmd, a, profile);
          for (const profile::SimOption& o : entry.sim_options) {
            std::string& text = a.settings[std::string(o.name)];
            text = o.default_value;
            cmd.add_option(fmt::format("--{}", o.name), text, std::string(o.help))->capture_default_str();
          }
          const std::string name(profile->name);
          examples(cmd, {fmt::format("rtukit sim {} --listen pty:/tmp/{}", name, name),
                         fmt::format("rtukit sim {} --listen tcp://127.0.0.1:1502 --state-file {}.json", name,
                                     name),
                         fmt::format("rtukit sim {} --listen pty:/tmp/{} --console unix:/tmp/{}.sock &", name,
                                     name, name)});
        },
        [&entry](SimArgs& a, const CLI::App& cmd) {
          a.baud_given = cmd.count("--baud") > 0;
          Outcome<profile::SimDevice> device = entry.make_sim(a.settings);
          if (!device)
            throw Failure{kUsage, fmt::format("sim {}: {}", entry.profile->name, device.error().reason())};
          return run_sim(a, std::move(*device));
        });
  }
  add_command<SimArgs>(
      *sim, action, "map", "serve a register-map file as a register-only device",
      [](CLI::App& cmd, SimArgs& a) {
        cmd.add_option("file", a.map_file, "the map (YAML or JSON; see docs/register-maps.md)")->required();
        add_sim_options(cmd, a, nullptr);
        examples(cmd, {"rtukit sim map examples/maps/energy-meter.yaml --listen pty:/tmp/meter"});
      },
      [](SimArgs& a, const CLI::App& cmd) {
        a.baud_given = cmd.count("--baud") > 0;
        Outcome<std::unique_ptr<profile::MapProfile>> map = profile::load_map(a.map_file);
        if (!map.ok()) throw Failure{exit_code(map.error().error()), std::string(map.error().reason())};
        // The profile outlives the simulator: both live until the process ends.
        static std::unique_ptr<profile::MapProfile> keep;
        keep = std::move(*map);
        if (!a.baud_given) a.link.baud = profile::link_defaults(keep->profile()).baud;
        profile::SimDevice device{profile::make_register_device(keep->profile()), {}, {}};
        return run_sim(a, std::move(device));
      });
}

}  // namespace rtukit::cli
