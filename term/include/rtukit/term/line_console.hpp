// rtukit io: a line console on a Unix socket (a simulator's console for
// `socat - UNIX-CONNECT:PATH`): each line a client sends is handed to the
// owner with a function that writes a reply to that client.
//
// Any number of clients; everything runs on the io_context's thread, so the
// handler may touch what that thread owns. Not thread-safe.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "rtukit/base/status.hpp"
#include "rtukit/io/asio_fwd.hpp"

namespace rtukit::term {

/// Sends `text` as it is (the caller ends it with '\n').
using ConsoleReply = std::function<void(std::string text)>;
/// One line (without its '\n') and how to answer its sender.
using ConsoleHandler = std::function<void(const std::string& line, const ConsoleReply& reply)>;

class LineConsole {
 public:
  /// Listens on the socket `path` (mode 0600: a console may change what it
  /// drives, so it is the owner's alone), replacing a socket left there by
  /// an earlier run. A line longer than 4096 bytes ends its client's session.
  /// Errors: invalid_argument when `path` exists and is not a socket ("PATH
  /// exists and is not a socket; not replacing it"); io_error with the OS
  /// error when the socket cannot be made ("console PATH: reason").
  static Outcome<std::unique_ptr<LineConsole>> open(asio::io_context& ctx, const std::string& path,
                                                    ConsoleHandler on_line);
  /// Stops listening and removes the socket.
  ~LineConsole();
  LineConsole(const LineConsole&) = delete;
  LineConsole& operator=(const LineConsole&) = delete;

 private:
  struct State;  // Asio's types stay in the source
  explicit LineConsole(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace rtukit::term
