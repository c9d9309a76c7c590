// What a person types, read by the rules every front-end uses. The pool
// panel's page once had its own duration parser, which had drifted from
// profile::parse_duration: it took "30M", which the CLI and the panel's own
// commands refuse, and called "100:00" no time at all where it is a time out
// of range.
#include "rtukit/devices/inverjet/typed.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <charconv>

#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/profile/text.hpp"

namespace rtukit::inverjet {
namespace {

using Json = nlohmann::json;

constexpr std::string_view kTimeForms = "write 30:00, 30m or 90s";

std::string_view trimmed(std::string_view t) {
  while (!t.empty() && (t.front() == ' ' || t.front() == '\t')) t.remove_prefix(1);
  while (!t.empty() && (t.back() == ' ' || t.back() == '\t')) t.remove_suffix(1);
  return t;
}

bool all_digits(std::string_view t) {
  return !t.empty() && std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// A field's text: a JSON string, or a number (a page may send one); any
// other value as JSON text, so it is refused as what it is ("1.5", "true"),
// not as an empty field. Null or missing: nothing typed.
std::optional<std::string> text_of(const Json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_integer()) return std::to_string(v.get<int64_t>());
  if (v.is_null()) return std::nullopt;
  return v.dump(-1, ' ', false, Json::error_handler_t::replace);
}

Json number_or_null(const std::optional<uint32_t>& v) {
  return v ? Json(*v) : Json(nullptr);
}

Json check_segments(const Json& rows) {
  Json out{{"why", ""}, {"row", -1}, {"field", ""}, {"segments", Json::array()}};
  const auto refuse = [&out](std::string why, int row, std::string_view field) {
    if (!out["why"].get<std::string>().empty()) return;  // the first thing wrong
    out["why"] = std::move(why);
    out["row"] = row;
    out["field"] = field;
  };
  if (!rows.is_array() || rows.empty() || rows.size() > kSegmentsPerPlan)
    refuse(fmt::format("a plan has 1 to {} segments", kSegmentsPerPlan), -1, "");
  if (!rows.is_array()) return out;
  uint32_t before = 0;
  for (size_t i = 0; i < rows.size() && i < kSegmentsPerPlan; ++i) {
    const Json& r = rows[i];
    const std::optional<std::string> speed_text =
        r.is_object() && r.contains("speed") ? text_of(r["speed"]) : std::nullopt;
    const std::optional<std::string> end_text =
        r.is_object() && r.contains("end") ? text_of(r["end"]) : std::nullopt;
    const TypedValue speed = read_speed_text(speed_text.value_or(""));
    const TypedValue end = read_time_text(end_text.value_or(""), "End");
    const int row = static_cast<int>(i);
    if (!speed.why.empty()) refuse(fmt::format("segment {}: {}", i + 1, speed.why), row, "speed");
    if (!end.why.empty()) refuse(fmt::format("segment {}: {}", i + 1, end.why), row, "end");
    if (end.value && *end.value <= before)
      refuse(fmt::format("segment {}: end {} is not after {}", i + 1, profile::format_mm_ss(*end.value),
                         profile::format_mm_ss(before)),
             row, "end");
    if (end.value) before = std::max(before, *end.value);
    out["segments"].push_back({{"speed", number_or_null(speed.value)}, {"end_s", number_or_null(end.value)}});
  }
  return out;
}

Json check_start(const Json& s) {
  Json out{{"why", ""}, {"field", ""}};
  const auto refuse = [&out](std::string why, std::string_view field) {
    out["why"] = std::move(why);
    out["field"] = field;
    return out;
  };
  if (!s.is_object() || !s.contains("mode") || !s["mode"].is_string())
    return refuse("Choose how to start: free, timer or a plan.", "");
  const std::string mode = s["mode"].get<std::string>();
  if (mode == "plan") {
    const bool number = s.contains("plan") && s["plan"].is_number_integer();
    const int64_t plan = number ? s["plan"].get<int64_t>() : 0;
    if (plan < 1 || plan > kPlanCount)
      return refuse(fmt::format("Choose a plan, 1 to {}.", kPlanCount), "plan");
    out["fields"] = {{"mode", "plan"}, {"plan", plan}};
    return out;
  }
  if (mode != "free" && mode != "timer") return refuse("Choose how to start: free, timer or a plan.", "");
  const std::optional<std::string> speed_text = s.contains("speed") ? text_of(s["speed"]) : std::nullopt;
  const TypedValue speed = read_speed_text(speed_text.value_or(""));
  if (!speed.value) return refuse(speed.why, "speed");
  out["fields"] = {{"mode", mode}, {"speed", *speed.value}};
  if (mode == "timer") {
    const std::optional<std::string> time_text =
        s.contains("duration") ? text_of(s["duration"]) : std::nullopt;
    const TypedValue time = read_time_text(time_text.value_or(""), "Time");
    if (!time.value) {
      out.erase("fields");
      return refuse(time.why, "duration");
    }
    out["fields"]["duration"] = profile::format_mm_ss(*time.value);
  }
  return out;
}

}  // namespace

TypedValue read_speed_text(std::string_view text) {
  const profile::Range range = kMap.row(reg::speed).write_range();
  std::string_view t = trimmed(text);
  const std::string shown(profile::excerpt(t, 20));
  if (t.ends_with('%')) t = trimmed(t.substr(0, t.size() - 1));
  if (t.empty())
    return {.why = fmt::format("Speed is empty: enter {} to {} %, for example 60.", range.min, range.max)};
  uint32_t v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.size() > 3 || ec != std::errc{} || end != t.data() + t.size() || !range.contains(v))
    return {.why =
                fmt::format("Speed \"{}\" is not {} to {} %: for example 60.", shown, range.min, range.max)};
  return {.value = v};
}

TypedValue read_time_text(std::string_view text, std::string_view what) {
  const std::string_view t = trimmed(text);
  const std::string shown(profile::excerpt(t, 20));
  if (t.empty()) return {.why = fmt::format("{} is empty: {}.", what, kTimeForms)};
  if (all_digits(t)) return {.why = fmt::format("{} \"{}\" has no unit: {}.", what, shown, kTimeForms)};
  const Result<uint32_t> s = profile::parse_duration(t);
  if (!s) return {.why = fmt::format("{} \"{}\" is not a time: {}.", what, shown, kTimeForms)};
  if (*s < 1 || *s > kMaxTime)
    return {.why = fmt::format("{} {} is out of range: 00:01 to {}.", what, shown,
                               profile::format_mm_ss(kMaxTime))};
  return {.value = *s};
}

Json check_typed(const Json& request) {
  if (!request.is_object()) return Json{{"why", "nothing to check: expected a JSON object"}};
  if (request.contains("segments")) return check_segments(request["segments"]);
  if (request.contains("start")) return check_start(request["start"]);
  if (request.contains("speed")) {
    const std::optional<std::string> t = text_of(request["speed"]);
    const TypedValue v = read_speed_text(t.value_or(""));
    Json out{{"why", v.why}};
    if (v.value) out["speed"] = *v.value;
    return out;
  }
  return Json{{"why", "nothing to check: expected \"speed\", \"start\" or \"segments\""}};
}

}  // namespace rtukit::inverjet
