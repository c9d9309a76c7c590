#include "rtukit/io/pty.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <utility>

#include "rtukit/io/serial_config.hpp"

namespace rtukit::io {

Pty::Pty(Pty&& o) noexcept
    : master_(std::exchange(o.master_, -1)),
      keep_open_(std::exchange(o.keep_open_, -1)),
      path_(std::move(o.path_)),
      link_(std::move(o.link_)) {
  o.link_.clear();
}

Pty& Pty::operator=(Pty&& o) noexcept {
  Pty old(std::move(*this));  // released when `old` goes out of scope
  master_ = std::exchange(o.master_, -1);
  keep_open_ = std::exchange(o.keep_open_, -1);
  path_ = std::move(o.path_);
  link_ = std::move(o.link_);
  o.link_.clear();
  return *this;
}

Pty::~Pty() {
  if (!link_.empty()) ::unlink(link_.c_str());
  if (keep_open_ >= 0) ::close(keep_open_);
  if (master_ >= 0) ::close(master_);
}

int Pty::release_master() noexcept {
  return std::exchange(master_, -1);
}

Outcome<Pty> Pty::create(const std::string& link) {
  auto fail = [](const std::string& step) {
    const int err = errno;
    return Status(Error(Errc::io_error, err), step + ": " + std::strerror(err));
  };
  Pty pty;
  pty.master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
  if (pty.master_ < 0) return fail("posix_openpt");
  if (::grantpt(pty.master_) != 0 || ::unlockpt(pty.master_) != 0) return fail("unlockpt");
  char name[128] = {};
  if (::ptsname_r(pty.master_, name, sizeof name) != 0) return fail("ptsname");
  pty.path_ = name;
  // Holding the slave side open keeps reads on the master from failing with
  // EIO between clients.
  pty.keep_open_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (pty.keep_open_ < 0) return fail("open pty slave");
  if (Error e = make_raw(pty.keep_open_)) {
    errno = e.os_error();
    return fail("raw mode");
  }
  if (!link.empty()) {
    struct stat st {};
    if (::lstat(link.c_str(), &st) == 0) {
      if (!S_ISLNK(st.st_mode)) {
        errno = EEXIST;
        return fail("symlink " + link);
      }
      ::unlink(link.c_str());
    }
    if (::symlink(name, link.c_str()) != 0) return fail("symlink " + link);
    pty.link_ = link;
  }
  return pty;
}

}  // namespace rtukit::io
