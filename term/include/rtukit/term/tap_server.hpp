// rtukit io: a Unix-socket server that hands a stream of text lines to every
// client that connects (a virtual bus's tap, read by `rtukit sniff --bus`).
//
// Each client gets a header first (made when it connects), then every line
// published after that. The publisher never waits for a client: one that
// falls more than 1 MB behind is disconnected. Runs on the io_context's
// thread; not thread-safe.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "rtukit/base/status.hpp"
#include "rtukit/io/asio_fwd.hpp"

namespace rtukit::term {

class TapServer {
 public:
  /// What a client is sent before any line: called once per client, as it connects.
  using Header = std::function<std::string()>;

  /// Serves on the socket `path` once listen() succeeds. Nothing is created yet.
  TapServer(asio::io_context& ctx, std::string path, Header header);
  /// Removes the socket when listen() made it.
  ~TapServer();
  TapServer(const TapServer&) = delete;
  TapServer& operator=(const TapServer&) = delete;

  /// Makes the socket's directory (mode 0700, ours) if missing, replaces a
  /// socket left by a server that died, and starts accepting clients.
  /// Errors: invalid_argument when a live server answers on `path` ("a bus
  /// of that name is running (PATH)"); io_error when the directory cannot be
  /// made or is not a directory of ours, when `path` exists and is not a
  /// socket, or when the socket cannot be bound (with the OS reason). The
  /// reason names the directory or the path.
  Status listen();

  /// Queues `line` for every connected client; drops a client that would
  /// then be more than kMaxBehind bytes behind.
  void publish(const std::string& line);

  static constexpr size_t kMaxBehind = size_t{1} << 20;

 private:
  struct State;  // Asio's types stay in the source
  std::unique_ptr<State> state_;
};

}  // namespace rtukit::term
