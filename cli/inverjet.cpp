// `rtukit inverjet ...`: the Inverjet through its typed client. Values are
// checked here first (one clear line, exit 2), so nothing half-valid is sent;
// decoding uses the register table (devices/inverjet/registers.hpp).
#include <fmt/core.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/plan_file.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/profile/text.hpp"

namespace rtukit::cli {
namespace {

namespace ij = rtukit::inverjet;
using nlohmann::json;

struct JetArgs {
  LinkOptions link;
  std::string unit = "21";
  bool json = false;
};

void add_link(CLI::App& cmd, JetArgs& a, bool json_flag) {
  a.link.add_to(cmd, false, ij::kDefaultBaud);
  cmd.add_option("--unit,-u", a.unit, "the machine's address, 1..254")->capture_default_str();
  if (json_flag) cmd.add_flag("--json", a.json, "print JSON");
}

// A master and the typed client on the command's link.
struct Session {
  explicit Session(const JetArgs& a)
      : master(a.link.make_master()),
        jet(*master, UnitId{static_cast<uint8_t>(parse_number(a.unit, "unit", 1, 254))}),
        context(fmt::format("Inverjet {} on {}", jet.unit().value, master->describe())),
        stats(a.link.stats) {}
  ~Session() {
    if (stats) print_stats(*master);
  }
  // One line naming the failure. The client gives the Inverjet's reason for
  // an exception (04 has three causes); a refused argument is a usage error.
  [[noreturn]] void fail(const rtukit::Status& e, std::string_view what) {
    if (e.is_exception()) {
      std::string hint(e.reason() == e.name() ? std::string_view() : e.reason());
      if (hint.empty() && e.error().exception_code() == 0x02) hint = "a reserved register";
      if (hint.empty() && e.error().exception_code() == 0x03) hint = "a value out of range";
      throw Failure{kModbusException,
                    fmt::format("{}: {} refused: Modbus exception {:02X} ({}){}{}", context, what,
                                e.error().exception_code(), e.name(), hint.empty() ? "" : ": ", hint)};
    }
    if (e.code() == Errc::invalid_argument)
      throw Failure{kUsage, fmt::format("{}: {}: {}", context, what, e.reason())};
    cli::fail(e.error(), fmt::format("{}: {}", context, what));
  }
  void check(const rtukit::Status& e, std::string_view what) {
    if (e) fail(e, what);
  }

  std::unique_ptr<Master> master;
  ij::Client jet;
  std::string context;
  bool stats;
};

uint16_t parse_speed(const std::string& text) {
  return static_cast<uint16_t>(parse_number(text, "speed (%)", 0, ij::kMaxSpeed));
}

// "30:00", "1800": 0/1..5999 s.
uint16_t parse_duration(const std::string& text, std::string_view what, uint32_t min) {
  const Result<uint32_t> t = profile::parse_mm_ss(text);
  if (!t.ok()) throw Failure{kUsage, fmt::format("{} '{}' is not mm:ss or a number of seconds", what, text)};
  if (*t < min || *t > ij::kMaxTime)
    throw Failure{kUsage,
                  fmt::format("{} {} ({} s) is out of range {}..5999 s (99:59)", what, text, *t, min)};
  return static_cast<uint16_t>(*t);
}

unsigned parse_plan_number(const std::string& text) {
  return static_cast<unsigned>(parse_number(text, "plan", 1, ij::kPlanCount));
}

std::string version_text(uint32_t v) {
  return fmt::format("V{}.{}", v >> 16, v & 0xFFFF);
}

json status_json(const ij::MachineStatus& s) {
  json faults = json::array();
  for (auto n : s.fault_names()) faults.push_back(n);
  return json{{"mode", s.mode},
              {"mode_name", profile::name_of(ij::kMap.row(ij::reg::work_mode), s.mode)},
              {"state", s.state},
              {"state_name", s.state_name()},
              {"phase", ij::phase_name(s.phase())},
              {"family", ij::family_name(s.family())},
              {"speed", s.speed},
              {"run_time", s.run_time},
              {"run_time_text", profile::format_mm_ss(s.run_time)},
              {"faults", s.faults},
              {"fault_names", faults},
              {"mosfet_temperature_c", s.mosfet_c},
              {"motor_temperature_c", s.motor_c},
              {"current_a", s.current_a},
              {"rpm", s.rpm},
              {"bus_voltage_v", s.bus_v},
              {"versions",
               {{"display_software", version_text(s.display_software)},
                {"display_hardware", version_text(s.display_hardware)},
                {"driver_software", version_text(s.driver_software)},
                {"driver_hardware", version_text(s.driver_hardware)}}}};
}

std::string faults_text(const ij::MachineStatus& s) {
  std::string out;
  for (auto n : s.fault_names()) out += (out.empty() ? "" : ", ") + std::string(n);
  return out.empty() ? "none" : fmt::format("{} (0x{:04X})", out, s.faults);
}

std::string time_text(const ij::MachineStatus& s) {
  return fmt::format("{} {}", profile::format_mm_ss(s.run_time),
                     s.family() == ij::Family::timer ? "remaining" : "elapsed");
}

std::string status_panel(const ij::MachineStatus& s) {
  return fmt::format(
      "state     {} ({})   mode {}\n"
      "speed     {} %   motor {} rpm, {:.2f} A\n"
      "time      {}\n"
      "faults    {}\n"
      "temps     MOSFET {:.1f} degC, motor {:.1f} degC\n"
      "bus       {:.1f} V\n"
      "versions  display {} (hw {}), driver {} (hw {})\n",
      s.state_name(), s.state, profile::format_value(ij::kMap.row(ij::reg::work_mode), s.mode), s.speed,
      s.rpm, s.current_a, time_text(s), faults_text(s), s.mosfet_c, s.motor_c, s.bus_v,
      version_text(s.display_software), version_text(s.display_hardware), version_text(s.driver_software),
      version_text(s.driver_hardware));
}

std::string status_line(const ij::MachineStatus& s) {
  return fmt::format(
      "{:<17} speed {:>3} %  time {}  motor {} rpm {:.2f} A  MOSFET {:.1f} degC  motor {:.1f} degC  faults "
      "{}",
      s.state_name(), s.speed, time_text(s), s.rpm, s.current_a, s.mosfet_c, s.motor_c, faults_text(s));
}

int run_status(const JetArgs& a) {
  Session s(a);
  Result<ij::MachineStatus> st = s.jet.status();
  if (!st.ok()) s.fail(st.error(), "status");
  if (a.json)
    fmt::print("{}\n", status_json(*st).dump());
  else
    fmt::print("{}", status_panel(*st));
  return kOk;
}

int run_watch(const JetArgs& a, const WatchOptions& w) {
  Session s(a);
  const bool tty = ::isatty(STDOUT_FILENO) && !a.json;
  watch_loop(w, [&](unsigned n) {
    Result<ij::MachineStatus> st = s.jet.status();
    if (!st.ok()) {
      if (n == 0) s.fail(st.error(), "watch");  // nothing there: say so and leave
      fmt::print("{}\n",
                 st.error().code() == Errc::timeout ? "(no response)" : std::string(st.error().name()));
    } else if (a.json) {
      fmt::print("{}\n", status_json(*st).dump());
    } else if (tty) {
      fmt::print("\x1b[H\x1b[2J{} (every {} ms, Ctrl-C to stop)\n\n{}", s.context, w.interval_ms,
                 status_panel(*st));
    } else {
      fmt::print("{}\n", status_line(*st));
    }
  });
  return kOk;
}

struct StartArgs {
  bool free = false;
  std::string timer, plan, speed, from;
  bool remember = false;
};

int run_start(const JetArgs& a, const StartArgs& s) {
  if (s.free + !s.timer.empty() + !s.plan.empty() != 1)
    throw Failure{kUsage, "choose one of --free, --timer DURATION, --plan N"};
  if (!s.plan.empty() && (!s.speed.empty() || s.remember))
    throw Failure{kUsage, "a training plan sets its own speed (no --speed or --remember with --plan)"};
  if (!s.from.empty() && s.plan.empty()) throw Failure{kUsage, "--from goes with --plan"};
  if (!s.timer.empty() && s.speed.empty()) throw Failure{kUsage, "--timer needs --speed"};
  const uint16_t speed = s.speed.empty() ? 0 : parse_speed(s.speed);
  const uint16_t duration = s.timer.empty() ? 0 : parse_duration(s.timer, "timer", 1);
  const unsigned plan = s.plan.empty() ? 0 : parse_plan_number(s.plan);
  const uint16_t from = s.from.empty() ? 0 : parse_duration(s.from, "--from", 0);
  Session session(a);
  rtukit::Status e;
  std::string what;
  if (s.free) {
    e = s.speed.empty() ? session.jet.start_free_from_memory() : session.jet.start_free(speed, s.remember);
    what =
        s.speed.empty() ? "free mode (speed and time from memory)" : fmt::format("free mode at {} %", speed);
  } else if (!s.timer.empty()) {
    e = session.jet.start_timer(speed, duration, s.remember);
    what = fmt::format("timer mode, {} at {} %", profile::format_mm_ss(duration), speed);
  } else {
    e = session.jet.start_plan(plan, from);
    what = fmt::format("plan P{} from {}", plan, profile::format_mm_ss(from));
    if (e == Errc::invalid_argument)
      throw Failure{kUsage, fmt::format("{}: P{} has nothing to run from {} (see `plan show {}`)",
                                        session.context, plan, profile::format_mm_ss(from), plan)};
  }
  session.check(e, "start " + what);
  fmt::print("started {}{}\n", what, s.remember ? " (after 3 s; saved as memory)" : "");
  return kOk;
}

int run_simple(const JetArgs& a, const std::string& verb) {
  Session s(a);
  rtukit::Status e;
  if (verb == "pause") e = s.jet.pause();
  if (verb == "stop") e = s.jet.stop();
  if (verb == "resume") {
    e = s.jet.resume();
    if (e == Errc::invalid_argument) throw Failure{kUsage, s.context + ": resume: nothing is paused"};
  }
  s.check(e, verb);
  fmt::print("{}: ok\n", verb);
  return kOk;
}

int run_speed(const JetArgs& a, const std::string& value) {
  const uint16_t speed = parse_speed(value);
  Session s(a);
  s.check(s.jet.set_speed(speed), fmt::format("speed {} %", speed));
  fmt::print("speed {} %\n", speed);
  return kOk;
}

int run_plan_show(const JetArgs& a, const std::string& n) {
  const unsigned plan = parse_plan_number(n);
  Session s(a);
  Outcome<std::vector<ij::Segment>> segments = s.jet.read_plan(plan);
  if (!segments.ok()) s.fail(segments.error(), fmt::format("read plan P{}", plan));
  if (a.json) {
    json out = json::array();
    for (const auto& seg : *segments)
      out.push_back({{"speed", seg.speed}, {"end", profile::format_mm_ss(seg.end)}});
    fmt::print("{}\n", out.dump());
  } else {
    fmt::print("# plan P{}: {} segment(s)\n{}", plan, segments->size(), ij::plan_to_csv(*segments));
  }
  return kOk;
}

int run_plan_set(const JetArgs& a, const std::string& n, const std::string& file) {
  const unsigned plan = parse_plan_number(n);
  std::ifstream in(file);
  if (!in) throw Failure{kUsage, fmt::format("cannot read plan file '{}'", file)};
  std::stringstream text;
  text << in.rdbuf();
  Outcome<std::vector<ij::Segment>> segments = ij::parse_plan(text.str());
  if (!segments.ok()) throw Failure{kUsage, fmt::format("{}: {}", file, segments.error().reason())};
  Session s(a);
  s.check(s.jet.write_plan(plan, *segments), fmt::format("write plan P{}", plan));
  fmt::print("plan P{}: {} segment(s) written, ends at {}\n", plan, segments->size(),
             profile::format_mm_ss(segments->back().end));
  return kOk;
}

int run_plan_clear(const JetArgs& a, const std::string& n) {
  const unsigned plan = parse_plan_number(n);
  Session s(a);
  s.check(s.jet.clear_plan(plan), fmt::format("clear plan P{}", plan));
  fmt::print("plan P{}: factory plan (01:00 at 20 %)\n", plan);
  return kOk;
}

int run_config(const JetArgs& a, const std::string& what, const std::string& value) {
  if (what == "show" || what.empty()) {
    Session s(a);
    Result<ij::Config> c = s.jet.config();
    if (!c.ok()) s.fail(c.error(), "config");
    json out;
    for (const ij::ConfigValue& v : *c) {
      if (a.json)
        out[std::string(v.row->key)] = v.raw;
      else
        fmt::print("{:<14} {}\n", v.row->key, profile::format_value(*v.row, v.raw));
    }
    if (a.json) fmt::print("{}\n", out.dump());
    return kOk;
  }
  if (value.empty()) throw Failure{kUsage, fmt::format("config {} needs a value", what)};
  if (what == "address") {
    const auto address = static_cast<uint8_t>(parse_number(value, "address", 1, 254));
    Session s(a);
    s.check(s.jet.set_address(address), fmt::format("set address {}", address));
    fmt::print("address {} -> {} (talk to --unit {} from now on)\n", a.unit, address, address);
  } else if (what == "baud") {
    const auto baud = static_cast<uint32_t>(parse_number(value, "baud", 0, 1000000));
    if (ij::code_of_baud(baud) < 0)
      throw Failure{kUsage,
                    fmt::format("baud {}: the Inverjet runs at 1200, 2400, 4800, 9600 or 19200", baud)};
    Session s(a);
    s.check(s.jet.set_baud(baud), fmt::format("set baud {}", baud));
    fmt::print("baud rate {} (talk at --baud {} from now on)\n", baud, baud);
  } else if (what == "mask") {
    const auto mask = static_cast<uint16_t>(parse_number(value, "control mask", 0, 7));
    Session s(a);
    s.check(s.jet.set_control_mask(mask), fmt::format("set control mask {}", mask));
    fmt::print("control mask {}\n", profile::format_value(ij::kMap.row(ij::reg::control_mask), mask));
  } else if (what == "pairing") {
    const uint16_t mode = value == "off" ? 0 : value == "wifi" ? 1 : value == "remote" ? 2 : 0xFFFF;
    if (mode == 0xFFFF) throw Failure{kUsage, "pairing: off, wifi or remote"};
    Session s(a);
    s.check(s.jet.set_pairing(mode), "set pairing");
    fmt::print("pairing {}\n", profile::format_value(ij::kMap.row(ij::reg::pairing), mode));
  } else {
    throw Failure{kUsage, fmt::format("config {}: expected show, address, baud, mask or pairing", what)};
  }
  return kOk;
}

}  // namespace

void add_inverjet_commands(CLI::App& app, Action& action) {
  CLI::App* jet =
      app.add_subcommand("inverjet", "the Inverjet swimming machine (unit 21, 9600 8N1 by default)");
  jet->require_subcommand(1);

  {
    auto args = std::make_shared<JetArgs>();
    CLI::App* cmd = jet->add_subcommand("status", "mode, state, speed, time, faults, temperatures, motor");
    add_link(*cmd, *args, true);
    cmd->callback([&action, args] { action = [args] { return run_status(*args); }; });
  }
  {
    auto args = std::make_shared<JetArgs>();
    auto w = std::make_shared<WatchOptions>(WatchOptions{500});
    CLI::App* cmd = jet->add_subcommand("watch", "live status, refreshed until Ctrl-C");
    add_link(*cmd, *args, true);
    w->add_to(*cmd);
    cmd->callback([&action, args, w] { action = [=] { return run_watch(*args, *w); }; });
  }
  {
    auto args = std::make_shared<JetArgs>();
    auto s = std::make_shared<StartArgs>();
    CLI::App* cmd = jet->add_subcommand("start", "start free mode, a timer run or a training plan");
    add_link(*cmd, *args, false);
    cmd->add_flag("--free", s->free, "free mode (counts up)");
    cmd->add_option("--timer", s->timer, "timer mode for DURATION (mm:ss or seconds, 1..5999 s)");
    cmd->add_option("--plan", s->plan, "training plan 1..4");
    cmd->add_option("--speed", s->speed, "speed 0..100 % (free: default from memory)");
    cmd->add_option("--from", s->from, "with --plan: start this far into the plan (mm:ss)");
    cmd->add_flag("--remember", s->remember,
                  "start after the 3 s initial delay and save speed/time as the mode's memory");
    cmd->callback([&action, args, s] { action = [=] { return run_start(*args, *s); }; });
  }
  for (const char* verb : {"pause", "resume", "stop"}) {
    auto args = std::make_shared<JetArgs>();
    const std::string v = verb;
    CLI::App* cmd = jet->add_subcommand(v, v == "pause"    ? "pause the run (motor stops, time freezes)"
                                           : v == "resume" ? "resume a paused run"
                                                           : "stop the motor, machine off");
    add_link(*cmd, *args, false);
    cmd->callback([&action, args, v] { action = [=] { return run_simple(*args, v); }; });
  }
  {
    auto args = std::make_shared<JetArgs>();
    auto value = std::make_shared<std::string>();
    CLI::App* cmd = jet->add_subcommand("speed", "set the running speed");
    add_link(*cmd, *args, false);
    cmd->add_option("SPEED", *value, "0..100 %")->required();
    cmd->callback([&action, args, value] { action = [=] { return run_speed(*args, *value); }; });
  }
  {
    CLI::App* plan = jet->add_subcommand("plan", "training plans P1..P4");
    plan->require_subcommand(1);
    auto show_args = std::make_shared<JetArgs>();
    auto show_n = std::make_shared<std::string>();
    CLI::App* show = plan->add_subcommand("show", "print a plan (CSV, or --json)");
    add_link(*show, *show_args, true);
    show->add_option("N", *show_n, "plan 1..4")->required();
    show->callback(
        [&action, show_args, show_n] { action = [=] { return run_plan_show(*show_args, *show_n); }; });

    auto set_args = std::make_shared<JetArgs>();
    auto set_n = std::make_shared<std::string>();
    auto file = std::make_shared<std::string>();
    CLI::App* set = plan->add_subcommand("set", "write a plan from a CSV (speed,end per line) or JSON file");
    add_link(*set, *set_args, false);
    set->add_option("N", *set_n, "plan 1..4")->required();
    set->add_option("FILE", *file, "plan file")->required();
    set->callback([&action, set_args, set_n, file] {
      action = [=] { return run_plan_set(*set_args, *set_n, *file); };
    });

    auto clear_args = std::make_shared<JetArgs>();
    auto clear_n = std::make_shared<std::string>();
    CLI::App* clear = plan->add_subcommand("clear", "reset a plan to the factory plan (01:00 at 20 %)");
    add_link(*clear, *clear_args, false);
    clear->add_option("N", *clear_n, "plan 1..4")->required();
    clear->callback(
        [&action, clear_args, clear_n] { action = [=] { return run_plan_clear(*clear_args, *clear_n); }; });
  }
  {
    auto args = std::make_shared<JetArgs>();
    auto what = std::make_shared<std::string>("show");
    auto value = std::make_shared<std::string>();
    CLI::App* cmd = jet->add_subcommand("config", "show or set address, baud, mask, pairing");
    add_link(*cmd, *args, true);
    cmd->add_option("WHAT", *what, "show | address A | baud B | mask M | pairing off|wifi|remote")
        ->capture_default_str();
    cmd->add_option("VALUE", *value, "the new value");
    cmd->callback(
        [&action, args, what, value] { action = [=] { return run_config(*args, *what, *value); }; });
  }
}

}  // namespace rtukit::cli
