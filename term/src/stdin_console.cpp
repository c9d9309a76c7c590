// The console's reads block, and a simulator must never wait on its user,
// so they run on a thread of their own; the simulator itself is touched
// only on the io_context's thread, where each line is posted. The thread is
// stopped through a pipe so it can be joined even while a read would block.
#include "rtukit/term/stdin_console.hpp"

#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <string>

#include "rtukit/io/asio.hpp"

namespace rtukit::term {

void ignore_tty_stops() {
  std::signal(SIGTTIN, SIG_IGN);
  std::signal(SIGTTOU, SIG_IGN);
}

StdinConsole::StdinConsole(asio::io_context& ctx, ConsoleHandler on_line, int fd) {
  if (::pipe(stop_) != 0) return;
  struct stat st {};
  const bool terminal = ::isatty(fd) != 0;
  if (!terminal && (::fstat(fd, &st) != 0)) return;  // no stdin at all
  thread_ = std::thread(
      [this, &ctx, on_line = std::move(on_line), fd, terminal] { read_lines(ctx, on_line, fd, terminal); });
}

void StdinConsole::read_lines(asio::io_context& ctx, const ConsoleHandler& on_line, int fd, bool terminal) {
  std::string pending;
  char buf[512];
  for (;;) {
    // A terminal is ours only while we are its foreground job; in the
    // background we leave it alone and look again a little later.
    if (terminal && ::tcgetpgrp(fd) != ::getpgrp()) {
      pollfd stop = {stop_[0], POLLIN, 0};
      if (::poll(&stop, 1, 250) > 0) return;
      continue;
    }
    pollfd fds[2] = {{fd, POLLIN, 0}, {stop_[0], POLLIN, 0}};
    if (::poll(fds, 2, terminal ? 250 : -1) < 0) continue;
    if (fds[1].revents) return;
    if (!fds[0].revents) continue;
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && terminal && errno == EIO) continue;  // lost the foreground between poll and read
    if (n <= 0) return;                               // end of input: the simulator keeps running
    pending.append(buf, static_cast<size_t>(n));
    for (size_t nl; (nl = pending.find('\n')) != std::string::npos;) {
      std::string line = pending.substr(0, nl);
      pending.erase(0, nl + 1);
      asio::post(ctx, [on_line, line] {
        on_line(line, [](const std::string& text) {
          std::fwrite(text.data(), 1, text.size(), stdout);
          std::fflush(stdout);
        });
      });
    }
  }
}

StdinConsole::~StdinConsole() {
  if (thread_.joinable()) {
    const char x = 'x';
    (void)!::write(stop_[1], &x, 1);
    thread_.join();
  }
  if (stop_[0] >= 0) ::close(stop_[0]);
  if (stop_[1] >= 0) ::close(stop_[1]);
}

}  // namespace rtukit::term
