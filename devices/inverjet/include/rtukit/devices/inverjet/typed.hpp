// rtukit Inverjet: what a person types into a page's fields (a speed, a
// time, a plan's rows, a start), read by the machine's rules once. The pool
// panel's page sends what was typed ({"op": "check", ...}) and shows the
// answer; it parses nothing itself, so the page, the CLI (the same
// profile::parse_duration and rows) and the panel's commands never disagree
// on what "30m" or "100:00" means. The refusals are in a swimmer's words.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

namespace rtukit::inverjet {

/// One field as typed: its value when it reads, else why not.
struct TypedValue {
  std::optional<uint32_t> value;
  std::string why;  ///< "" when it reads
};

/// A speed in % within the speed row's write range, spaces and a trailing
/// "%" allowed ("60", " 60 % "). Refusals: 'Speed is empty: enter 0 to 100
/// %, for example 60.', 'Speed "x" is not 0 to 100 %: for example 60.'.
TypedValue read_speed_text(std::string_view text);

/// A time as profile::parse_duration reads it ("30:00", "30m", "90s",
/// "1m30s"; spaces around it ignored) within 00:01..99:59 (kMaxTime).
/// `what` names the field ("Time", "End"). Refusals: 'Time is empty: write
/// 30:00, 30m or 90s.', 'Time "5" has no unit: ...', 'Time "x" is not a
/// time: ...', 'Time 100:00 is out of range: 00:01 to 99:59.'.
TypedValue read_time_text(std::string_view text, std::string_view what);

/// The answer to a page's check of what it typed, by what the request holds:
///  {"speed": text}   -> {"why", "speed"?}
///  {"start": {"mode": "free"|"timer"|"plan", "speed": text, "duration":
///   text, "plan": 1..kPlanCount}} -> {"why", "field" ("speed", "duration",
///   "plan" or ""), "fields"?: the start's body for run_command when right}
///  {"segments": [{"speed": text, "end": text}, ...]} -> {"why" (the first
///   thing wrong, "" when the plan is right: a plan has 1..50 segments, each
///   speed reads, each end reads and is after the one before), "row"
///   (0-based, -1 for the plan as a whole), "field" ("speed", "end" or ""),
///   "segments": each row as it reads, {"speed": n|null, "end_s": n|null}}
/// Anything else: {"why": "nothing to check: ..."}. Never throws on any JSON.
nlohmann::json check_typed(const nlohmann::json& request);

}  // namespace rtukit::inverjet
