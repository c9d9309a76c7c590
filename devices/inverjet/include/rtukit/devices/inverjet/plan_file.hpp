// Training-plan files for `rtukit inverjet plan set`:
//  - CSV: one `speed,end` per line (end as mm:ss, or 90s / 30m: a bare number is
//    refused, profile::parse_duration); an optional
//    header line `speed,end`; blank lines and lines starting with # skipped.
//  - JSON: [{"speed": 40, "end": "05:00"}, ...] (end as text, the same forms).
// The format is chosen by the first non-blank character ('[' = JSON).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/devices/inverjet/machine.hpp"

namespace rtukit::inverjet {

/// Parses and validates (validate_plan) a plan: CSV (speed,end per line), a
/// JSON array of {"speed", "end"} (end as "mm:ss", "30m", "90s"), or the
/// document `rtukit inverjet plan show --json` prints (its "segments"). Errors: invalid_argument,
/// the reason naming the line (CSV) or entry (JSON): "line 3: end 00:50 is not after 01:00".
Outcome<std::vector<Segment>> parse_plan(std::string_view text);

/// The plan as CSV with a header (what `plan show` prints; parse_plan reads it back).
std::string plan_to_csv(const std::vector<Segment>& segments);

/// The plan as JSON: [{"speed", "end" ("05:00"), "end_s" (300)}, ...], what
/// `plan show --json` prints under "segments" (parse_plan reads it back).
nlohmann::ordered_json plan_json(const std::vector<Segment>& segments);

/// Reads the plan file `path` and parses it (parse_plan). A plan is 50
/// lines at most: a file larger than 64 KB, or one that is not a regular
/// file, is not a plan. io_error: the OS cannot read it ("cannot read plan
/// file 'p.csv'", the OS's error in the Error); invalid_argument: "cannot read
/// plan file 'p.csv': not a regular file", "p.csv: line 3: end 00:50 is not
/// after 01:00".
Outcome<std::vector<Segment>> read_plan_file(const std::string& path);

}  // namespace rtukit::inverjet
