// rtukit io: a pseudo-terminal a slave listens on, so any tool can open it as
// if it were a serial port (its path is printed, and optionally symlinked).
#pragma once

#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/core/error.hpp"

namespace rtukit::io {

/// A process's command line, as /proc/PID/cmdline holds it (arguments
/// separated by NULs), shortened for a message: the program's name without
/// its path, then its arguments, at most 100 characters. A program run
/// through an emulator's binfmt_misc interpreter (qemu-user on the RK3588
/// build's test host: "/usr/libexec/qemu-binfmt/aarch64-binfmt-P
/// /path/rtukit /path/rtukit sim ...") is named as the program, not the
/// emulator. Empty in, empty out.
std::string describe_command_line(std::string_view cmdline);

/// Whether `path` is a symlink to a pty slave (/dev/pts/N) that was made
/// after the link: the pty the link was made for is gone (its owner died
/// without removing the link) and its number came back for another
/// program's pty. Opening it would take that other program's line (a test's
/// simulator, someone's terminal): SerialLink refuses it as if the port were
/// absent. False for anything else (a live link, a real serial port).
bool stale_pty_link(const std::string& path);

class Pty {
 public:
  Pty() = default;
  Pty(Pty&& other) noexcept;
  Pty& operator=(Pty&& other) noexcept;
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;
  ~Pty();

  /// Creates a pty in raw mode. With a non-empty `link`, a symlink to the
  /// slave side is created there. The link is ours while we live: we hold a
  /// lock on `link + ".lock"` beside it (an advisory flock; the file holds
  /// our pid and goes when we do). A link another live process serves is
  /// never replaced: its lock is held (invalid_argument, "LINK is in use by
  /// pid N (its command line)"), or, without a lock file, it points at a pty
  /// that was there when the link was made and is still open (a socat pair,
  /// an older rtukit). A stale link (its owner died) is replaced; any other
  /// file there is an error. The slave side is kept open by us too, so the
  /// pty survives clients that open and close it.
  /// Errors: io_error with the OS error number; invalid_argument for a link
  /// in use; `why` says which step failed.
  static Outcome<Pty> create(const std::string& link);

  /// The master side, for the slave server to read and write. Ownership stays here
  /// unless release_master() is called.
  int master_fd() const noexcept { return master_; }
  /// Hands the master fd to the caller (who closes it).
  int release_master() noexcept;
  /// Path of the slave side (/dev/pts/N), what clients open.
  const std::string& path() const noexcept { return path_; }
  /// The symlink, if one was made; else path().
  const std::string& name() const noexcept { return link_.empty() ? path_ : link_; }

  /// Stops holding the slave side open (its raw mode stays). From then on
  /// the master tells whether a client has the port open (slave_open()),
  /// and reads on it fail with EIO while nobody has.
  void release_slave() noexcept;
  /// Whether some process has the slave side open (after release_slave();
  /// before it, always true). Asks the kernel: POLLHUP on the master.
  bool slave_open() const noexcept;
  /// Throws away what was written to the master and not read on the slave
  /// side (bytes a client left unread when it closed the port). The kernel
  /// keeps them for the next client otherwise.
  Error discard_unread() noexcept;

 private:
  int master_ = -1;
  int keep_open_ = -1;
  int lock_ = -1;
  std::string path_;
  std::string link_;
  std::string lock_path_;
};

}  // namespace rtukit::io
