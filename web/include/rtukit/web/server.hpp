// The web layer every rtukit program with a page shares (the Rehand 6600
// host daemon, the Inverjet pool panel): HTTP and WebSocket on one event
// loop (Boost.Beast over Boost.Asio, one thread; docs/architecture.md says
// why), over plain TCP or TLS per listener, with the pages' assets built
// into the binary (assets.hpp).
//
// Contract:
//  - Every handler runs on the server's one thread, one at a time: the
//    application's session state needs no lock. Other threads reach that
//    thread with post().
//  - A handler must not block for long: the other clients wait meanwhile.
//    An exception thrown by a handler does not escape: an HTTP handler's
//    becomes a 500, a WebSocket handler's closes that socket.
//  - No client can hurt another or the program: requests and messages are
//    size-limited (`max_message`), a WebSocket message may have at most
//    `max_frames_per_message` frames (empty ones count), a WebSocket client
//    that sends more than `max_messages_per_s` messages and control frames
//    (averaged over 2 s) is dropped, one that does not read its messages
//    (more than `max_queue` bytes waiting) is dropped, an HTTP connection
//    that has not sent a complete request `request_timeout_ms` after it
//    opened (or after its previous answer) is closed, and each listener
//    serves at most `Listener::max_connections` connections, at most
//    `Listener::max_per_source` of them from one source address (an IPv6
//    address whole, not its /64; more are closed at once): a stranger
//    flooding one listener never takes another listener's slots.
//  - Before any handler sees a request (plain HTTP or WebSocket upgrade),
//    the server checks (RFC 6455 section 10.2, DNS rebinding):
//    `Host` is an IP literal with the listener's bound port (`127.0.0.1:8080`,
//    `[::1]:8080`; the port may be left out when it is the scheme's default),
//    or `localhost:PORT` on a loopback listener, or one of the listener's
//    `host_names` with the port; else 403 "Host not allowed". `Origin`, when
//    present (also "null"), must be `http://` (`https://` on a TLS listener)
//    + the request's `Host` (compared without regard to case); else 403
//    "Origin not allowed".
//  - Every response (handlers', refusals, the WebSocket 101) carries
//    `Content-Security-Policy: default-src 'self'; frame-ancestors 'none'`,
//    `X-Content-Type-Options: nosniff` and `Referrer-Policy: no-referrer`.
//  - A TLS listener speaks TLS 1.2 or newer only; a client that speaks plain
//    HTTP to it is closed without an answer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"

namespace rtukit::web {

struct HttpRequest {
  std::string method;  ///< "GET", "POST", ...
  std::string path;    ///< "/api/state" (no query)
  std::string query;   ///< "role=phone&token=..." (no '?')
  std::string body;
  std::string peer;     ///< "127.0.0.1:51234"
  size_t listener = 0;  ///< index into ServerOptions::listen
  std::string user_agent;
  std::string host;     ///< the Host header ("127.0.0.1:8080"), already checked by the server
  std::string origin;   ///< the Origin header, "" when absent; when present it is the request's own origin
  std::string cookie;   ///< the Cookie header, raw ("a=1; b=2"), "" when absent
  bool secure = false;  ///< true on a TLS listener
  /// The value of `key` in the query ("" when absent); no %-decoding beyond '+'.
  std::string param(std::string_view key) const;
};

struct HttpResponse {
  unsigned status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::string cache_control = "no-store";
  /// More header fields, sent as given ({"Set-Cookie", "sid=...; Secure; HttpOnly"}). The
  /// server's security headers (see above) are set after these and win.
  std::vector<std::pair<std::string, std::string>> headers;
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
  /// The client's IP address without the port ("192.168.4.23", "::1"; an
  /// IPv4-mapped IPv6 address as IPv4), for per-source limits.
  const std::string& peer_address() const noexcept { return peer_address_; }

 protected:
  Socket(uint64_t id, HttpRequest request, std::string peer_address)
      : id_(id), request_(std::move(request)), peer_address_(std::move(peer_address)) {}

 private:
  uint64_t id_;
  HttpRequest request_;
  std::string peer_address_;
};
using SocketPtr = std::shared_ptr<Socket>;

struct Handlers {
  /// A plain HTTP request (Host and Origin already checked). Default: 404.
  std::function<HttpResponse(const HttpRequest&)> http;
  /// An upgrade request (Host and Origin already checked): return an empty
  /// optional to accept it, or the refusal (401, 403, 404...). Default: accept.
  std::function<std::optional<HttpResponse>(const HttpRequest&)> upgrade;
  std::function<void(const SocketPtr&)> opened;
  std::function<void(const SocketPtr&, std::string_view text)> message;
  std::function<void(const SocketPtr&)> closed;
};

/// A PEM certificate (chain) and its PEM private key, by path.
struct TlsFiles {
  std::string cert, key;
};

/// One address the server listens on, and what it allows there.
struct Listener {
  Listener() = default;
  Listener(std::string where) : address(std::move(where)) {}  // NOLINT: implicit on purpose
  Listener(const char* where) : address(where) {}             // NOLINT: implicit on purpose
  /// The defaults for `address`, except on a loopback address: there every
  /// client is this machine, one source, so `max_per_source` is the whole
  /// `max_connections` (a kiosk browser opens several connections).
  static Listener from(std::string address);

  /// "127.0.0.1:8080", "0.0.0.0:8443", "[::1]:8080"; port 0 picks a free one.
  std::string address;
  /// Set: HTTPS and WSS only, with this certificate and key (see tls.hpp).
  std::optional<TlsFiles> tls;
  size_t max_connections = 32;  ///< HTTP and WebSocket connections open at once on this listener
  size_t max_per_source = 8;    ///< of those, from one source IP address
  /// Names (no port: "chair.local") accepted in `Host` besides IP literals,
  /// compared without regard to case.
  std::vector<std::string> host_names;
};

struct ServerOptions {
  std::vector<Listener> listen;
  size_t max_message = 64 * 1024;
  size_t max_queue = 1024 * 1024;
  unsigned max_messages_per_s = 200;
  size_t max_frames_per_message = 256;   ///< WebSocket frames in one message, empty ones included
  unsigned request_timeout_ms = 10'000;  ///< for a complete HTTP request (and the TLS handshake)
  /// The message-rate limiter's clock; nullptr: the steady clock. Must
  /// outlive the server. (Deadlines on sockets run on Asio's timers.)
  DriverClock* clock = nullptr;
};

class Server {
 public:
  Server(ServerOptions options, Handlers handlers);
  ~Server();  ///< stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Loads the listeners' TLS files, binds every listen address and starts
  /// the thread. Errors: invalid_argument (an address that does not parse,
  /// a budget of 0), io_error (in use, not allowed; a certificate or key
  /// that cannot be loaded or do not match), with the address or the file
  /// in the reason.
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
/// The same for a listener: "https://..." when it has TLS.
std::string listener_url(const Listener& listener, uint16_t port);
/// True for 127.0.0.0/8, ::1 and "localhost".
bool is_loopback(std::string_view listen);

}  // namespace rtukit::web
