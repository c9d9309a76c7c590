// rtukit device profiles, host side: where a simulated device keeps its
// flash. The rows flagged `kPersisted` are saved as JSON with a CRC-16 over
// their canonical dump, so a damaged file is noticed, never half-used.
//
// Saving is crash-safe (io::write_file_atomically): temporary file in the
// same directory, fsync, rename over the old file, fsync of the directory. A
// power cut or a kill at any moment leaves the old or the new file.
#pragma once

#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/register_map.hpp"

namespace rtukit::profile {

/// $XDG_STATE_HOME/rtukit/<device>.json, else ~/.local/state/rtukit/<device>.json.
std::string default_state_path(std::string_view device);

/// The file's text: {"format": "rtukit-state", "version": 1, "device": NAME,
/// "registers": {key: value or [values of a repeated block]}, "checksum": "0x...."}.
std::string state_to_text(const Profile& profile, const Image& image);

/// Replaces the persisted rows of `image` from a file's text: all or nothing
/// (on error the image is unchanged). Errors: malformed (not JSON, another
/// device's or program's file, unknown version, a row missing or of the
/// wrong shape), bad_crc (checksum mismatch), illegal_data_value (a value
/// its row refuses); the reason says which.
Status state_from_text(const Profile& profile, std::string_view text, Image& image);

struct LoadedState {
  bool from_file = false;
  /// The path holds something that is not this device's state file (another
  /// program's file, another device's state, a directory, a FIFO, a device
  /// node, a file far larger than a state file): it must not be overwritten.
  bool foreign = false;
  std::string warning;  ///< why the defaults are used (missing, damaged, foreign...), else empty
};
/// Never fails: a missing, damaged or foreign file leaves the image's
/// defaults and says why. A file of ours that is damaged (a bad checksum, a
/// value out of range, truncated) is `warning` only: saving replaces it. A
/// file that is not ours is `foreign`: the caller must not save over it.
/// Never blocks (a FIFO is not opened for reading) and never reads more than
/// 1 MiB.
LoadedState load_state(const std::string& path, const Profile& profile, Image& image);

/// Writes the persisted rows atomically (creating the directory). Errors: io_error.
Status save_state(const std::string& path, const Profile& profile, const Image& image);

}  // namespace rtukit::profile
