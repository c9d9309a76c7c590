// The Inverjet's verbs as a table (profile/verb.hpp): what `rtukit inverjet
// status|start|pause|resume|stop|speed|plan ...|config` take, check and do.
// Every argument is checked here before the link is opened; the machine is
// identified (identify) before anything is read or written; the runs are the
// same functions the bridge and the panel call (start, run_command).
#include <fmt/core.h>

#include <optional>

#include "rtukit/devices/inverjet/plan_file.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/inverjet/views.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/profile/typed_value.hpp"

namespace rtukit::inverjet {
namespace {

using profile::Verb;
using profile::VerbArg;
using profile::VerbArgs;
using profile::VerbContext;
using profile::VerbResult;
using Form = VerbArg::Form;
using Json = nlohmann::ordered_json;

// A number within [min, max], or invalid_argument naming `what`.
Outcome<int64_t> number(std::string_view text, std::string_view what, int64_t min, int64_t max) {
  return profile::parse_number(text, what, min, max);
}

// A request failed: a Modbus exception says why in the machine's terms
// (exception_reason); a timeout or the port keeps its Error, the reason
// saying what was being done.
rtukit::Status failed(const rtukit::Status& e, std::string_view what) {
  if (e.is_exception()) {
    const std::string hint = exception_reason(e);
    return {e.error(), fmt::format("{} refused: Modbus exception {:02X} ({}){}{}", what,
                                   e.error().exception_code(), e.name(), hint.empty() ? "" : ": ", hint)};
  }
  if (e.code() == Errc::invalid_argument || e.code() == Errc::refused)
    return {e.error(), fmt::format("{}: {}", what, e.reason())};
  return {e.error(), std::string(what)};
}

// The client on the opened link, once the machine there is an Inverjet.
// Another device: refused, and nothing is written to it.
rtukit::Status connect(VerbContext& c, std::optional<Client>& jet) {
  Master& m = c.open();
  const rtukit::Status e = identify(m, c.unit);
  if (e.code() == Errc::refused) return {e.error(), fmt::format("{}; check --port and --unit", e.reason())};
  if (e) return {e.error(), "identify"};
  jet.emplace(m, c.unit);
  return {};
}

Outcome<VerbResult> status(VerbContext& c) {
  std::optional<Client> jet;
  if (rtukit::Status e = connect(c, jet)) return e;
  Result<MachineStatus> s = jet->status();
  if (!s.ok()) return failed(s.error(), "status");
  return VerbResult{"", status_panel(*s, Family::none, c.alert), status_values(*s), nullptr};
}

// The live status: the machine identified, then a status read each refresh.
// Nothing there at the first refresh ends the view; later a failed read
// keeps it, marked stale. The run family a paused run had is remembered, so
// its time keeps its meaning (time_counts).
Outcome<VerbResult> watch(VerbContext& c) {
  struct View {
    std::optional<Client> jet;
    Family remembered = Family::none;
  };
  auto view = std::make_shared<View>();
  if (rtukit::Status e = connect(c, view->jet)) return e;
  VerbResult r;
  r.refresh = [view, alert = c.alert](unsigned n) -> Outcome<profile::LiveFrame> {
    Result<MachineStatus> s = view->jet->status();
    if (!s.ok()) {
      if (n == 0) return failed(s.error(), "watch");
      return profile::LiveFrame{
          .ok = false,
          .why = std::string(s.error().code() == Errc::timeout ? "no response" : s.error().text()),
          .kind = std::string(s.error().name())};
    }
    view->remembered = remember_family(*s, view->remembered);
    std::string panel = status_panel(*s, view->remembered, alert);
    if (!panel.empty() && panel.back() == '\n') panel.pop_back();
    return profile::LiveFrame{.panel = std::move(panel),
                              .line = status_line(*s, view->remembered),
                              .values = status_values(*s, view->remembered)};
  };
  return r;
}

Outcome<VerbResult> start_verb(const VerbArgs& a, VerbContext& c) {
  using profile::given;
  if (rtukit::Status e = check_start_options({given(a, "free"), given(a, "timer"), given(a, "plan"),
                                              given(a, "speed"), given(a, "from"), given(a, "remember")}))
    return e;
  StartRequest r;
  r.mode = given(a, "free") ? StartMode::free : given(a, "timer") ? StartMode::timer : StartMode::plan;
  if (given(a, "speed")) {
    const Outcome<int64_t> v = number(profile::arg(a, "speed"), "speed (%)", 0, kMaxSpeed);
    if (!v) return v.error();
    r.speed = static_cast<uint16_t>(*v);
  }
  if (given(a, "timer")) {
    const Outcome<uint16_t> t = parse_run_duration(profile::arg(a, "timer"), "timer", timer_range());
    if (!t) return t.error();
    r.duration_s = *t;
  }
  if (given(a, "plan")) {
    const Outcome<int64_t> n = number(profile::arg(a, "plan"), "plan", 1, kPlanCount);
    if (!n) return n.error();
    r.plan = static_cast<unsigned>(*n);
  }
  if (given(a, "from")) {
    const Outcome<uint16_t> t = parse_run_duration(profile::arg(a, "from"), "--from", from_range());
    if (!t) return t.error();
    r.from_s = *t;
  }
  r.remember = given(a, "remember");
  if (rtukit::Status e = check_start(r)) return e;
  std::optional<Client> jet;
  if (rtukit::Status e = connect(c, jet)) return e;
  const std::string what = start_text(r);
  const rtukit::Status e = start(*jet, r);
  if (r.mode == StartMode::plan && e == Errc::invalid_argument)
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("P{} has nothing to run from {} (see `plan show {}`)", r.plan,
                                      profile::format_mm_ss(r.from_s), r.plan));
  if (e) return failed(e, "start " + what);
  return VerbResult{"start",
                    fmt::format("started {}{}", what, r.remember ? " (after 3 s; saved as memory)" : ""),
                    nullptr, nullptr};
}

// pause, resume, stop, speed: the command table every front-end runs (run_command).
Outcome<VerbResult> command(std::string_view verb, const VerbArgs& a, VerbContext& c) {
  nlohmann::json body = nlohmann::json::object();
  std::string what(verb);
  if (verb == "speed") {
    const Outcome<int64_t> v = number(profile::arg(a, "speed"), "speed (%)", 0, kMaxSpeed);
    if (!v) return v.error();
    body["speed"] = static_cast<unsigned>(*v);
    what = fmt::format("speed {} %", *v);
  }
  std::optional<Client> jet;
  if (rtukit::Status e = connect(c, jet)) return e;
  nlohmann::json result;
  const rtukit::Status e = run_command(*jet, verb, body, result);
  if (verb == "resume" && e == Errc::invalid_argument)
    return rtukit::Status(Errc::invalid_argument, "resume: nothing is paused");
  if (e) return failed(e, what);
  if (verb != "speed") return VerbResult{std::string(verb), fmt::format("{}: ok", verb), nullptr, nullptr};
  const uint16_t speed = body["speed"].get<uint16_t>();
  return VerbResult{"speed", what, Json{{"speed", profile::entry_json(kMap.row(reg::speed), speed)}},
                    nullptr};
}

Outcome<VerbResult> plan_verb(std::string_view verb, const VerbArgs& a, VerbContext& c) {
  const Outcome<int64_t> n = number(profile::arg(a, "n"), "plan", 1, kPlanCount);
  if (!n) return n.error();
  const auto plan = static_cast<unsigned>(*n);
  std::vector<Segment> file;
  if (verb == "plan set") {
    Outcome<std::vector<Segment>> read = read_plan_file(std::string(profile::arg(a, "file")));
    if (!read) return read.error();
    file = std::move(*read);
  }
  std::optional<Client> jet;
  if (rtukit::Status e = connect(c, jet)) return e;
  if (verb == "plan show") {
    Outcome<std::vector<Segment>> segments = jet->read_plan(plan);
    if (!segments) return failed(segments.error(), fmt::format("read plan P{}", plan));
    std::string csv = plan_to_csv(*segments);
    if (!csv.empty() && csv.back() == '\n') csv.pop_back();
    return VerbResult{"", fmt::format("# plan P{}: {} segment(s)\n{}", plan, segments->size(), csv), nullptr,
                      Json{{"plan", plan}, {"segments", plan_json(*segments)}}};
  }
  if (verb == "plan set") {
    if (rtukit::Status e = jet->write_plan(plan, file)) return failed(e, fmt::format("write plan P{}", plan));
    return VerbResult{"plan set",
                      fmt::format("plan P{}: {} segment(s) written, ends at {}", plan, file.size(),
                                  profile::format_mm_ss(file.back().end)),
                      nullptr, nullptr};
  }
  if (rtukit::Status e = jet->clear_plan(plan)) return failed(e, fmt::format("clear plan P{}", plan));
  return VerbResult{"plan clear", fmt::format("plan P{}: factory plan ({})", plan, factory_plan_text()),
                    nullptr, nullptr};
}

Outcome<VerbResult> config_verb(const VerbArgs& a, VerbContext& c) {
  const std::string_view key = profile::arg(a, "what", "show");
  if (key == "show") {
    std::optional<Client> jet;
    if (rtukit::Status e = connect(c, jet)) return e;
    Result<Config> config = jet->config();
    if (!config.ok()) return failed(config.error(), "config");
    std::string text;
    Json values = Json::object();
    for (const ConfigValue& v : *config) {
      if (!text.empty()) text += '\n';
      text += fmt::format("{:<14} {}", v.row->key, profile::format_value(*v.row, v.raw));
      values[std::string(v.row->key)] = profile::entry_json(*v.row, v.raw);
    }
    return VerbResult{"", text, values, nullptr};
  }
  if (!profile::given(a, "value"))
    return rtukit::Status(Errc::invalid_argument, fmt::format("config {} needs a value", key));
  const Outcome<ConfigChange> change = parse_config(key, profile::arg(a, "value"), number);
  if (!change) return change.error();
  const ConfigChange& ch = *change;
  std::optional<Client> jet;
  if (rtukit::Status e = connect(c, jet)) return e;
  const uint8_t was = jet->unit().value;  // the client follows an address change
  if (rtukit::Status e = write_config(*jet, ch))
    return failed(e, ch.key == "pairing" ? std::string("set pairing")
                     : ch.key == "mask"  ? fmt::format("set control mask {}", ch.value)
                                         : fmt::format("set {} {}", ch.key, ch.value));
  const std::string shown = profile::format_value(*ch.row, ch.raw);
  const std::string text =
      ch.key == "address"
          ? fmt::format("address {} -> {} (talk to --unit {} from now on)", was, ch.value, ch.value)
      : ch.key == "baud" ? fmt::format("baud rate {} (talk at --baud {} from now on)", ch.value, ch.value)
      : ch.key == "mask" ? fmt::format("control mask {}", shown)
                         : fmt::format("pairing {}", shown);
  return VerbResult{fmt::format("config {}", ch.key), text,
                    Json{{std::string(ch.row->key), profile::entry_json(*ch.row, ch.raw)}}, nullptr};
}

}  // namespace

const std::vector<profile::Verb>& verb_table() {
  // Ranges, limits and value names from the rows and the machine's constants.
  const std::string speed = fmt::format("0..{} %", kMaxSpeed);
  const std::string plans = fmt::format("plan 1..{}", kPlanCount);
  const VerbArg plan_arg{"n", Form::positional, plans, true};
  std::string pairing;
  for (const profile::Named& n : kMap.row(reg::pairing).names) pairing += fmt::format("{}|", n.name);
  static const std::vector<Verb> verbs{
      {.name = "status",
       .help = "mode, state, speed, time, faults, temperatures, motor",
       .examples = {"{port}", "{port} --unit 12 --json"},
       .reads = true},
      {.name = "watch",
       .help = "live status, refreshed until Ctrl-C",
       .examples = {"{port}", "{port} --json --interval 1000 > swim.jsonl"},
       .reads = true,
       .live_interval_ms = 500},
      {.name = "start",
       .help = "start free mode, a timer run or a training plan",
       .args = {{"free", Form::flag, "free mode (counts up)"},
                {"timer", Form::option,
                 fmt::format("timer mode for DURATION (mm:ss, or with a unit: 30m, 90s; at most {})",
                             profile::format_mm_ss(static_cast<uint16_t>(timer_range().max)))},
                {"plan", Form::option, "training " + plans},
                {"speed", Form::option, "speed " + speed + " (free: default from memory)"},
                {"from", Form::option, "with --plan: start this far into the plan (mm:ss)"},
                {"remember", Form::flag,
                 "start after the 3 s initial delay and save speed/time as the mode's memory"}},
       .examples = {"{port} --free --speed 60", "{port} --timer 30:00 --speed 80 --remember",
                    "{port} --plan 1 --from 12:00"}},
      {.name = "pause", .help = "pause the run (motor stops, time freezes)", .examples = {"{port}"}},
      {.name = "resume", .help = "resume a paused run", .examples = {"{port}"}},
      {.name = "stop", .help = "stop the motor, machine off", .examples = {"{port}"}},
      {.name = "speed",
       .help = "set the running speed",
       .args = {{"speed", Form::positional, speed, true}},
       .examples = {"{port} 75"}},
      {.name = "plan show",
       .help = "print a plan (CSV, or --json)",
       .args = {plan_arg},
       .examples = {"{port} 1 > p1.csv", "{port} 1 --json > p1.json"},
       .reads = true},
      {.name = "plan set",
       .help = "write a plan from a CSV (speed,end per line) or JSON file",
       .args = {plan_arg,
                {"file", Form::positional, "plan file (what `plan show` prints, CSV or --json)", true}},
       .examples = {"{port} 2 p1.csv"}},
      {.name = "plan clear",
       .help = "reset a plan to the factory plan (" + factory_plan_text() + ")",
       .args = {plan_arg},
       .examples = {"{port} 4"}},
      {.name = "config",
       .help = "show or set address, baud, mask, pairing",
       .args = {{"what", Form::positional,
                 fmt::format("show | address A | baud B | mask M | pairing {}0..{}", pairing,
                             kMap.row(reg::pairing).names.size() - 1),
                 false, "show"},
                {"value", Form::positional, "the new value"}},
       .examples = {"{port}", "{port} baud 19200", "{port} address 12"},
       .reads = true},
  };
  return verbs;
}

Outcome<profile::VerbResult> run_verb(const profile::Verb& verb, const profile::VerbArgs& args,
                                      profile::VerbContext& context) {
  const std::string_view name = verb.name;
  if (name == "status") return status(context);
  if (name == "watch") return watch(context);
  if (name == "start") return start_verb(args, context);
  if (name == "pause" || name == "resume" || name == "stop" || name == "speed")
    return command(name, args, context);
  if (name.starts_with("plan ")) return plan_verb(name, args, context);
  if (name == "config") return config_verb(args, context);
  return rtukit::Status(Errc::invalid_argument, fmt::format("inverjet has no verb '{}'", name));
}

}  // namespace rtukit::inverjet
