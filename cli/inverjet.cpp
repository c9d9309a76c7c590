// `rtukit inverjet bridge|panel|panel-password`: the programs that serve
// the machine (programs/inverjet_bridge.hpp, inverjet_panel.hpp). Its other
// commands (status, watch, start, pause, resume, stop, speed, plan, config)
// are its verb table (devices/inverjet/src/verb_table.cpp), added with every
// device's verbs (profiles.cpp); this file wires the programs' options.
#include <fmt/core.h>

#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/programs/inverjet_bridge.hpp"
#include "rtukit/programs/inverjet_panel.hpp"

namespace rtukit::cli {
namespace {

namespace ij = rtukit::inverjet;

// Every inverjet command's options (each command uses the ones it declares).
struct JetArgs {
  LinkOptions link;
  std::string unit;  ///< empty: the machine's factory address (the address row's default)
  std::string file;  ///< panel-password: the file to write
  // bridge
  std::vector<std::string> units;  ///< "21" or "22=lane2"
  std::string mqtt = "mqtt://127.0.0.1:1883", id, user, password_file, tls_ca,
              discovery_prefix = "homeassistant";
  double poll_hz = 2, max_rate = 2;
  std::string http = "127.0.0.1:8081";  ///< panel
  std::vector<std::string> host_names;  ///< panel: DNS names allowed in Host
  std::string tls_cert, tls_key;        ///< panel: its certificate and key (PEM)
  bool force = false;                   ///< panel-password: replace an existing file
  bool no_discovery = false;
};

// The MQTT bridge, until SIGINT/SIGTERM.
int run_bridge(const JetArgs& a) {
  programs::BridgeOptions o;
  o.tls_ca = a.tls_ca;
  if (rtukit::Status e = programs::parse_mqtt_url(a.mqtt, o)) throw Failure{kUsage, std::string(e.reason())};
  o.user = a.user;
  if (!a.password_file.empty()) {
    const Outcome<std::string> pw = programs::read_mqtt_password(a.password_file);
    if (!pw) throw Failure{kIoError, fmt::format("--password-file: {}", pw.error().reason())};
    o.password = *pw;
  }
  o.poll_hz = a.poll_hz;
  o.max_rate = a.max_rate;
  o.discovery_prefix = a.no_discovery ? "" : a.discovery_prefix;
  o.response_timeout_ms = a.link.timeout_ms;
  Outcome<std::vector<programs::BridgeMachine>> machines = programs::bridge_machines(a.units, a.id);
  if (!machines) throw Failure{kUsage, std::string(machines.error().reason())};
  o.machines = std::move(*machines);
  programs::Bridge bridge(io::make_link(a.link.spec(false)), o);
  return serve(bridge, "inverjet bridge", [&] {
    const std::vector<std::string> ids = bridge.client_ids();
    for (size_t i = 0; i < o.machines.size(); ++i)
      fmt::print("inverjet bridge: unit {} as rtukit/inverjet/{}/ on {}://{}:{} (client id {})\n",
                 o.machines[i].unit, o.machines[i].id, o.tls_ca.empty() ? "mqtt" : "mqtts", o.host, o.port,
                 ids.at(i));
    for (const std::string& w : bridge.warnings()) fmt::print(stderr, "inverjet bridge: {}\n", w);
  });
}

// The pool panel, until SIGINT/SIGTERM. Off loopback it needs a password
// file and TLS (Panel::start refuses: one line, exit 2).
int run_panel(const JetArgs& a) {
  programs::PanelOptions o;
  o.unit = device_unit(a.unit, ij::kProfile).value;
  o.http = a.http;
  o.poll_hz = a.poll_hz;
  o.response_timeout_ms = a.link.timeout_ms;
  o.host_names = a.host_names;
  o.password_file = a.password_file;
  o.tls_cert = a.tls_cert;
  o.tls_key = a.tls_key;
  programs::Panel panel(io::make_link(a.link.spec(false)), o);
  return serve(panel, "inverjet panel", [&] {
    fmt::print("inverjet panel: {}  (unit {}{})\n", panel.url(), o.unit,
               o.password_file.empty() ? ", no password: loopback only" : ", password required");
  });
}

// `rtukit inverjet panel-password FILE`: the panel's password file, from a
// password read on stdin (docs/inverjet.md, "Pool panel").
int run_panel_password(const JetArgs& a) {
  // Refused codes are the user's to fix (exit 2); the rest is the file's (4).
  const auto check = [](const rtukit::Status& e) {
    if (e)
      throw Failure{e.code() == Errc::refused || e.code() == Errc::invalid_argument ? kUsage : kIoError,
                    std::string(e.reason())};
  };
  check(programs::check_password_file_path(a.file, a.force));  // before asking for a password
  const std::string password = term::read_secret_line("New panel password: ");
  if (password.empty())
    throw Failure{kUsage, fmt::format("no password on stdin (at least {} characters)",
                                      programs::kMinPasswordCharacters)};
  check(programs::check_new_password(password));
  if (term::stdin_is_terminal() && term::read_secret_line("Again: ") != password)
    throw Failure{kUsage, "the two passwords differ: nothing written"};
  check(programs::write_password_file(a.file, password, a.force));
  fmt::print(
      "{}: the panel's password (PBKDF2-HMAC-SHA256, mode 0600); use it with `rtukit inverjet panel "
      "--password-file {}`\n",
      a.file, a.file);
  return kOk;
}

}  // namespace

void add_inverjet_commands(CLI::App& app, Action& action) {
  CLI::App* jet = app.add_subcommand("inverjet", device_title(ij::kProfile));
  jet->require_subcommand(1);
  const std::string port = "--port /dev/ttyUSB0";
  add_command<JetArgs>(
      *jet, action, "bridge", "MQTT bridge with Home Assistant discovery (docs/inverjet.md)",
      [&](CLI::App& cmd, JetArgs& a) {
        a.link.add_to(cmd, false, ij::kDefaultBaud);
        cmd.add_option("--unit,-u", a.units, "a machine: UNIT or UNIT=ID (repeatable; default 21)");
        cmd.add_option("--mqtt", a.mqtt, "the broker: mqtt://HOST[:PORT] or mqtts://HOST[:PORT]")
            ->capture_default_str();
        cmd.add_option("--id", a.id, "the machine's id in the topics (rtukit/inverjet/ID/...)");
        cmd.add_option("--user", a.user, "MQTT user name");
        cmd.add_option("--password-file", a.password_file, "a file holding the MQTT password");
        cmd.add_option("--tls-ca", a.tls_ca, "CA certificate file: TLS to the broker");
        cmd.add_option("--poll-hz", a.poll_hz, "polls per second per machine")->capture_default_str();
        cmd.add_option("--max-rate", a.max_rate, "state documents per second per machine, at most")
            ->capture_default_str();
        cmd.add_option("--discovery-prefix", a.discovery_prefix, "Home Assistant's discovery prefix")
            ->capture_default_str();
        cmd.add_flag("--no-discovery", a.no_discovery, "no Home Assistant discovery");
        examples(cmd,
                 {"rtukit inverjet bridge " + port + " --mqtt mqtt://127.0.0.1:1883 --id pool1",
                  "rtukit inverjet bridge " + port +
                      " --unit 21=lane1 --unit 22=lane2 --user jets --password-file /etc/rtukit/mqtt.pw"});
      },
      [](const JetArgs& a) { return run_bridge(a); });
  add_command<JetArgs>(
      *jet, action, "panel",
      "the pool panel: a web page to run the machine and edit its plans (docs/inverjet.md)",
      [&](CLI::App& cmd, JetArgs& a) {
        a.link.add_to(cmd, false, ij::kDefaultBaud);
        cmd.add_option("--unit,-u", a.unit, device_unit_help(ij::kProfile));
        cmd.add_option("--http", a.http, "HOST:PORT to serve the page on")->capture_default_str();
        cmd.add_option("--poll-hz", a.poll_hz, "polls per second")->capture_default_str();
        cmd.add_option("--password-file", a.password_file,
                       "the panel's password (made by `rtukit inverjet panel-password FILE`); required "
                       "off loopback");
        cmd.add_option("--tls-cert", a.tls_cert, "PEM certificate: serve HTTPS (required off loopback)");
        cmd.add_option("--tls-key", a.tls_key, "the certificate's PEM private key");
        cmd.add_option("--host-name", a.host_names,
                       "a DNS name the panel is reached by (pool.local), besides IP addresses (repeatable)");
        examples(cmd, {"rtukit inverjet panel " + port + " --http 127.0.0.1:8081",
                       "rtukit inverjet panel " + port +
                           " --http 192.168.10.2:8443 --password-file /etc/rtukit/panel.pw --tls-cert "
                           "/etc/rtukit/panel.crt --tls-key /etc/rtukit/panel.key --host-name pool.local"});
      },
      [](const JetArgs& a) { return run_panel(a); });
  add_command<JetArgs>(
      *jet, action, "panel-password",
      "make the pool panel's password file from a password read on stdin (docs/inverjet.md)",
      [&](CLI::App& cmd, JetArgs& a) {
        cmd.add_option("FILE", a.file, "the file to write (mode 0600)")->required();
        cmd.add_flag("--force", a.force, "replace an existing file");
        examples(cmd, {"rtukit inverjet panel-password /etc/rtukit/panel.pw",
                       "printf '%s\\n' \"$PW\" | rtukit inverjet panel-password panel.pw --force"});
      },
      [](const JetArgs& a) { return run_panel_password(a); });
  // status, watch, start, pause, resume, stop, speed, plan, config: the device's
  // verb table (inverjet::verb_table), added with every device's verbs.
}

}  // namespace rtukit::cli
