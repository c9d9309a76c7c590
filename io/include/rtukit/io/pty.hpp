// rtukit io: a pseudo-terminal a slave listens on, so any tool can open it as
// if it were a serial port (its path is printed, and optionally symlinked).
#pragma once

#include <string>

#include "rtukit/core/error.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::io {

class Pty {
 public:
  Pty() = default;
  Pty(Pty&& other) noexcept;
  Pty& operator=(Pty&& other) noexcept;
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;
  ~Pty();

  /// Creates a pty in raw mode. With a non-empty `link`, a symlink to the
  /// slave side is created there (an existing symlink is replaced; any other
  /// file there is an error). The slave side is kept open by us too, so the
  /// pty survives clients that open and close it.
  /// Errors: io_error with the OS error number; `why` says which step failed.
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

 private:
  int master_ = -1;
  int keep_open_ = -1;
  std::string path_;
  std::string link_;
};

}  // namespace rtukit::io
