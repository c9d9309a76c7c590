// The Rehand 6600's verbs (profile/verb.hpp): `status` (the handshake, then
// table 1), `pulse` and `set` (through the host controller and its rules,
// as the display's own buttons), and from the tables `errors [CODE]` (table
// 3) and `stopping` (D-9). A failed link is the chair's 1010 (the entry's
// no_answer for a link nobody answers). `watch` (a live view of the host
// controller) and `hold` (a lease renewed as a finger on a button does, then
// released) run until done or until the person stops them.
#include <fmt/core.h>

#include <algorithm>
#include <cmath>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/verbs.hpp"
#include "rtukit/devices/rehand6600/views.hpp"

namespace rtukit::rehand6600 {
namespace {

std::string without_final_newline(std::string text) {
  if (!text.empty() && text.back() == '\n') text.pop_back();
  return text;
}

// The hold commands by name, from the command table.
std::string hold_commands() {
  std::string names;
  for (const Register& x : registers())
    if (x.role == Kind::hold && x.address != reg::kHostReady)
      names += (names.empty() ? "" : ", ") + std::string(x.key);
  return names;
}

// Table 3, or one code with what it means and what to check: four hex
// digits are the code as the chair shows it ("10C3"); anything else is a
// number (0x10C3, 65535).
Outcome<profile::VerbResult> errors(const profile::VerbArgs& args) {
  std::vector<uint16_t> codes(error_codes().begin(), error_codes().end());
  const std::string_view text = profile::arg(args, "code");
  if (!text.empty()) {
    const bool as_shown =
        text.size() == 4 && text.find_first_not_of("0123456789abcdefABCDEF") == std::string::npos;
    const Outcome<int64_t> code = profile::parse_number(
        as_shown ? "0x" + std::string(text) : std::string(text), "error code", 1, 0xFFFF);
    if (!code) return code.error();
    codes = {static_cast<uint16_t>(*code)};
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const uint16_t c : codes) list.push_back(error_json(c));
  return profile::VerbResult{"",
                             text.empty()
                                 ? without_final_newline(errors_markdown())
                                 : fmt::format("{}: {}", error_text(codes[0]), error_advice(codes[0])),
                             nullptr, nlohmann::ordered_json{{"errors", list}}};
}

// Another device answered (the handshake refused it): the chair's 1010, with
// what to check. A link nobody answers is worded by the entry's no_answer.
rtukit::Status another_device(const rtukit::Status& e) {
  return e.code() == Errc::refused ? rtukit::Status(Errc::refused, link_failure_text(e.reason(), true)) : e;
}

}  // namespace

rtukit::Status identify(Master& master, UnitId unit) {
  const rtukit::Status e = handshake(master, unit);
  if (e.ok()) return e;
  return e.code() == Errc::io_error || e.code() == Errc::not_connected
             ? rtukit::Status(e.error(), "handshake")
             : another_device(e);
}

namespace {

// The handshake, then table 1 in one read: the status panel, or its values.
Outcome<profile::VerbResult> status(const profile::VerbArgs& args, profile::VerbContext& where) {
  Master& master = where.open();
  if (const rtukit::Status e = identify(master, where.unit)) return e;
  Snapshot s;
  if (const Error e = master.read_holding_registers(where.unit, 0, s.regs))
    return e.code() == Errc::io_error || e.is_exception()
               ? rtukit::Status(e, "reading table 1")
               : rtukit::Status(e, fmt::format("reading table 1: no answer ({})", e.name()));
  s.valid = true;
  const bool mph = profile::given(args, "mph");
  return profile::VerbResult{"", without_final_newline(panel(s, mph, where.alert)), snapshot_values(s, mph),
                             nullptr};
}

// A host controller on the link, connected (its handshake done and table 1
// read) within a few answer timeouts; the link's failure otherwise.
Outcome<std::unique_ptr<Host>> connected_host(profile::VerbContext& where) {
  // A front-end that offers no link of its own cannot run the controller: say so, never call nothing.
  if (!where.open_link)
    return rtukit::Status(Errc::not_connected, "this front-end gives the host controller no link");
  HostOptions o;
  o.unit = where.unit;
  o.response_timeout = where.response_timeout;
  o.trace = where.trace;
  auto host = std::make_unique<Host>(where.open_link(), o);
  host->start();
  if (host->wait_connected(std::chrono::milliseconds(2000) + 4 * where.response_timeout)) return host;
  const rtukit::Status why = host->last_failure();
  host->stop();
  if (why.ok()) return rtukit::Status(Errc::timeout, "no handshake");
  return another_device(why);
}

// A command the controller's rules refused (with what to check when an
// error is active), or the request's failure, named by what was asked.
rtukit::Status refusal(const rtukit::Status& e, std::string_view verb, std::string_view key,
                       uint16_t active_error) {
  if (e.code() == Errc::refused)
    return rtukit::Status(Errc::refused,
                          fmt::format("{} refused: {}{}{}", key, e.reason(), active_error ? ": " : "",
                                      active_error ? error_advice(active_error) : std::string()));
  if (e.code() == Errc::invalid_argument)
    return rtukit::Status(Errc::invalid_argument, fmt::format("{}: {}", key, e.reason()));
  if (e.code() == Errc::io_error) return rtukit::Status(e.error(), fmt::format("{} {}", verb, key));
  return rtukit::Status(e.error(), fmt::format("{} {}: no answer ({})", verb, key, e.error().name()));
}

Outcome<profile::VerbResult> pulse(const profile::VerbArgs& args, profile::VerbContext& where) {
  const std::string key(profile::arg(args, "cmd"));
  const Outcome<const Register*> r = command_register(key, Kind::pulse);
  if (!r) return r.error();
  Outcome<std::unique_ptr<Host>> host = connected_host(where);
  if (!host) return host.error();
  const rtukit::Status e = (*host)->pulse((*r)->address);
  const uint16_t active = (*host)->active_error();
  (void)(*host)->wait_poll(std::chrono::milliseconds(500));  // the lights as they are after it
  const Snapshot s = (*host)->snapshot();
  (*host)->stop();
  if (e) return refusal(e, "pulse", key, active);
  return profile::VerbResult{
      "pulse",
      fmt::format("pulsed {}: main light {}, left signal {}, right signal {}", key,
                  value_text(s, "main_light"), value_text(s, "left_signal"), value_text(s, "right_signal")),
      nullptr, nullptr};
}

Outcome<profile::VerbResult> set(const profile::VerbArgs& args, profile::VerbContext& where) {
  const std::string_view what = profile::arg(args, "what"), value = profile::arg(args, "value");
  const Outcome<SettingChange> c = parse_setting(what, value);  // a value outside the row: usage
  if (!c) return rtukit::Status(Errc::invalid_argument, std::string(c.error().reason()));
  Outcome<std::unique_ptr<Host>> host = connected_host(where);
  if (!host) return host.error();
  const rtukit::Status e = write_setting(**host, *c);
  const uint16_t active = (*host)->active_error();
  (*host)->stop();
  if (e) return refusal(e, "set", what, active);
  return profile::VerbResult{
      "set", fmt::format("{} = {}", what, value),
      nlohmann::ordered_json{{std::string(c->row->key), profile::entry_json(*c->row, c->raw)}}, nullptr};
}

// The live panel from the host controller; while the link is down (1010)
// the last reading stays, marked stale with the reason.
Outcome<profile::VerbResult> watch(const profile::VerbArgs& args, profile::VerbContext& where) {
  Outcome<std::unique_ptr<Host>> started = connected_host(where);
  if (!started) return started.error();
  std::shared_ptr<Host> host = std::move(*started);  // stopped when the view ends (~Host)
  profile::VerbResult r;
  r.refresh = [host, mph = profile::given(args, "mph"),
               alert = where.alert](unsigned) -> Outcome<profile::LiveFrame> {
    const Snapshot s = host->snapshot();
    const uint16_t err = host->active_error();
    profile::LiveFrame f{.panel = without_final_newline(panel(s, mph, alert)),
                         .line = line(s, mph),
                         .values = snapshot_values(s, mph)};
    f.values["active_error"] =
        profile::quantity_json(err ? error_text(err) : "", {}, err ? error_text(err) : "none");
    if (err == kMasterCommunicationError) {
      f.ok = false;
      f.why = fmt::format("{}: {}", error_text(err), host->last_failure().reason());
    }
    return f;
  };
  return r;
}

// A hold command for a while, its lease renewed every 100 ms (well within
// its 300 ms, as the display renews while the button is held), then
// released; a stop request (Ctrl-C) releases it at once. Refused by the
// controller's rules: released, with what to check.
Outcome<profile::VerbResult> hold(const profile::VerbArgs& args, profile::VerbContext& where) {
  const std::string key(profile::arg(args, "cmd"));
  const Outcome<const Register*> found = command_register(key, Kind::hold);
  if (!found) return found.error();
  const Register& r = **found;
  const Outcome<uint16_t> value = command_value(r, profile::arg(args, "value"));
  if (!value) return value.error();
  const Outcome<std::chrono::milliseconds> length = parse_hold_duration(profile::arg(args, "for", "1s"));
  if (!length) return length.error();
  Outcome<std::unique_ptr<Host>> started = connected_host(where);
  if (!started) return started.error();
  Host& host = **started;
  DriverClock& clock = clock_or_steady(where.clock);
  const auto start = clock.now();
  bool interrupted = false;
  while (clock.now() - start < *length) {
    // A stop asked for before a (re)press (during the handshake, say): never press again.
    if (!profile::wait(where, std::chrono::milliseconds(0))) {
      interrupted = true;
      break;
    }
    if (const rtukit::Status e = host.hold(r.address, *value)) {
      profile::progress(where, "");
      const uint16_t active = host.active_error();
      host.stop();
      return refusal(e, "hold", key, active);
    }
    const std::chrono::duration<double> left = *length - (clock.now() - start);
    profile::progress(where, fmt::format("holding {} {}: {:.1f} s left (Ctrl-C releases)", key,
                                         format_value(r, *value), std::max(0.0, left.count())));
    if (!profile::wait(where, std::chrono::milliseconds(100))) {
      interrupted = true;
      break;
    }
  }
  profile::progress(where, "");
  (void)host.release(r.address);
  (void)host.wait_poll(std::chrono::milliseconds(500));
  const Snapshot s = host.snapshot();
  host.stop();
  const double held = std::chrono::duration<double>(clock.now() - start).count();
  profile::VerbResult done{
      "hold",
      fmt::format("held {} = {} for {:.1f} s, released{}", key, format_value(r, *value), held,
                  interrupted ? " (interrupted)" : ""),
      nlohmann::ordered_json{
          {std::string(r.key), profile::entry_json(r, *value)},
          {"held", profile::quantity_json(std::round(held * 10) / 10, "s", fmt::format("{:.1f} s", held))}},
      nullptr};
  done.interrupted = interrupted;
  if (!interrupted) done.more = without_final_newline(panel(s, false, where.alert));
  return done;
}

}  // namespace

const std::vector<profile::Verb>& verb_table() {
  static const std::vector<profile::Verb> verbs{
      {.name = "status",
       .help = "handshake, then table 1: battery, motion, lights, posture, error",
       .args = {{"mph", profile::VerbArg::Form::flag, "speed in mph (default km/h)"}},
       .examples = {"{port}", "{port} --json --mph"},
       .reads = true},
      {.name = "pulse",
       .help = "a pulse command: light, phone_left_signal, phone_right_signal, phone_light",
       .args = {{"cmd", profile::VerbArg::Form::positional, "the command", true}},
       .examples = {"{port} light"}},
      {.name = "set",
       .help = "drive-mode normal|indoor|outdoor, speed-level 1..5, host-fault CODE",
       .args = {{"what", profile::VerbArg::Form::positional, "drive-mode | speed-level | host-fault", true},
                {"value", profile::VerbArg::Form::positional, "the value", true}},
       .examples = {"{port} drive-mode outdoor", "{port} speed-level 3 --json"}},
      {.name = "watch",
       .help = "live panel from the host controller until Ctrl-C",
       .args = {{"mph", profile::VerbArg::Form::flag, "speed in mph (default km/h)"}},
       .examples = {"{port}", "{port} --json --interval 1000 > chair.jsonl"},
       .reads = true,
       .live_interval_ms = 250},
      {.name = "hold",
       .help = "hold a command (posture, phone drive, anti-pinch...) for a while, then release",
       .args = {{"cmd", profile::VerbArg::Form::positional, hold_commands(), true},
                {"value", profile::VerbArg::Form::positional,
                 "the direction, required where the command has two: stand|sit, up|down (seat_lift, "
                 "leg_rotate), forward|back (backrest, seat_tilt, plate_tilt), extend|retract "
                 "(leg_extend); none for the others"},
                {"for", profile::VerbArg::Form::option, "how long (2s, 500ms, 1m, 1m30s; at most 10 minutes)",
                 false, "1s"}},
       .examples = {"{port} seat_lift up --for 2s", "{port} stand sit --for 500ms --json"},
       .lasting = true},
      {.name = "errors",
       .help = "table 3: error codes, functions, UI texts, what each means and what to check",
       .args = {{"code", profile::VerbArg::Form::positional, "one code, as the chair shows it (10C3)"}},
       .examples = {"", "10C3", "--json"},
       .uses_link = false,
       .reads = true},
      {.name = "stopping",
       .help = "D-9: stopping time and distance per speed level and drive mode (model clock)",
       .examples = {""},
       .uses_link = false,
       .reads = true},
  };
  return verbs;
}

Outcome<profile::VerbResult> run_verb(const profile::Verb& verb, const profile::VerbArgs& args,
                                      profile::VerbContext& where) {
  if (verb.name == "status") return status(args, where);
  if (verb.name == "pulse") return pulse(args, where);
  if (verb.name == "set") return set(args, where);
  if (verb.name == "watch") return watch(args, where);
  if (verb.name == "hold") return hold(args, where);
  if (verb.name == "errors") return errors(args);
  if (verb.name == "stopping")
    return profile::VerbResult{"", without_final_newline(stopping_markdown()), nullptr, nullptr};
  return rtukit::Status(Errc::invalid_argument, fmt::format("rehand6600 has no verb '{}'", verb.name));
}

}  // namespace rtukit::rehand6600
