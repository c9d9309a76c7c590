// rtukit io: a simulator's console on stdin that never freezes it.
//
// stdin is read when it is a pipe, a FIFO or a file, and a terminal only
// while this process is the terminal's foreground job: a simulator sent to
// the background of an interactive shell keeps serving, is never stopped by
// the shell (callers also call ignore_tty_stops) and leaves the terminal to
// the foreground job.
#pragma once

#include <thread>

#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/term/line_console.hpp"

namespace rtukit::term {

/// Ignores SIGTTIN and SIGTTOU for the whole process: a background job must
/// never be stopped by the terminal it was started from.
void ignore_tty_stops();

class StdinConsole {
 public:
  /// Reads console lines from `fd` (stdin; a test passes a pipe) on a thread
  /// of its own and posts each one (without its '\n') to `ctx`, where
  /// `on_line` runs; its reply is written to stdout and flushed. Reading
  /// ends at the end of input (the io_context keeps running) or when this
  /// object goes. Without stdin (a closed descriptor) nothing is read, and
  /// no error is reported. Preconditions: `ctx` outlives this object; `fd`
  /// stays open while it lives.
  StdinConsole(asio::io_context& ctx, ConsoleHandler on_line, int fd = 0);
  /// Stops the thread, even while it waits for input, and joins it. Lines
  /// already posted still run if `ctx` runs.
  ~StdinConsole();
  StdinConsole(const StdinConsole&) = delete;
  StdinConsole& operator=(const StdinConsole&) = delete;

 private:
  void read_lines(asio::io_context& ctx, const ConsoleHandler& on_line, int fd, bool terminal);
  int stop_[2] = {-1, -1};  // a pipe: a byte in it stops the thread
  std::thread thread_;
};

}  // namespace rtukit::term
