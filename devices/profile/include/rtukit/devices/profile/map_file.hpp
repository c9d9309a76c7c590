// rtukit device profiles, host side: register-map files. Any Modbus device
// described in YAML (or JSON, which the same loader reads) in the schema the
// built-in devices use, so `rtukit sim map`, `rtukit read --map` and the
// sniffer treat it like a built-in device. docs/register-maps.md documents
// the format; `rtukit <device> registers --yaml` exports a built-in profile
// to it.
#pragma once

#include <deque>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/model.hpp"
#include "rtukit/devices/profile/schema.hpp"

namespace rtukit::profile {

/// A profile read from a file. Owns every string and row it points to.
class MapFileReader;

class MapProfile {
 public:
  const Profile& profile() const noexcept { return profile_; }

 private:
  friend Outcome<std::unique_ptr<MapProfile>> parse_map(std::string_view text, std::string_view source);
  friend class MapFileReader;  // parse_map's field readers
  std::string_view keep(std::string s);
  std::deque<std::string> strings_;
  std::deque<std::vector<Named>> names_;
  std::vector<Row> rows_;
  std::vector<FlagName> flag_names_;
  Profile profile_;
};

/// Parses a map file's text. `source` names the file in messages. Errors:
/// invalid_argument with "SOURCE:LINE: what is wrong" (unknown field or
/// encoding, bad range, overlapping registers, duplicate key...).
Outcome<std::unique_ptr<MapProfile>> parse_map(std::string_view text, std::string_view source);

/// Reads and parses a map file (a regular file of at most 4 MiB). Errors as
/// parse_map, or io_error when it cannot be read.
Outcome<std::unique_ptr<MapProfile>> load_map(const std::string& path);

/// Checks a profile's table (the built-in ones are checked by a test):
/// keys unique and snake_case, ranges inside the encoding, defaults inside
/// the range, stride >= words, names where an encoding needs them, no two
/// rows covering one address. Errors: invalid_argument naming the row.
Status check_profile(const Profile& profile);

/// A register-only device for `profile` (which must outlive it): validates
/// exactly as the map says (strict gaps, ranges, read-only, all or nothing)
/// and stores what is written. Registers start at their defaults.
std::unique_ptr<Model> make_register_device(const Profile& profile);

/// The profile in the map-file format (YAML), loadable by parse_map.
std::string map_to_yaml(const Profile& profile);
/// The same document as JSON text (`registers --json`), also loadable by parse_map.
std::string map_to_json(const Profile& profile);

}  // namespace rtukit::profile
