#include "rtukit/io/atomic_file.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace rtukit::io {
namespace {

// mkdir -p for the directory part of `path`.
void make_parents(const std::string& path) {
  for (size_t at = path.find('/', 1); at != std::string::npos; at = path.find('/', at + 1))
    ::mkdir(path.substr(0, at).c_str(), 0755);
}

// Temporary files `<name>.tmp.<pid>` next to `path` whose process is gone:
// a writer killed between creating its temporary file and the rename (a
// power cut, SIGKILL) leaves one behind; without this, a device killed a
// thousand times would collect a thousand. Only regular files of ours with
// that exact name are removed (unlink never follows a symlink).
void remove_stale_temporaries(const std::string& dir, const std::string& name) {
  DIR* d = ::opendir(dir.c_str());
  if (!d) return;
  const std::string prefix = name + ".tmp.";
  while (const dirent* e = ::readdir(d)) {
    const std::string entry = e->d_name;
    if (!entry.starts_with(prefix) || entry.size() == prefix.size() || entry.size() > prefix.size() + 9)
      continue;
    const std::string digits = entry.substr(prefix.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos) continue;
    const auto pid = static_cast<pid_t>(std::stol(digits));
    if (pid <= 0 || pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;
    struct stat st {};
    if (::fstatat(::dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode) ||
        st.st_uid != ::geteuid())
      continue;
    ::unlinkat(::dirfd(d), e->d_name, 0);
  }
  ::closedir(d);
}

Status fail(const std::string& what, int err) {
  return Status(Error(Errc::io_error, err), what + ": " + std::strerror(err));
}

}  // namespace

Status write_file_atomically(const std::string& path, std::string_view content, unsigned mode) {
  make_parents(path);
  const size_t slash = path.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  remove_stale_temporaries(dir, slash == std::string::npos ? path : path.substr(slash + 1));
  // Per process, so two writers never share a temporary file. A leftover of
  // ours (a crash) is removed; unlink never follows a planted symlink, and
  // O_EXCL | O_NOFOLLOW never writes through one.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  ::unlink(tmp.c_str());
  const int fd =
      ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, static_cast<mode_t>(mode));
  if (fd < 0) return fail("cannot create " + tmp, errno);
  const auto abandon = [&](const std::string& what) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    return fail(what, err);
  };
  size_t done = 0;
  while (done < content.size()) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return abandon("cannot write " + tmp);
    done += static_cast<size_t>(n);
  }
  // The data must be on disk before the rename makes it the file.
  if (::fsync(fd) != 0) return abandon("cannot flush " + tmp);
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return fail("cannot replace " + path, err);
  }
  // And the rename itself must survive a power cut.
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return {};
}

}  // namespace rtukit::io

namespace rtukit::io {

Outcome<std::string> read_regular_file(const std::string& path, size_t max_size) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return Status(Error(Errc::io_error, errno), std::strerror(errno));
  struct stat st {};
  std::string text;
  Status status;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    status = Status(Errc::malformed, "not a regular file");
  } else if (static_cast<size_t>(st.st_size) > max_size) {
    status = Status(Errc::malformed, "larger than " + std::to_string(max_size) + " bytes");
  } else {
    text.resize(static_cast<size_t>(st.st_size));
    size_t got = 0;
    while (got < text.size()) {
      const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
      if (n <= 0) break;
      got += static_cast<size_t>(n);
    }
    text.resize(got);
  }
  ::close(fd);
  if (!status.ok()) return status;
  return text;
}

}  // namespace rtukit::io

namespace rtukit::io {

Outcome<int> create_output_file(const std::string& path, std::string_view ours_prefix, bool overwrite) {
  constexpr int kWrite = O_WRONLY | O_NOFOLLOW | O_CLOEXEC;
  int fd = ::open(path.c_str(), kWrite | O_CREAT | O_EXCL, 0644);
  if (fd >= 0) return fd;
  if (errno != EEXIST) return fail("cannot create " + path, errno);
  // Something is there: look before replacing it. O_NONBLOCK: a FIFO never
  // blocks the look; O_NOFOLLOW: a symlink is refused, not followed.
  const int look = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (look < 0) return fail(path + " exists and cannot be read", errno);
  struct stat st {};
  std::string head(ours_prefix.size(), '\0');
  const bool regular = ::fstat(look, &st) == 0 && S_ISREG(st.st_mode);
  const ssize_t got = regular ? ::read(look, head.data(), head.size()) : -1;
  ::close(look);
  if (!regular) return Status(Errc::refused, path + " exists and is not a regular file; not replaced");
  const bool ours = got == static_cast<ssize_t>(ours_prefix.size()) && head == ours_prefix;
  if (!ours && !overwrite)
    return Status(Errc::refused,
                  path + " exists and is not a file rtukit wrote; not replaced (--overwrite replaces it)");
  fd = ::open(path.c_str(), kWrite | O_TRUNC);
  if (fd < 0) return fail("cannot replace " + path, errno);
  return fd;
}

}  // namespace rtukit::io
