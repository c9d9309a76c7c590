// The web layer every rtukit program with a page shares (the Rehand 6600
// host daemon, the Inverjet pool panel): HTTP and WebSocket on one event
// loop (Boost.Beast over Boost.Asio, one thread; docs/architecture.md says
// why), with the pages' assets built into the binary (assets.hpp).
//
// Contract:
//  - Every handler runs on the server's one thread, one at a time: the
//    application's session state needs no lock. Other threads reach that
//    thread with post().
//  - A handler must not block for long: the other clients wait meanwhile.
//  - No client can hurt another or the program: requests and messages are
//    size-limited (`max_message`), a WebSocket client that sends more than
//    `max_messages_per_s` (averaged over 2 s) is dropped, one that does not
//    read its messages (more than `max_queue` bytes waiting) is dropped, and
//    at most `max_connections` are served (more are closed at once).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/io/status.hpp"

namespace rtukit::web {

struct HttpRequest {
  std::string method;  ///< "GET", "POST", ...
  std::string path;    ///< "/api/state" (no query)
  std::string query;   ///< "role=phone&token=..." (no '?')
  std::string body;
  std::string peer;     ///< "127.0.0.1:51234"
  size_t listener = 0;  ///< index into ServerOptions::listen
  std::string user_agent;
  /// The value of `key` in the query ("" when absent); no %-decoding beyond '+'.
  std::string param(std::string_view key) const;
};

struct HttpResponse {
  unsigned status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::string cache_control = "no-store";
};

/// One WebSocket client. Held by the server while open; the application may
/// keep the shared_ptr (for example in a map by id) and send at any time.
class Socket {
 public:
  virtual ~Socket() = default;
  /// Queues a text message. Thread-safe. A client whose queue exceeds
  /// `max_queue` is dropped. No effect once closed.
  virtual void send(std::string text) = 0;
  /// Closes the connection (a close frame with `reason`); `closed` follows.
  virtual void close(std::string reason) = 0;
  virtual bool is_open() const = 0;
  uint64_t id() const noexcept { return id_; }
  const HttpRequest& request() const noexcept { return request_; }  ///< the upgrade request

 protected:
  Socket(uint64_t id, HttpRequest request) : id_(id), request_(std::move(request)) {}

 private:
  uint64_t id_;
  HttpRequest request_;
};
using SocketPtr = std::shared_ptr<Socket>;

struct Handlers {
  /// A plain HTTP request. Default: 404.
  std::function<HttpResponse(const HttpRequest&)> http;
  /// An upgrade request: return an empty optional to accept it, or the
  /// refusal (401, 403, 404...). Default: accept.
  std::function<std::optional<HttpResponse>(const HttpRequest&)> upgrade;
  std::function<void(const SocketPtr&)> opened;
  std::function<void(const SocketPtr&, std::string_view text)> message;
  std::function<void(const SocketPtr&)> closed;
};

struct ServerOptions {
  /// "127.0.0.1:8080", "0.0.0.0:8443", "[::1]:8080"; port 0 picks a free one.
  std::vector<std::string> listen;
  size_t max_message = 64 * 1024;
  size_t max_queue = 1024 * 1024;
  unsigned max_messages_per_s = 200;
  size_t max_connections = 64;
};

class Server {
 public:
  Server(ServerOptions options, Handlers handlers);
  ~Server();  ///< stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Binds every listen address and starts the thread. Errors:
  /// invalid_argument (an address that does not parse), io_error (in use,
  /// not allowed), with the address in the reason.
  rtukit::Status start();
  /// Closes every connection and joins the thread. Idempotent.
  void stop();
  /// The bound ports, in the order of `listen` (after start()).
  std::vector<uint16_t> ports() const;
  /// Runs `fn` on the server's thread.
  void post(std::function<void()> fn);
  /// Runs `fn` on the server's thread every `period_ms` until stop().
  void every(unsigned period_ms, std::function<void()> fn);
  /// Open WebSocket connections now.
  size_t connections() const;

  struct Impl;  ///< the sessions' shared state (server.cpp only)

 private:
  std::unique_ptr<Impl> impl_;
};

/// "http://127.0.0.1:8080" for a bound listen address ("[::1]" kept pasteable).
std::string url_of(std::string_view listen, uint16_t port);
/// True for 127.0.0.0/8, ::1 and "localhost".
bool is_loopback(std::string_view listen);

}  // namespace rtukit::web
