// rtukit device profiles, host side: register values as people read and
// type them, and as JSON. Built on the map's decode/encode and scale, so a
// unit or a scale is written once, in the row.
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/register_map.hpp"

namespace rtukit::profile {

/// A value as a person reads it: "80 %", "30:00", "timer running (8)",
/// "voltage, motor drive" (bits; "none" for 0), "V1.2", "31.5 degC", "-5",
/// "on"/"off" (boolean). A choice value not listed: "unknown (9)".
std::string format_value(const Row& row, int64_t raw);

/// Text a person typed -> raw value, checked against the row's write range:
///  - a number in the row's unit ("31.5" for a 0.1-degC row), optionally
///    followed by the unit ("80%", "80 %"), or hex ("0x1F");
///  - a choice by name, case-insensitive, with '-', '_' and ' ' alike
///    ("outdoor", "timer-running"), or by number;
///  - bits as names joined by ',' or '|' ("bluetooth,wi-fi"), or a number;
///  - a duration as mm:ss or seconds ("30:00", "1800");
///  - a boolean as on/off, true/false, 1/0.
/// Errors: invalid_argument when the text is not a value of the row (the
/// reason lists the choices: "'fast' is not a drive_mode (normal, indoor,
/// outdoor)"); illegal_data_value when outside the write range ("speed: 120
/// is outside 0..100 %").
Outcome<int64_t> parse_value(const Row& row, std::string_view text);

/// A caller's argument checked before anything is sent: ok, or
/// invalid_argument with the row's terms ("speed: 120 is outside 0..100 %",
/// "baud: 7 is not one of 1200, 2400, ...").
Status check_argument(const Row& row, int64_t raw);

/// The name of a choice value or bit ("timer running"), or empty when not listed.
std::string_view name_of(const Row& row, int64_t value) noexcept;
/// The names of a row's flags: "persisted" first, then the device's own
/// (`Profile::flag_names`), then the kit's link flags ("link-address", "link-baud").
std::vector<std::string_view> flag_names(const Profile& profile, const Row& row);

/// The value for JSON: a number in the row's unit (scaled), a choice's name,
/// an array of bit names, "mm:ss" stays a number of seconds, a version "1.2".
nlohmann::json value_json(const Row& row, int64_t raw);

/// One register value in rtukit's JSON shape (docs/json.md):
/// {"value": value_json, "unit": the row's unit (absent when none; "s" for
/// mm:ss durations), "text": format_value, "raw": the register value}.
nlohmann::ordered_json entry_json(const Row& row, int64_t raw);

/// A value computed from registers, shaped like a register entry beside
/// them: {"value", "unit" (absent when empty), "text"}.
nlohmann::ordered_json quantity_json(nlohmann::ordered_json value, std::string_view unit, std::string text);

/// Length of the longest prefix of `s` that is valid UTF-8 in whole
/// characters (no overlong forms, surrogates or code points past U+10FFFF):
/// s.size() when all of it is. Text that goes into JSON must be valid UTF-8
/// (nlohmann::json::dump() throws otherwise), so outside text is checked with
/// this before it is kept or quoted.
size_t valid_utf8_prefix(std::string_view s) noexcept;
/// Outside text quoted in a reason: at most `max` bytes of whole UTF-8
/// characters, bytes that are not UTF-8 as '?' (safe to put into JSON).
std::string excerpt(std::string_view s, size_t max);

/// Bytes as hex pairs: "15 03 00 21" (frames in logs and descriptions).
std::string hex(std::span<const uint8_t> bytes);

/// mm:ss for a number of seconds ("30:00", "99:59").
std::string format_mm_ss(unsigned seconds);
/// A duration as a person types it, in the one form every front-end takes
/// (CLI, pool panel, MQTT bridge, plan files): "mm:ss" or "m:ss" ("30:00",
/// "1:30"; seconds 00..59), or a number with a unit: "30m", "90s", "1m30s".
/// A bare number is refused: "30" could be seconds or minutes, and a timer
/// of 30 s that a swimmer meant as 30 min ends the run at once.
/// Errors: invalid_argument with the reason and an example.
Result<uint32_t> parse_duration(std::string_view text) noexcept;

/// The canonical key for what a user typed: "drive-mode" -> "drive_mode".
std::string canonical_key(std::string_view typed);
/// The row a user named (either case style), or nullptr.
const Row* find_row(const RegisterMap& map, std::string_view typed);
/// The row whose key is nearest to a key that named none (at most 2 edits,
/// and fewer than a third of the key's letters: "sped" -> speed), for a
/// "did you mean" in the refusal; nullptr when none is that near, or two are.
const Row* nearest_row(const RegisterMap& map, std::string_view typed);

/// Lowercase word with '-' and ' ' as '_' (for comparing names a user typed).
std::string fold_name(std::string_view name);

/// The generic register reference of a profile as Markdown (one table per
/// space: address, key, title, access, unit, range, default, flags, values).
std::string registers_markdown(const Profile& profile);

/// The name of a space ("holding"), role ("setting"), encoding ("u16"),
/// access ("read_only") as written in map files.
std::string_view space_name(Space s) noexcept;
std::string_view role_name(Role r) noexcept;
std::string_view encoding_name(Encoding e) noexcept;
std::string_view access_name(Access a) noexcept;

}  // namespace rtukit::profile
