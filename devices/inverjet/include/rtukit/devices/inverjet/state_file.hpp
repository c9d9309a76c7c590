// Where the simulated Inverjet keeps its flash: the persisted settings
// (address, baud, control mask, free/timer memory, the four plans) as a JSON
// file with a checksum.
//
// Saving is crash-safe (io::write_file_atomically): the new content goes to
// a temporary file in the same directory, is flushed (fsync), then renamed
// over the old file (atomic on POSIX file systems) and the directory is
// flushed. A power cut or a kill at any moment leaves either the old or the
// new file, never a mix.
#pragma once

#include <string>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/inverjet/machine.hpp"

namespace rtukit::inverjet {

/// $XDG_STATE_HOME/rtukit/inverjet.json, else ~/.local/state/rtukit/inverjet.json.
std::string default_state_path();

struct LoadedSettings {
  Settings settings;  ///< what was loaded, or the factory defaults
  bool from_file = false;
  std::string warning;  ///< why the defaults are used (missing, truncated, bad checksum...), else empty
};

/// Never fails: a missing or damaged file gives the defaults and a warning.
LoadedSettings load_settings(const std::string& path);

/// Writes `settings` to `path` atomically (creating its directory).
/// Errors: io_error with the OS error; `why` gets a one-line reason.
Error save_settings(const std::string& path, const Settings& settings, std::string* why = nullptr);

/// The file's text for `settings` (JSON, with checksum).
std::string settings_to_text(const Settings& settings);
/// Parses the file's text. Errors: malformed (not JSON, wrong format or
/// version, missing field), bad_crc (checksum mismatch), invalid_argument
/// (a value out of its register's range); `why` says which.
Result<Settings> settings_from_text(const std::string& text, std::string* why = nullptr);

}  // namespace rtukit::inverjet
