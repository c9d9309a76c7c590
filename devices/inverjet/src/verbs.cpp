// The Inverjet's verbs and status view: what every front-end shows and runs.
#include "rtukit/devices/inverjet/verbs.hpp"

#include <fmt/core.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "rtukit/devices/profile/text.hpp"

namespace rtukit::inverjet {
namespace {

using Json = nlohmann::json;

// {"value": ..., "unit"?: ..., "text": ...}: the shape of a computed entry
// beside the register entries (docs/json.md).
Json quantity(Json value, std::string_view unit, std::string text) {
  Json q{{"value", std::move(value)}};
  if (!unit.empty()) q["unit"] = unit;
  q["text"] = std::move(text);
  return q;
}

// A JSON integer 0..65535. Text ("55") is a wrong type: one form per field.
std::optional<uint16_t> small_number(const Json& v) {
  if (v.is_number_unsigned() && v.get<uint64_t>() <= 0xFFFF) return static_cast<uint16_t>(v.get<uint64_t>());
  return std::nullopt;
}

// "0..100" from a row's writable range, as the refusals say it.
std::string range_of(profile::Handle h) {
  const profile::Range r = kMap.row(h).write_range();
  return fmt::format("{}..{}", r.min, r.max);
}

}  // namespace

// ---------------------------------------------------------------- the view

std::string_view time_counts_name(TimeCounts t) noexcept {
  switch (t) {
    case TimeCounts::remaining:
      return "remaining";
    case TimeCounts::unknown:
      return "at the fault";
    default:
      return "elapsed";
  }
}

Family time_family(const MachineStatus& s, Family remembered) noexcept {
  if (s.family() != Family::none) return s.family();
  if (plan_of(s)) return Family::training;  // a plan's time counts up
  return remembered;
}

TimeCounts time_counts(const MachineStatus& s, Family remembered) noexcept {
  switch (time_family(s, remembered)) {
    case Family::timer:
      return TimeCounts::remaining;
    case Family::none:
      return s.phase() == Phase::fault ? TimeCounts::unknown : TimeCounts::elapsed;
    default:
      return TimeCounts::elapsed;
  }
}

Family remember_family(const MachineStatus& s, Family remembered) noexcept {
  if (s.family() != Family::none) return s.family();
  return s.phase() == Phase::off ? Family::none : remembered;
}

std::optional<unsigned> plan_of(const MachineStatus& s) noexcept {
  // The work mode's value names are "plan P1".."plan P4" for 1..kPlanCount.
  if (s.mode >= 1 && s.mode <= kPlanCount) return s.mode;
  return std::nullopt;
}

Json status_values(const MachineStatus& s, Family remembered) {
  Json v = Json::object();
  const auto reg = [&v](profile::Handle h, int64_t raw) {
    const profile::Row& r = kMap.row(h);
    v[std::string(r.key)] = profile::entry_json(r, raw);
  };
  // A measured value back to its register's raw value, through the row's scale.
  const auto measured = [&reg](profile::Handle h, double value) {
    const Result<int64_t> raw = profile::RegisterMap::from_number(kMap.row(h), value);
    reg(h, raw ? *raw : 0);
  };
  const auto named = [&v](const char* key, std::string_view value) {
    v[key] = quantity(std::string(value), {}, std::string(value));
  };
  reg(reg::work_mode, s.mode);
  reg(reg::state, s.state);
  named("phase", phase_name(s.phase()));
  named("family", family_name(s.family()));
  reg(reg::speed, s.speed);
  reg(reg::run_time, s.run_time);
  named("run_time_counts", time_counts_name(time_counts(s, remembered)));
  reg(reg::faults, s.faults);
  measured(kMap.handle("mosfet_temperature"), s.mosfet_c);
  measured(kMap.handle("motor_temperature"), s.motor_c);
  measured(kMap.handle("motor_current"), s.current_a);
  reg(reg::motor_speed, s.rpm_x_poles);
  v["rpm"] = quantity(s.rpm, "rpm", fmt::format("{} rpm", s.rpm));
  measured(kMap.handle("bus_voltage"), s.bus_v);
  reg(reg::display_software, s.display_software);
  reg(reg::display_hardware, s.display_hardware);
  reg(reg::driver_software, s.driver_software);
  reg(reg::driver_hardware, s.driver_hardware);
  return v;
}

uint16_t jet_speed(const MachineStatus& s) noexcept {
  const Phase p = s.phase();
  return p == Phase::starting || p == Phase::running ? s.speed : 0;
}

std::string_view fault_advice(unsigned bit) noexcept {
  for (const Named& a : detail::kFaultAdvice)
    if (a.value == bit) return a.name;
  return "a fault we cannot name: call service";
}

Actions allowed_actions(const MachineStatus& s) noexcept {
  const Phase p = s.phase();
  Actions a;
  a.start = p != Phase::fault;  // B-3: nothing starts the motor from the fault screen
  a.pause = p == Phase::starting || p == Phase::running;
  a.resume = p == Phase::paused;
  a.stop = p != Phase::off;
  a.speed = p == Phase::starting || p == Phase::running || p == Phase::paused;
  return a;
}

Json limits_document() {
  const profile::Range speed = kMap.row(reg::speed).write_range();
  return Json{{"plans", kPlanCount},
              {"segments", kSegmentsPerPlan},
              {"speed", {{"min", speed.min}, {"max", speed.max}}},
              {"time_max_s", kMaxTime},
              {"time_max", profile::format_mm_ss(kMaxTime)},
              {"fast_speed", kFastSpeed}};
}

std::string_view failure_code(Failure f) noexcept {
  switch (f) {
    case Failure::invalid:
      return "invalid";
    case Failure::fault:
      return "fault";
    case Failure::masked:
      return "masked";
    case Failure::wrong_state:
      return "wrong_state";
    case Failure::refused:
      return "refused";
    case Failure::no_answer:
      return "no_answer";
    case Failure::busy:
      return "busy";
  }
  return "refused";
}

Failure classify_failure(const rtukit::Status& e) noexcept {
  const std::string_view why = e.reason();
  if (why.starts_with(kNothingPausedReason)) return Failure::wrong_state;
  if (e.is_exception()) {
    switch (e.error().exception_code()) {
      case 0x01:
      case 0x02:
      case 0x03:
        return Failure::invalid;
      case 0x06:
        return Failure::busy;
      case 0x04:
        if (why.starts_with(kFaultScreenReason)) return Failure::fault;
        if (why.starts_with(kMaskedReason)) return Failure::masked;
        if (why.starts_with(kWrongStateReason)) return Failure::wrong_state;
        return Failure::refused;
      default:
        return Failure::refused;
    }
  }
  switch (e.code()) {
    case Errc::invalid_argument:
      return Failure::invalid;
    case Errc::timeout:
    case Errc::bad_crc:
    case Errc::malformed:
    case Errc::unexpected_response:
    case Errc::io_error:
    case Errc::not_connected:
      return Failure::no_answer;
    default:
      return Failure::refused;
  }
}

std::string_view failure_advice(Failure f) noexcept {
  switch (f) {
    case Failure::invalid:
      return "The machine did not accept the values: check the speed and the time.";
    case Failure::fault:
      return "The machine shows a fault: see the fault box for what to do; it can start again once the fault "
             "is cleared.";
    case Failure::masked:
      return "The machine ignores remote control right now (control mask): use its own buttons, or ask the "
             "pool staff.";
    case Failure::wrong_state:
      return "The machine is not in a state for that: look at the state above and use the matching button.";
    case Failure::refused:
      return "The machine refused: check its display; press Stop on the machine if in doubt.";
    case Failure::no_answer:
      return "The machine did not answer: check its power and cable. To stop it, press Stop on the machine "
             "itself.";
    case Failure::busy:
      return "Too many commands at once: wait a moment and try again.";
  }
  return "";
}

void describe_failure(const rtukit::Status& e, Json& result) {
  const Failure f = classify_failure(e);
  result["ok"] = false;
  result["error"] = e.is_exception() ? fmt::format("Modbus exception {:02X} ({}): {}",
                                                   e.error().exception_code(), e.name(), e.reason())
                                     : std::string(e.reason());
  result["code"] = std::string(failure_code(f));
  result["advice"] = std::string(failure_advice(f));
}

void describe_busy(std::string_view why, Json& result) {
  result["ok"] = false;
  result["error"] = std::string(why);
  result["code"] = std::string(failure_code(Failure::busy));
  result["advice"] = std::string(failure_advice(Failure::busy));
}

Json state_document(const MachineStatus& s, Family remembered) {
  Json faults = Json::array();
  Json advice = Json::array();
  for (const Named& bit : fault_names()) {
    if (!(s.faults & (1U << bit.value))) continue;
    faults.push_back(std::string(bit.name));
    advice.push_back({{"fault", std::string(bit.name)}, {"advice", std::string(fault_advice(bit.value))}});
  }
  const Actions allowed = allowed_actions(s);
  const TimeCounts counts = time_counts(s, remembered);
  const std::optional<unsigned> plan = plan_of(s);
  const bool timer = time_family(s, remembered) == Family::timer;
  const bool off = s.phase() == Phase::off;
  return Json{{"mode", off     ? "off"
                       : plan  ? fmt::format("plan {}", *plan)
                       : timer ? "timer"
                               : "free"},
              {"mode_raw", s.mode},
              {"state", std::string(s.state_name())},
              {"state_raw", s.state},
              {"running", s.phase() == Phase::running},
              {"speed", s.speed},
              {"jet_speed", jet_speed(s)},
              {"time", profile::format_mm_ss(s.run_time)},
              {"time_counts", time_counts_name(counts)},
              {"remaining_s", counts == TimeCounts::remaining ? Json(s.run_time) : Json(nullptr)},
              {"elapsed_s", counts == TimeCounts::elapsed ? Json(s.run_time) : Json(nullptr)},
              {"faults", faults},
              {"fault", !faults.empty()},
              {"fault_advice", advice},
              {"allowed",
               {{"start", allowed.start},
                {"pause", allowed.pause},
                {"resume", allowed.resume},
                {"stop", allowed.stop},
                {"speed", allowed.speed}}},
              {"mosfet_c", s.mosfet_c},
              {"motor_c", s.motor_c},
              {"current_a", s.current_a},
              {"rpm", s.rpm},
              {"bus_v", s.bus_v},
              {"plan_select", plan ? fmt::format("Plan {}", *plan) : ""},
              {"versions",
               {{"display_software", s.display_software},
                {"display_hardware", s.display_hardware},
                {"driver_software", s.driver_software},
                {"driver_hardware", s.driver_hardware}}}};
}

// ---------------------------------------------------------------- the identity

rtukit::Status identify(Master& master, UnitId unit) {
  const profile::Row& r = kMap.row(reg::pole_count);
  const auto fixed = static_cast<uint16_t>(r.writable_range.min);
  uint16_t value = 0;
  const Error e = master.read_holding_registers(unit, r.address, {&value, 1});
  if (e && !e.is_exception()) return e;  // no answer, the port: as for any request
  if (!e && value == fixed) return {};
  const std::string got =
      e ? fmt::format("answers Modbus exception {:02X} ({})", e.exception_code(), e.name())
        : fmt::format("reads {}", value);
  return rtukit::Status(
      Errc::refused,
      fmt::format("not an Inverjet: its {} (holding 0x{:04X}) {} where an Inverjet's always reads {}",
                  r.title, r.address, got, fixed));
}

std::string exception_reason(const rtukit::Status& e) {
  if (!e.is_exception()) return {};
  if (e.reason() != e.name()) return std::string(e.reason());
  if (e.error().exception_code() == 0x02) return "a reserved register";
  if (e.error().exception_code() == 0x03) return "a value out of range";
  return {};
}

// ---------------------------------------------------------------- the start

profile::Range timer_range() noexcept {
  return {1, kMap.row(reg::timer_time).write_range().max};
}

profile::Range from_range() noexcept {
  return {0, kMaxTime};
}

rtukit::Status check_start(const StartRequest& r) {
  const auto refuse = [](std::string why) { return rtukit::Status(Errc::invalid_argument, std::move(why)); };
  const auto span = [](profile::Range range) {
    return fmt::format("{}..{}", profile::format_mm_ss(static_cast<unsigned>(range.min)),
                       profile::format_mm_ss(static_cast<unsigned>(range.max)));
  };
  switch (r.mode) {
    case StartMode::free:
      return {};  // no speed: the machine's memory (and nothing new to remember)
    case StartMode::timer:
      if (!r.speed)
        return refuse(fmt::format("timer: \"speed\" is required, a whole number {}", range_of(reg::speed)));
      if (!timer_range().contains(r.duration_s))
        return refuse(fmt::format("timer: \"duration\" must be {}", span(timer_range())));
      return {};
    case StartMode::plan:
      if (r.plan < 1 || r.plan > kPlanCount)
        return refuse(fmt::format("plan: \"plan\" 1..{} is required", kPlanCount));
      if (r.speed || r.remember)
        return refuse("plan: a training plan sets its own speed (no speed, no remember)");
      if (!from_range().contains(r.from_s))
        return refuse(fmt::format("plan: \"from\" must be {}", span(from_range())));
      return {};
  }
  return refuse("start: mode must be free, timer or plan");
}

rtukit::Status start(Client& client, const StartRequest& r) {
  if (rtukit::Status e = check_start(r)) return e;
  switch (r.mode) {
    case StartMode::free:
      return r.speed ? client.start_free(*r.speed, r.remember) : client.start_free_from_memory();
    case StartMode::timer:
      return client.start_timer(*r.speed, r.duration_s, r.remember);
    case StartMode::plan:
      return client.start_plan(r.plan, r.from_s);
  }
  return Errc::invalid_argument;
}

std::string start_text(const StartRequest& r) {
  switch (r.mode) {
    case StartMode::free:
      return r.speed ? fmt::format("free mode at {} %", *r.speed) : "free mode (speed and time from memory)";
    case StartMode::timer:
      return fmt::format("timer mode, {} at {} %", profile::format_mm_ss(r.duration_s), r.speed.value_or(0));
    case StartMode::plan:
      return fmt::format("plan P{} from {}", r.plan, profile::format_mm_ss(r.from_s));
  }
  return {};
}

rtukit::Status check_start_options(const StartOptions& o) {
  const auto refuse = [](const char* why) { return rtukit::Status(Errc::invalid_argument, why); };
  if (o.free + o.timer + o.plan != 1) return refuse("choose one of --free, --timer DURATION, --plan N");
  if (o.plan && (o.speed || o.remember))
    return refuse("a training plan sets its own speed (no --speed or --remember with --plan)");
  if (o.from && !o.plan) return refuse("--from goes with --plan");
  if (o.timer && !o.speed) return refuse("--timer needs --speed");
  return {};
}

Outcome<uint16_t> parse_run_duration(std::string_view text, std::string_view what, profile::Range range) {
  const Result<uint32_t> t = profile::parse_duration(text);
  if (!t.ok())
    return rtukit::Status(Errc::invalid_argument, fmt::format("{} '{}': {}", what, text, t.error().reason()));
  if (!range.contains(*t))
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("{} {} ({} s) is out of range {}..{} s ({})", what, text, *t, range.min,
                                      range.max, profile::format_mm_ss(static_cast<unsigned>(range.max))));
  return static_cast<uint16_t>(*t);
}

// ---------------------------------------------------------------- the verbs

std::string command_example(std::string_view name) {
  if (name == "start") return R"({"mode": "timer", "speed": 60, "duration": "30:00", "ts": 1764100000})";
  if (name == "pause" || name == "resume" || name == "stop") return R"({"ts": 1764100000})";
  if (name == "speed") return R"({"speed": 55, "ts": 1764100000})";
  if (name == "plan")
    return R"({"plan": 2, "segments": [{"speed": 40, "end": "05:00"}, {"speed": 70, "end": "10:00"}], "ts": 1764100000})";
  return {};
}

rtukit::Status run_command(Client& client, std::string_view name_view, const Json& body, Json& result) {
  const std::string name(name_view);
  const auto refuse = [&](std::string why) { return rtukit::Status(Errc::invalid_argument, std::move(why)); };
  if (!body.is_object()) return refuse(fmt::format("{}: expected a JSON object", profile::excerpt(name, 40)));
  const std::string speeds = range_of(reg::speed);
  const std::string plans = fmt::format("1..{}", kPlanCount);
  const auto duration = [&](const char* key, std::optional<uint32_t>& out) -> rtukit::Status {
    const Json& v = body[key];
    if (!v.is_string())
      return refuse(fmt::format("\"{}\": a duration as text: \"30:00\", \"30m\" or \"90s\"", key));
    const Result<uint32_t> s = profile::parse_duration(v.get<std::string>());
    if (!s)
      return refuse(fmt::format("\"{}\" '{}': {}", key, profile::excerpt(v.get<std::string>(), 20),
                                s.error().reason()));
    out = *s;
    return {};
  };
  // A speed's range is checked by the typed client (its refusal names the
  // row's range); here only its form.
  const auto speed_of = [&](const Json& v) { return small_number(v); };
  const auto plan_number = [&]() -> std::optional<uint16_t> {
    const std::optional<uint16_t> plan = body.contains("plan") ? small_number(body["plan"]) : std::nullopt;
    return plan && *plan >= 1 && *plan <= kPlanCount ? plan : std::nullopt;
  };
  if (name == "pause") return client.pause();
  if (name == "resume") return client.resume();
  if (name == "stop") return client.stop();
  if (name == "speed") {
    const std::optional<uint16_t> speed = body.contains("speed") ? speed_of(body["speed"]) : std::nullopt;
    if (!speed) return refuse(fmt::format("speed: \"speed\" is required, a whole number {}", speeds));
    return client.set_speed(*speed);
  }
  if (name == "start") {
    // value() throws on a "mode" that is not text ({"mode": 1}), which ended
    // the bridge's or the panel's bus thread (found by fuzz_mqtt_command).
    if (!body.contains("mode") || !body["mode"].is_string())
      return refuse("start: \"mode\" is required: \"free\", \"timer\" or \"plan\"");
    const std::string mode = body["mode"].get<std::string>();
    // The form of each field here; the rules of a start are start()'s (check_start).
    StartRequest r;
    if (mode == "free") {
      if (body.contains("speed")) {
        r.speed = speed_of(body["speed"]);
        if (!r.speed)
          return refuse(fmt::format(
              "free: \"speed\" must be a whole number {} (leave it out: the remembered speed)", speeds));
      }
      return start(client, r);
    }
    if (mode == "timer") {
      r.mode = StartMode::timer;
      r.speed = body.contains("speed") ? speed_of(body["speed"]) : std::nullopt;
      if (!r.speed) return refuse(fmt::format("timer: \"speed\" is required, a whole number {}", speeds));
      if (!body.contains("duration")) return refuse("timer: \"duration\" is required, for example \"30:00\"");
      std::optional<uint32_t> seconds;
      if (rtukit::Status e = duration("duration", seconds)) return e;
      if (!timer_range().contains(*seconds))
        return refuse(fmt::format("timer: \"duration\" must be 00:01..{}", profile::format_mm_ss(kMaxTime)));
      r.duration_s = static_cast<uint16_t>(*seconds);
      return start(client, r);
    }
    if (mode == "plan") {
      r.mode = StartMode::plan;
      const std::optional<uint16_t> plan = plan_number();
      if (!plan) return refuse(fmt::format("plan: \"plan\" {} is required", plans));
      std::optional<uint32_t> from = 0;
      if (body.contains("from"))
        if (rtukit::Status e = duration("from", from)) return e;
      if (!from_range().contains(*from))
        return refuse(fmt::format("plan: \"from\" must be 00:00..{}", profile::format_mm_ss(kMaxTime)));
      r.plan = *plan;
      r.from_s = static_cast<uint16_t>(*from);
      return start(client, r);
    }
    return refuse(
        fmt::format("start: mode must be free, timer or plan, not '{}'", profile::excerpt(mode, 20)));
  }
  if (name == "plan") {
    if (!body.contains("segments") || !body["segments"].is_array())
      return refuse(fmt::format(
          "plan: expected {{\"plan\": {}, \"segments\": [{{\"speed\": {}, \"end\": \"mm:ss\"}}, ...]}}",
          plans, speeds));
    const std::optional<uint16_t> plan = plan_number();
    if (!plan) return refuse(fmt::format("plan: \"plan\" {} is required", plans));
    std::vector<Segment> segments;
    for (const Json& s : body["segments"]) {
      const std::string at = fmt::format("plan: segment {}", segments.size() + 1);
      if (!s.is_object() || !s.contains("speed") || !s.contains("end"))
        return refuse(at + " needs \"speed\" and \"end\"");
      const std::optional<uint16_t> speed = small_number(s["speed"]);
      if (!speed) return refuse(fmt::format("{}: \"speed\" must be a whole number {}", at, speeds));
      const Result<uint32_t> end = s["end"].is_string() ? profile::parse_duration(s["end"].get<std::string>())
                                                        : Result<uint32_t>(Error(Errc::invalid_argument, ""));
      if (!end || *end > 0xFFFF)
        return refuse(at + ": \"end\" must be a duration as text: \"05:00\", \"5m\" or \"90s\"");
      segments.push_back({*speed, static_cast<uint16_t>(*end)});
    }
    // validate_plan checks speeds and ends against the plan rows' ranges.
    if (rtukit::Status e = validate_plan(segments)) return e;
    if (rtukit::Status e = client.write_plan(*plan, segments)) return e;
    result["segments"] = segments.size();
    return {};
  }
  return refuse(fmt::format("unknown command '{}'", profile::excerpt(name, 40)));
}

}  // namespace rtukit::inverjet
