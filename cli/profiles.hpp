// rtukit CLI: reading and printing registers by name, through a profile.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "common.hpp"
#include "rtukit/devices/profile/reading.hpp"
#include "rtukit/devices/profile/schema.hpp"

namespace rtukit::cli {

// Selecting, reading and showing entries as JSON: the kit's (profile/reading.hpp).
using profile::ReadValue;
using profile::Selected;

/// "key = 80 %" lines, or the JSON document (docs/json.md): {"time", "ok",
/// "device", "unit", "values": {key: entry}}; an entry that failed is {"error": ...}.
void print_values(const profile::Profile& p, UnitId unit, std::span<const ReadValue> values, bool json);

/// Loads a map file or throws Failure (kUsage with the line-numbered reason,
/// kIoError when unreadable). The profile lives until the process ends.
const profile::Profile& load_map_or_fail(const std::string& path);

/// `rtukit read --map FILE [KEY...]`.
int run_map_read(const LinkOptions& link, const std::string& unit, const std::string& map_file,
                 std::span<const std::string> keys, bool json);

}  // namespace rtukit::cli
