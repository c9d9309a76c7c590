// rtukit CLI: a simulator's console on stdin that never freezes it.
//
// stdin is read when it is a pipe, a FIFO or a file, and a terminal only
// while the simulator is the terminal's foreground job: a simulator sent to
// the background of an interactive shell keeps serving and is never stopped
// by the shell (callers also ignore SIGTTIN/SIGTTOU: see ignore_tty_stops).
#pragma once

#include <fmt/core.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>

#include "rtukit/io/asio.hpp"
#include "rtukit/io/line_console.hpp"

namespace rtukit::cli {

/// A background job must never be stopped by the terminal it was started from.
inline void ignore_tty_stops() {
  std::signal(SIGTTIN, SIG_IGN);
  std::signal(SIGTTOU, SIG_IGN);
}

/// A console line and how to answer it: the same type for stdin and the socket (io/line_console.hpp).
using OnLine = io::ConsoleHandler;

// Reads console lines from stdin on its own thread and hands each one to the
// io_context (the simulator is only touched there). Stops through a pipe, so
// it can be joined even while a read would block.
class StdinConsole {
 public:
  StdinConsole(asio::io_context& ctx, OnLine on_line) {
    if (::pipe(stop_) != 0) return;
    struct stat st {};
    const bool terminal = ::isatty(STDIN_FILENO) != 0;
    if (!terminal && (::fstat(STDIN_FILENO, &st) != 0)) return;  // no stdin at all
    thread_ = std::thread([this, &ctx, on_line, terminal] {
      std::string pending;
      char buf[512];
      for (;;) {
        // A terminal is ours only while we are its foreground job; in the
        // background we leave it alone and look again a little later.
        if (terminal && ::tcgetpgrp(STDIN_FILENO) != ::getpgrp()) {
          pollfd stop = {stop_[0], POLLIN, 0};
          if (::poll(&stop, 1, 250) > 0) return;
          continue;
        }
        pollfd fds[2] = {{STDIN_FILENO, POLLIN, 0}, {stop_[0], POLLIN, 0}};
        if (::poll(fds, 2, terminal ? 250 : -1) < 0) continue;
        if (fds[1].revents) return;
        if (!fds[0].revents) continue;
        const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
        if (n < 0 && terminal && errno == EIO) continue;  // lost the foreground between poll and read
        if (n <= 0) return;                               // end of input: the simulator keeps running
        pending.append(buf, static_cast<size_t>(n));
        for (size_t nl; (nl = pending.find('\n')) != std::string::npos;) {
          std::string line = pending.substr(0, nl);
          pending.erase(0, nl + 1);
          asio::post(ctx, [on_line, line] {
            on_line(line, [](const std::string& text) {
              fmt::print("{}", text);
              std::fflush(stdout);
            });
          });
        }
      }
    });
  }
  ~StdinConsole() {
    if (thread_.joinable()) {
      const char x = 'x';
      (void)!::write(stop_[1], &x, 1);
      thread_.join();
    }
    if (stop_[0] >= 0) ::close(stop_[0]);
    if (stop_[1] >= 0) ::close(stop_[1]);
  }
  StdinConsole(const StdinConsole&) = delete;
  StdinConsole& operator=(const StdinConsole&) = delete;

 private:
  int stop_[2] = {-1, -1};
  std::thread thread_;
};

}  // namespace rtukit::cli
