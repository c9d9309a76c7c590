// rtukit io: replacing a small file so that a crash or power cut at any
// moment leaves either the old content or the new one, never a mix. For
// simulated flash (a device's persisted settings).
#pragma once

#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/core/error.hpp"

namespace rtukit::io {

/// Writes `content` to a temporary file next to `path` (its directories are
/// created; the temporary file is created exclusively and never through a
/// symlink), flushes it (fsync), renames it over `path` (atomic on POSIX file
/// systems) and flushes the directory. The file gets `mode` (0600 for
/// secrets). Temporary files of `path` left by writers that were killed
/// (`<name>.tmp.<pid>` of a process that no longer exists) are removed.
/// Errors: io_error with the OS error and a one-line reason. A failed write
/// leaves `path` untouched.
Status write_file_atomically(const std::string& path, std::string_view content, unsigned mode = 0644);

/// Reads a small regular file whole. Never blocks on a FIFO, never reads a
/// device or a file larger than `max_size` into memory. Errors: io_error
/// with the OS error (cannot open), malformed ("not a regular file", "larger
/// than N bytes"), with the reason.
Outcome<std::string> read_regular_file(const std::string& path, size_t max_size);

/// Opens `path` to write a file rtukit produces as a stream (a bus tap, a
/// pcap capture): created if missing (mode 0644). An existing file is
/// truncated only when it is ours, a regular file whose first bytes are
/// `ours_prefix`, or when `overwrite` is set; never through a symlink, and
/// never a FIFO, a device or a directory. Returns the file descriptor.
/// Errors: refused ("exists and is not ..."), io_error with the OS reason.
Outcome<int> create_output_file(const std::string& path, std::string_view ours_prefix, bool overwrite);

}  // namespace rtukit::io
