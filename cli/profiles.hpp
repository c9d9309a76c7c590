// rtukit CLI: reading and printing registers by name, through a profile.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "common.hpp"
#include "rtukit/devices/profile/schema.hpp"

namespace rtukit::cli {

/// One entry of a row: the row and, for a repeated block, which entry.
struct Selected {
  const profile::Row* row;
  unsigned index = 0;
};

/// The entries named by `keys` ("speed", "p1_speed[3]", "p1_speed" = every
/// entry); no keys: every readable entry. Throws Failure{kUsage} for an
/// unknown key (listing the known ones) or a bad index.
std::vector<Selected> select_rows(const profile::Profile& p, std::span<const std::string> keys,
                                  bool for_write);

struct ReadValue {
  Selected entry;
  int64_t raw = 0;
  Error error;
};
/// Reads the entries from a device, adjacent ones in one request.
std::vector<ReadValue> read_selected(Master& master, UnitId unit, std::span<const Selected> selected);
/// The values as one JSON document (docs/json.md): {"time", "ok", "device",
/// "unit", "values": {key: entry}}; an entry that failed is {"error": ...}.
Json values_document(const profile::Profile& p, UnitId unit, std::span<const ReadValue> values);
/// "key = 80 %" lines, or values_document.
void print_values(const profile::Profile& p, UnitId unit, std::span<const ReadValue> values, bool json);

/// Loads a map file or throws Failure (kUsage with the line-numbered reason,
/// kIoError when unreadable). The profile lives until the process ends.
const profile::Profile& load_map_or_fail(const std::string& path);

/// `rtukit read --map FILE [KEY...]`.
int run_map_read(const LinkOptions& link, const std::string& unit, const std::string& map_file,
                 std::span<const std::string> keys, bool json);

}  // namespace rtukit::cli
