#include "rtukit/io/pty.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <utility>
#include <vector>

#include "rtukit/io/serial_config.hpp"

#ifndef TIOCGPTPEER
#define TIOCGPTPEER _IO('T', 0x41)  // Linux 4.13; older headers lack it
#endif

namespace rtukit::io {
namespace {

Status os_failure(const std::string& step) {
  const int err = errno;
  return Status(Error(Errc::io_error, err), step + ": " + std::strerror(err));
}

std::string_view base_name(std::string_view path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

// "pid 1234 (rtukit sim inverjet --listen pty:/tmp/x)", as far as /proc tells.
std::string describe_pid(pid_t pid) {
  const std::string text = "pid " + std::to_string(pid);
  std::ifstream in("/proc/" + std::to_string(pid) + "/cmdline", std::ios::binary);
  const std::string raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string cmd = describe_command_line(raw);
  return cmd.empty() ? text : text + " (" + cmd + ")";
}

// What a link lock file may hold: nothing yet, or the pid of its owner.
bool lock_content(int fd, pid_t& pid) {
  char buf[32] = {};
  const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
  if (n < 0) return false;
  pid = 0;
  for (ssize_t i = 0; i < n; ++i) {
    if (std::isdigit(static_cast<unsigned char>(buf[i])))
      pid = pid * 10 + (buf[i] - '0');
    else if (buf[i] != '\n' || i != n - 1)
      return false;
  }
  return n < static_cast<ssize_t>(sizeof buf) - 1;
}

// Takes the lock beside `link`: the fd holding it, or why not. `existed`:
// the lock file was there before (left by an owner that died: its link is
// stale).
Outcome<int> lock_link(const std::string& link, const std::string& lock_path, bool& existed) {
  for (int attempt = 0; attempt < 20; ++attempt) {
    int fd = ::open(lock_path.c_str(), O_RDWR | O_CLOEXEC | O_NOFOLLOW);
    existed = fd >= 0;
    if (fd < 0 && errno == ENOENT)
      fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0 && errno == EEXIST) continue;  // made by another just now: look again
    if (fd < 0 && errno == EACCES) fd = ::open(lock_path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) return os_failure("lock " + lock_path);
    struct stat st {};
    pid_t pid = 0;
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || !lock_content(fd, pid)) {
      ::close(fd);
      return Status(Errc::invalid_argument,
                    lock_path + " exists and is not the lock of a link; not touching it or " + link);
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      if (err != EWOULDBLOCK) {
        ::close(fd);
        errno = err;
        return os_failure("lock " + lock_path);
      }
      (void)lock_content(fd, pid);  // the owner writes its pid right after locking
      ::close(fd);
      return Status(Errc::invalid_argument,
                    link + " is in use by " + (pid > 0 ? describe_pid(pid) : std::string("another process")) +
                        "; choose another path, or stop that one");
    }
    // Its owner may have removed it between our open and our lock (it was
    // exiting): only the file at the path counts.
    struct stat now {};
    if (::stat(lock_path.c_str(), &now) != 0 || now.st_ino != st.st_ino || now.st_dev != st.st_dev) {
      ::close(fd);
      continue;
    }
    const std::string text = std::to_string(::getpid()) + "\n";
    if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, text.data(), text.size(), 0) < 0) {
      // read-only (another user's lock file): locked all the same
    }
    return fd;
  }
  return Status(Error(Errc::io_error, EBUSY), "lock " + lock_path + ": keeps changing");
}

// Whether `link` is a symlink to a pty that exists and already existed when
// the link was made: a live pty someone serves there (a pty number that came
// back later for another terminal is newer than the link).
bool points_at_live_pty(const std::string& link, std::string& target) {
  struct stat l {};
  if (::lstat(link.c_str(), &l) != 0 || !S_ISLNK(l.st_mode)) return false;
  char buf[256] = {};
  const ssize_t n = ::readlink(link.c_str(), buf, sizeof buf - 1);
  if (n <= 0) return false;
  target.assign(buf, static_cast<size_t>(n));
  struct stat t {};
  if (::stat(link.c_str(), &t) != 0 || !S_ISCHR(t.st_mode)) return false;
  const unsigned major_number = major(t.st_rdev);
  if (major_number < 136 || major_number > 143) return false;  // Unix98 pty slaves
  const auto ns = [](const struct timespec& ts) {
    return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
  };
  return ns(t.st_ctim) <= ns(l.st_ctim);
}

}  // namespace

bool stale_pty_link(const std::string& path) {
  std::string target;
  struct stat l {};
  struct stat t {};
  // A link to a pty newer than itself: the only case points_at_live_pty
  // rejects among links that lead to a pty slave.
  return ::lstat(path.c_str(), &l) == 0 && S_ISLNK(l.st_mode) && ::stat(path.c_str(), &t) == 0 &&
         S_ISCHR(t.st_mode) && major(t.st_rdev) >= 136 && major(t.st_rdev) <= 143 &&
         !points_at_live_pty(path, target);
}

std::string describe_command_line(std::string_view cmdline) {
  std::vector<std::string_view> args;
  for (size_t at = 0; at < cmdline.size();) {
    const size_t end = std::min(cmdline.find('\0', at), cmdline.size());
    args.push_back(cmdline.substr(at, end - at));
    at = end + 1;
  }
  while (!args.empty() && args.back().empty()) args.pop_back();
  // binfmt_misc runs a foreign binary as INTERPRETER PATH [ARGV0] ARGS: with
  // the P flag (Debian's qemu-user-binfmt names it "*-binfmt-P") argv[0] is
  // kept, so PATH and ARGV0 usually repeat; the program is PATH.
  if (args.size() >= 2) {
    const std::string_view interpreter = base_name(args[0]);
    if (interpreter.starts_with("qemu-") || interpreter.find("-binfmt-") != std::string_view::npos) {
      const bool keeps_argv0 = interpreter.ends_with("-binfmt-P") || interpreter.ends_with("-binfmt-PF");
      args.erase(args.begin());
      if (keeps_argv0 && args.size() >= 2) args.erase(args.begin() + 1);
    }
  }
  std::string text;
  for (size_t i = 0; i < args.size(); ++i) {
    if (i > 0) text += ' ';
    text += i == 0 ? base_name(args[i]) : args[i];  // the program's name, not its path
  }
  if (text.size() > 100) text = text.substr(0, 97) + "...";
  return text;
}

Pty::Pty(Pty&& o) noexcept
    : master_(std::exchange(o.master_, -1)),
      keep_open_(std::exchange(o.keep_open_, -1)),
      lock_(std::exchange(o.lock_, -1)),
      path_(std::move(o.path_)),
      link_(std::move(o.link_)),
      lock_path_(std::move(o.lock_path_)) {
  o.link_.clear();
  o.lock_path_.clear();
}

Pty& Pty::operator=(Pty&& o) noexcept {
  Pty old(std::move(*this));  // released when `old` goes out of scope
  master_ = std::exchange(o.master_, -1);
  keep_open_ = std::exchange(o.keep_open_, -1);
  lock_ = std::exchange(o.lock_, -1);
  path_ = std::move(o.path_);
  link_ = std::move(o.link_);
  lock_path_ = std::move(o.lock_path_);
  o.link_.clear();
  o.lock_path_.clear();
  return *this;
}

Pty::~Pty() {
  if (!link_.empty()) ::unlink(link_.c_str());
  if (lock_ >= 0) {
    ::unlink(lock_path_.c_str());  // still locked: the next owner makes a new one
    ::close(lock_);
  }
  if (keep_open_ >= 0) ::close(keep_open_);
  if (master_ >= 0) ::close(master_);
}

int Pty::release_master() noexcept {
  return std::exchange(master_, -1);
}

void Pty::release_slave() noexcept {
  if (keep_open_ >= 0) ::close(std::exchange(keep_open_, -1));
}

bool Pty::slave_open() const noexcept {
  if (keep_open_ >= 0 || master_ < 0) return true;
  struct pollfd p {
    master_, 0, 0
  };
  if (::poll(&p, 1, 0) < 0) return true;
  return (p.revents & POLLHUP) == 0;
}

Error Pty::discard_unread() noexcept {
  if (master_ < 0) return Errc::not_connected;
  // The slave side's input queue can only be flushed from the slave side:
  // open it (by the master, never through a path someone may have
  // replaced), flush, close.
  int fd = ::ioctl(master_, TIOCGPTPEER, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) fd = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return Error(Errc::io_error, errno);
  const int rc = ::tcflush(fd, TCIFLUSH);
  const int err = errno;
  ::close(fd);
  return rc == 0 ? Error() : Error(Errc::io_error, err);
}

Outcome<Pty> Pty::create(const std::string& link) {
  Pty pty;
  if (!link.empty()) {
    // First the link's lock: another live owner, and nothing is touched.
    pty.lock_path_ = link + ".lock";
    bool lock_existed = false;
    Outcome<int> lock = lock_link(link, pty.lock_path_, lock_existed);
    if (!lock.ok()) {
      pty.lock_path_.clear();
      return lock.error();
    }
    pty.lock_ = *lock;
    std::string target;
    if (!lock_existed && points_at_live_pty(link, target))
      return Status(Errc::invalid_argument, link + " is in use: it points at " + target +
                                                ", a pty another program still serves; choose another path");
  }
  pty.master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
  if (pty.master_ < 0) return os_failure("posix_openpt");
  if (::grantpt(pty.master_) != 0 || ::unlockpt(pty.master_) != 0) return os_failure("unlockpt");
  char name[128] = {};
  if (::ptsname_r(pty.master_, name, sizeof name) != 0) return os_failure("ptsname");
  pty.path_ = name;
  // Holding the slave side open keeps reads on the master from failing with
  // EIO between clients.
  pty.keep_open_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (pty.keep_open_ < 0) return os_failure("open pty slave");
  if (Error e = make_raw(pty.keep_open_)) {
    errno = e.os_error();
    return os_failure("raw mode");
  }
  if (!link.empty()) {
    struct stat st {};
    if (::lstat(link.c_str(), &st) == 0) {
      if (!S_ISLNK(st.st_mode)) {
        errno = EEXIST;
        return os_failure("symlink " + link);
      }
      ::unlink(link.c_str());  // stale: its owner died (we hold the lock)
    }
    if (::symlink(name, link.c_str()) != 0) return os_failure("symlink " + link);
    pty.link_ = link;
  }
  return pty;
}

}  // namespace rtukit::io
