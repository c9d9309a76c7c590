// `rtukit rehand6600 ...`: the wheelchair controller as the RK3588 host sees
// it. One-shot reads go through the handshake first; watch and hold run the
// host controller library (devices/rehand6600/host.hpp) with its leases and
// UI rules. The handshake, the commands by name and the views are the device
// layer's (devices/rehand6600/verbs.hpp, views.hpp); this file wires and prints.
#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <nlohmann/json.hpp>
#include <thread>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/verbs.hpp"
#include "rtukit/devices/rehand6600/views.hpp"
#include "rtukit/programs/rehand_host.hpp"
#include "rtukit/web/server.hpp"

namespace rtukit::cli {
namespace {

namespace rh = rtukit::rehand6600;
using nlohmann::json;

// Every rehand6600 command's options (each command uses the ones it declares).
struct ChairArgs {
  LinkOptions link;
  std::string http = "127.0.0.1:8080";  ///< host: the display's listener
  std::vector<std::string> phone;       ///< host: phone listeners
  std::string pairing_file;             ///< host: paired phones
  std::string phone_url;                ///< host: what phones open (QR code)
  std::string tls_cert, tls_key;        ///< host: the phone listener's certificate
  std::vector<std::string> host_names;  ///< host: names phones may use for the chair
  unsigned forget_days = 30;            ///< host: a pairing unused this many days is forgotten
  std::string unit;                     ///< empty: the controller's factory address
  bool json = false;
  bool mph = false;
  WatchOptions watch{250};
  std::string key;              ///< hold/pulse command, set item
  std::string value;            ///< its value
  std::string duration = "1s";  ///< hold --for
};

void add_link(CLI::App& cmd, ChairArgs& a, bool reads) {
  a.link.timeout_ms = 200;
  a.link.add_to(cmd, false, rh::kDefaultBaud);
  cmd.add_option("--unit,-u", a.unit, device_unit_help(rh::kProfile));
  cmd.add_flag("--json", a.json,
               reads ? "print JSON (docs/json.md)" : "print the result as JSON (docs/json.md)");
  if (reads) cmd.add_flag("--mph", a.mph, "speed in mph (default km/h)");
}

UnitId unit_of(const ChairArgs& a) {
  return device_unit(a.unit, rh::kProfile);
}

// 1010 with its reason and what to check (rehand6600::link_failure_text);
// `code` the exit code (3 no answer, 5 another device).
[[noreturn]] void master_error(const std::string& context, const std::string& reason, int code) {
  throw Failure{code, fmt::format("{}: {}", context, rh::link_failure_text(reason, code == kRefused))};
}

// The views are the device layer's (devices/rehand6600/views.hpp).
std::string panel_text(const rh::Snapshot& s, bool mph) {
  return rh::panel(s, mph, [](std::string_view t) { return LivePanel::alert(t); });
}

// What a command did, as a line or as a JSON document.
void done(const ChairArgs& a, std::string_view action, const std::string& text,
          Json values = Json::object()) {
  if (!a.json) {
    fmt::print("{}\n", text);
    return;
  }
  Json out = json_document("rehand6600", unit_of(a).value);
  out["action"] = action;
  out["text"] = text;
  if (!values.empty()) out["values"] = std::move(values);
  print_json(out);
}

// A running host controller for watch and hold; fails with 1010 when the
// handshake does not succeed within `wait`.
std::unique_ptr<rh::Host> start_host(const ChairArgs& a, std::string* context) {
  rh::HostOptions o;
  o.unit = unit_of(a);
  o.response_timeout = std::chrono::milliseconds(a.link.timeout_ms);
  o.trace = a.link.tracer();
  auto host = std::make_unique<rh::Host>(io::make_link(a.link.spec(false)), o);
  *context = fmt::format("Rehand 6600 unit {} on {}", o.unit.value, host->describe());
  host->start();
  if (!host->wait_connected(std::chrono::milliseconds(2000 + 4 * a.link.timeout_ms))) {
    const rtukit::Status why = host->last_failure();
    host->stop();
    // The exit code from the error's code: 4 the port, 3 no answer, 5 another device.
    const int code = why.ok() ? kNoResponse : why.code() == Errc::refused ? kRefused : exit_code(why.error());
    // A port that cannot be used is said in words ("/dev/null is not a serial port").
    if (code == kIoError) fail(why.error(), *context);
    master_error(*context, why.ok() ? std::string("no handshake") : std::string(why.reason()), code);
  }
  return host;
}

int run_watch(const ChairArgs& a) {
  std::string context;
  auto host = start_host(a, &context);
  watch_view(a.watch, a.json, "rehand6600", unit_of(a), context, [&](unsigned) {
    const rh::Snapshot s = host->snapshot();
    const uint16_t err = host->active_error();
    ViewFrame f{.panel = panel_text(s, a.mph),
                .line = fmt::format("{} {}", clock_hms(), rh::line(s, a.mph)),
                .values = rh::snapshot_values(s, a.mph)};
    f.values["active_error"] =
        quantity_json(err ? rh::error_text(err) : "", {}, err ? rh::error_text(err) : "none");
    // 1010: the link is down; the last reading stays, marked stale.
    if (err == rh::kMasterCommunicationError) {
      f.ok = false;
      f.why = fmt::format("{}: {}", rh::error_text(err), host->last_failure().reason());
    }
    return f;
  });
  host->stop();
  return kOk;
}

// A command, its direction and a hold's length are checked by the device
// layer (rehand6600/verbs.hpp) before the port is opened: nothing is sent.
template <class T>
T usage_or(Outcome<T> r) {
  if (!r.ok()) throw Failure{kUsage, std::string(r.error().reason())};
  return *r;
}

// A device rule refused (exit 5, with its reason, and what to check when an
// error is active), or the request failed.
[[noreturn]] void refused_or_fail(const rtukit::Status& e, const std::string& context, std::string_view key,
                                  std::string_view verb, uint16_t active_error = 0) {
  if (e.code() == Errc::refused)
    throw Failure{kRefused,
                  fmt::format("{}: {} refused: {}{}{}", context, key, e.reason(), active_error ? ": " : "",
                              active_error ? rh::error_advice(active_error) : std::string())};
  if (e.code() == Errc::invalid_argument)
    throw Failure{kUsage, fmt::format("{}: {}: {}", context, key, e.reason())};
  fail(e.error(), fmt::format("{}: {} {}", context, verb, key));
}

int run_hold(const ChairArgs& a, const std::string& key, const std::string& value_text,
             const std::string& duration) {
  const rh::Register& r = *usage_or(rh::command_register(key, rh::Kind::hold));
  const uint16_t value = usage_or(rh::command_value(r, value_text));
  const auto length = usage_or(rh::parse_hold_duration(duration));
  std::string context;
  auto host = start_host(a, &context);
  const Interruptible interrupt;
  Progress countdown;  // on a terminal only
  const auto start = time_source().now();
  // Renew the lease well within its 300 ms, as a UI does while the button is held.
  while (!interrupt.interrupted() && time_source().now() - start < length) {
    if (const rtukit::Status e = host->hold(r.address, value)) {
      countdown.clear();
      const uint16_t active = host->active_error();
      host->stop();
      refused_or_fail(e, context, key, "hold", active);
    }
    const auto left = std::chrono::duration<double>(length - (time_source().now() - start));
    countdown.show(fmt::format("holding {} {}: {:.1f} s left (Ctrl-C releases)", key,
                               rh::format_value(r, value), std::max(0.0, left.count())));
    interrupt.sleep(std::chrono::milliseconds(100));
  }
  countdown.clear();
  (void)host->release(r.address);
  (void)host->wait_poll(std::chrono::milliseconds(500));
  const rh::Snapshot s = host->snapshot();
  host->stop();
  const auto held = std::chrono::duration<double>(time_source().now() - start).count();
  // Ctrl-C (or SIGTERM, SIGHUP) ends the hold early: released all the same,
  // and the exit code says it was cut short (128 + the signal: 130 for Ctrl-C).
  const int sig = interrupt.signal();
  const int code = sig == 0 || sig == SIGPIPE ? kOk : 128 + sig;
  const std::string text = fmt::format("held {} = {} for {:.1f} s, released{}", key,
                                       rh::format_value(r, value), held, code == kOk ? "" : " (interrupted)");
  if (a.json) {
    done(a, "hold", text,
         {{std::string(r.key), profile::entry_json(r, value)},
          {"held", quantity_json(std::round(held * 10) / 10, "s", fmt::format("{:.1f} s", held))}});
    return code;
  }
  fmt::print("{}\n", text);
  if (code != kOk) return code;
  fmt::print("{}", panel_text(s, a.mph));
  return kOk;
}

// The daemon on the RK3588: owns the UART, serves the HMI and the phone page
// until SIGINT/SIGTERM.
int run_host(const ChairArgs& a) {
  programs::HostDaemonOptions o;
  o.http = a.http;
  o.phone = a.phone;
  o.mph = a.mph;
  o.pairing_file = a.pairing_file;
  o.phone_url = a.phone_url;
  o.tls_cert = a.tls_cert;
  o.tls_key = a.tls_key;
  o.host_names = a.host_names;
  o.pairing_max_age = std::chrono::hours(24) * a.forget_days;
  if (o.pairing_file.empty())
    o.pairing_file = programs::default_pairing_file(std::getenv("STATE_DIRECTORY"), std::getenv("HOME"));
  o.host.unit = unit_of(a);
  o.host.response_timeout = std::chrono::milliseconds(a.link.timeout_ms);
  o.host.trace = a.link.tracer();
  programs::HostDaemon daemon(io::make_link(a.link.spec(false)), o);
  const Interruptible interrupt;
  if (rtukit::Status e = daemon.start())
    throw Failure{e.code() == Errc::invalid_argument ? kUsage : kIoError,
                  fmt::format("rehand6600 host: {}", e.reason())};
  const auto urls = daemon.urls();
  fmt::print("rehand6600 host: display {}  (open it in the kiosk browser)\n", urls[0]);
  for (size_t i = 1; i < urls.size(); ++i) fmt::print("rehand6600 host: phones {}/  (TLS)\n", urls[i]);
  if (!daemon.fingerprint().empty())
    fmt::print("rehand6600 host: phone certificate SHA-256 {}\n", daemon.fingerprint());
  fmt::print("rehand6600 host: pairing store {}\n", o.pairing_file);
  std::fflush(stdout);
  while (interrupt.sleep(std::chrono::milliseconds(200))) {
  }
  daemon.stop();
  return kOk;
}

}  // namespace

void add_rehand6600_commands(CLI::App& app, Action& action) {
  CLI::App* chair = app.add_subcommand("rehand6600", device_title(rh::kProfile));
  chair->require_subcommand(1);
  const std::string port = "--port /dev/ttyS3";
  add_command<ChairArgs>(
      *chair, action, "watch", "live panel from the host controller until Ctrl-C",
      [&](CLI::App& cmd, ChairArgs& a) {
        add_link(cmd, a, true);
        a.watch.add_to(cmd);
        examples(cmd, {"rtukit rehand6600 watch " + port,
                       "rtukit rehand6600 watch " + port + " --json --interval 1000 > chair.jsonl"});
      },
      [](const ChairArgs& a) { return run_watch(a); });
  add_command<ChairArgs>(
      *chair, action, "hold",
      "hold a command (posture, phone drive, anti-pinch...) for a while, then release",
      [&](CLI::App& cmd, ChairArgs& a) {
        cmd.add_option(
               "CMD", a.key,
               "stand, seat_lift, backrest, seat_tilt, leg_rotate, leg_extend, plate_tilt, anti_pinch, "
               "phone_forward, phone_reverse, phone_left, phone_right, phone_horn, sos")
            ->required();
        cmd.add_option("VALUE", a.value,
                       "the direction, required where the command has two: stand|sit, up|down (seat_lift, "
                       "leg_rotate), forward|back (backrest, seat_tilt, plate_tilt), extend|retract "
                       "(leg_extend); none for the others");
        cmd.add_option("--for", a.duration, "how long (2s, 500ms)")->capture_default_str();
        add_link(cmd, a, false);
        examples(cmd, {"rtukit rehand6600 hold " + port + " seat_lift up --for 2s",
                       "rtukit rehand6600 hold " + port + " stand sit --for 500ms --json"});
      },
      [](const ChairArgs& a) { return run_hold(a, a.key, a.value, a.duration); });
  add_command<ChairArgs>(
      *chair, action, "host",
      "the RK3588 host daemon: owns the UART, serves the touch HMI and the phone remote",
      [&](CLI::App& cmd, ChairArgs& a) {
        add_link(cmd, a, true);
        cmd.add_option("--http", a.http,
                       "the display's listener (HOST:PORT), loopback only: the kiosk browser on this board")
            ->capture_default_str();
        cmd.add_option("--phone", a.phone,
                       "a TLS listener for phones (HOST:PORT, repeatable): the chair's hotspot address, e.g. "
                       "192.168.4.1:8443");
        cmd.add_option(
            "--tls-cert", a.tls_cert,
            "the phone listener's certificate, PEM (default: made at first start beside the pairing file)");
        cmd.add_option("--tls-key", a.tls_key, "its private key, PEM (with --tls-cert)");
        cmd.add_option(
            "--host-name", a.host_names,
            "a name phones may use for the chair besides its IP address (repeatable), e.g. chair.local");
        cmd.add_option(
            "--phone-url", a.phone_url,
            "what phones open, for the pairing QR code (default https://<this machine's address>:PORT)");
        cmd.add_option(
            "--pairing-file", a.pairing_file,
            "paired phones (default $STATE_DIRECTORY or ~/.local/state/rtukit/rehand6600-pairing.json)");
        cmd.add_option("--forget-after", a.forget_days,
                       "days after which a phone that has not connected is forgotten (default 30)")
            ->check(CLI::Range(1u, 3650u));
        examples(cmd,
                 {"rtukit rehand6600 host --port /dev/ttyS9 --http 127.0.0.1:8080 --phone 192.168.4.1:8443"});
      },
      [](const ChairArgs& a) { return run_host(a); });
  // status, pulse, set, errors, stopping: the device's verb table (rehand6600::verb_table).
}

}  // namespace rtukit::cli
