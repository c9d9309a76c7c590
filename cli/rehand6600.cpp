// `rtukit rehand6600 host`: the RK3588 host daemon (programs/rehand_host.hpp).
// The chair's other commands (status, watch, hold, pulse, set, errors,
// stopping) are its verb table (devices/rehand6600/verb_table.cpp), added
// with every device's verbs (profiles.cpp); this file wires the daemon's
// options and the BLE reference client's (programs/rehand_ble_remote.hpp).
#include <fmt/core.h>

#include <chrono>
#include <cstdlib>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/devices/rehand6600/device.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/programs/rehand_ble_remote.hpp"
#include "rtukit/programs/rehand_host.hpp"

namespace rtukit::cli {
namespace {

namespace rh = rtukit::rehand6600;

// The host daemon's options, bound to the daemon's own (HostDaemonOptions).
struct ChairArgs {
  LinkOptions link;
  programs::HostDaemonOptions o;
  unsigned forget_days = 30;  ///< a pairing unused this many days is forgotten
  std::string unit;           ///< empty: the controller's factory address
};

// The daemon on the RK3588: owns the UART, serves the HMI and the phone page
// until SIGINT/SIGTERM.
int run_host(ChairArgs a) {
  programs::HostDaemonOptions& o = a.o;
  o.pairing_max_age = std::chrono::hours(24) * a.forget_days;
  if (o.pairing_file.empty())
    o.pairing_file = programs::default_pairing_file(std::getenv("STATE_DIRECTORY"), std::getenv("HOME"));
  o.host.unit = device_unit(a.unit, rh::kProfile);
  o.host.response_timeout = std::chrono::milliseconds(a.link.timeout_ms);
  o.host.trace = a.link.tracer();
  programs::HostDaemon daemon(io::make_link(a.link.spec(false)), o);
  return serve(daemon, "rehand6600 host", [&] {
    const auto urls = daemon.urls();
    fmt::print("rehand6600 host: display {}  (open it in the kiosk browser)\n", urls[0]);
    for (size_t i = 1; i < urls.size(); ++i) fmt::print("rehand6600 host: phones {}/  (TLS)\n", urls[i]);
    if (!daemon.fingerprint().empty())
      fmt::print("rehand6600 host: phone certificate SHA-256 {}\n", daemon.fingerprint());
    fmt::print("rehand6600 host: pairing store {}\n", o.pairing_file);
  });
}

}  // namespace

void add_rehand6600_commands(CLI::App& app, Action& action) {
  CLI::App* chair = app.add_subcommand("rehand6600", device_title(rh::kProfile));
  chair->require_subcommand(1);
  add_command<ChairArgs>(
      *chair, action, "host",
      "the RK3588 host daemon: owns the UART, serves the touch HMI and the phone remote",
      [&](CLI::App& cmd, ChairArgs& a) {
        a.link.timeout_ms = rh::device_entry().answer_timeout_ms;
        a.link.add_to(cmd, false, rh::kDefaultBaud);
        cmd.add_option("--unit,-u", a.unit, device_unit_help(rh::kProfile));
        cmd.add_flag("--mph", a.o.mph, "speed in mph on the display (default km/h)");
        cmd.add_option("--http", a.o.http,
                       "the display's listener (HOST:PORT), loopback only: the kiosk browser on this board")
            ->capture_default_str();
        cmd.add_option("--phone", a.o.phone,
                       "a TLS listener for phones (HOST:PORT, repeatable): the chair's hotspot address, e.g. "
                       "192.168.4.1:8443");
        cmd.add_flag("--ble{hci0}", a.o.ble_adapter,
                     "phones over Bluetooth LE too, on this adapter (--ble: hci0, --ble=hci1; "
                     "docs/rehand6600-ble.md)");
        cmd.add_option(
            "--tls-cert", a.o.tls_cert,
            "the phone listener's certificate, PEM (default: made at first start beside the pairing file)");
        cmd.add_option("--tls-key", a.o.tls_key, "its private key, PEM (with --tls-cert)");
        cmd.add_option(
            "--host-name", a.o.host_names,
            "a name phones may use for the chair besides its IP address (repeatable), e.g. chair.local");
        cmd.add_option(
            "--phone-url", a.o.phone_url,
            "what phones open, for the pairing QR code (default https://<this machine's address>:PORT)");
        cmd.add_option(
            "--pairing-file", a.o.pairing_file,
            "paired phones (default $STATE_DIRECTORY or ~/.local/state/rtukit/rehand6600-pairing.json)");
        cmd.add_option("--forget-after", a.forget_days,
                       "days after which a phone that has not connected is forgotten (default 30)")
            ->check(CLI::Range(1u, 3650u));
        examples(cmd,
                 {"rtukit rehand6600 host --port /dev/ttyS9 --http 127.0.0.1:8080 --phone 192.168.4.1:8443",
                  "rtukit rehand6600 host --port /dev/ttyS9 --ble"});
      },
      [](const ChairArgs& a) { return run_host(a); });
  add_command<programs::BleRemoteOptions>(
      *chair, action, "remote", "the reference Bluetooth LE client: drive the chair from a terminal's keys",
      [](CLI::App& cmd, programs::BleRemoteOptions& o) {
        cmd.add_option("--ble", o.address, "the chair's Bluetooth address, paired (docs/rehand6600-ble.md)")
            ->required();
        cmd.add_option("--adapter", o.adapter, "this computer's Bluetooth adapter")->capture_default_str();
        cmd.add_option("--key-gap", o.key_gap, "a held key that stops repeating this long is let go (ms)")
            ->capture_default_str()
            ->check(CLI::Range(100, 2000));
        examples(cmd, {"rtukit rehand6600 remote --ble 00:1A:7D:DA:71:13"});
      },
      [](const programs::BleRemoteOptions& o) {
        if (const rtukit::Status e = programs::run_ble_remote(o))
          throw Failure{exit_code(e.error()), fmt::format("rehand6600 remote: {}", e.reason())};
        return 0;
      });
  // status, watch, hold, pulse, set, errors, stopping: the device's verb table (rehand6600::verb_table).
}

}  // namespace rtukit::cli
