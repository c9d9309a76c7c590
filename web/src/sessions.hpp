// The web server's sessions (private to web/src): the listener and server
// state, a connection's budget slot, the WebSocket frame meter and the HTTP
// and WebSocket session templates over a stream. The sessions are templates
// over the stream (plain TCP, or TLS over it), so both listeners run the same
// code and the same protections; each stream's sessions are compiled in a
// file of their own (sessions_plain.cpp, sessions_tls.cpp) so the build
// compiles them side by side (issue 39: this was one 5-minute file under ASan,
// on the build's critical path).
#pragma once

#include <fmt/core.h>
#include <openssl/ssl.h>

#include <boost/asio/compose.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <chrono>
#include <deque>
#include <exception>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>

#include "rtukit/io/asio_fwd.hpp"  // rtukit::asio
#include "rtukit/web/guard.hpp"
#include "rtukit/web/server.hpp"

namespace rtukit::web {
namespace detail {

namespace ssl = asio::ssl;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using PlainStream = beast::tcp_stream;
using TlsStream = beast::ssl_stream<beast::tcp_stream>;

template <class Stream>
constexpr bool kTls = std::is_same_v<Stream, TlsStream>;

inline bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; };
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

// Every response, whoever wrote it, including the WebSocket 101.
template <class Fields>
void set_security_headers(Fields& f) {
  f.set(http::field::server, "rtukit");
  f.set("Content-Security-Policy", "default-src 'self'; frame-ancestors 'none'");
  f.set("X-Content-Type-Options", "nosniff");
  f.set("Referrer-Policy", "no-referrer");
}

struct ListenerState {
  Listener options;
  uint16_t port = 0;
  bool loopback = false;
  std::unique_ptr<tcp::acceptor> acceptor;
  std::unique_ptr<ssl::context> tls;
  std::unique_ptr<asio::steady_timer> retry;  ///< the pause after a failed accept
  // The budget in use, under Impl::mutex.
  size_t open = 0;
  std::map<asio::ip::address, size_t> per_source;
};

}  // namespace detail

// The server's state, shared by its sessions.
struct Server::Impl {
  // Destroyed by hand, first: its pending handlers own sessions, and their
  // destructors use the members below (the budgets, the TLS contexts).
  ~Impl() {
    for (detail::ListenerState& l : listeners) {
      l.acceptor.reset();
      l.retry.reset();
    }
    timers.clear();
    io.reset();
  }
  ServerOptions options;
  Handlers handlers;
  std::optional<asio::io_context> io{std::in_place, 1};
  std::vector<detail::ListenerState> listeners;  ///< fixed once start() returned
  std::thread thread;
  std::vector<std::shared_ptr<asio::steady_timer>> timers;
  uint64_t next_id = 1;
  mutable std::mutex mutex;  ///< guards sockets (connections() from other threads) and the budgets
  std::map<uint64_t, std::weak_ptr<Socket>> sockets;
  bool stopped = false;

  void accept(size_t index);
  void serve(size_t index, asio::ip::tcp::socket socket);
};

namespace detail {

// One connection's place in its listener's budget, from accept to the end of
// the connection (it moves from the HTTP session to the WebSocket session).
class Slot {
 public:
  static std::optional<Slot> take(Server::Impl& server, size_t listener, const asio::ip::address& source) {
    std::lock_guard lock(server.mutex);
    ListenerState& l = server.listeners[listener];
    size_t& mine = l.per_source[source];
    if (l.open >= l.options.max_connections || mine >= l.options.max_per_source) {
      if (mine == 0) l.per_source.erase(source);
      return std::nullopt;
    }
    ++l.open;
    ++mine;
    return Slot(server, listener, source);
  }
  Slot(Slot&& other) noexcept
      : server_(std::exchange(other.server_, nullptr)), listener_(other.listener_), source_(other.source_) {}
  Slot& operator=(Slot&&) = delete;
  ~Slot() {
    if (!server_) return;
    std::lock_guard lock(server_->mutex);
    ListenerState& l = server_->listeners[listener_];
    --l.open;
    if (--l.per_source[source_] == 0) l.per_source.erase(source_);
  }

 private:
  Slot(Server::Impl& server, size_t listener, asio::ip::address source)
      : server_(&server), listener_(listener), source_(source) {}
  Server::Impl* server_;
  size_t listener_;
  asio::ip::address source_;
};

// Sees every byte a WebSocket client sends after the upgrade and follows the
// frame headers (RFC 6455 section 5.2). Beast says nothing about frames: an
// empty non-final frame never completes a read (Beast loops to the next
// frame), so without this a client could send them forever, unseen by the
// size limit and the message rate limit. `on_frame(opcode, fin)` returning
// false fails the read that carried the frame, which ends the session.
template <class Next>
class FrameMeter {
 public:
  using executor_type = typename Next::executor_type;
  using next_layer_type = Next;

  explicit FrameMeter(Next&& next) : next_(std::move(next)) {}
  executor_type get_executor() noexcept { return next_.get_executor(); }
  Next& next_layer() noexcept { return next_; }
  const Next& next_layer() const noexcept { return next_; }

  std::function<bool(unsigned opcode, bool fin)> on_frame;

  template <class Buffers, class Token>
  auto async_read_some(const Buffers& buffers, Token&& token) {
    return asio::async_compose<Token, void(beast::error_code, size_t)>(
        [this, buffers, started = false](auto& self, beast::error_code ec = {}, size_t n = 0) mutable {
          if (!started) {
            started = true;
            next_.async_read_some(buffers, std::move(self));
            return;
          }
          if (!ec && !feed(buffers, n)) ec = asio::error::message_size;
          self.complete(ec, n);
        },
        token, next_);
  }

  template <class Buffers, class Token>
  auto async_write_some(const Buffers& buffers, Token&& token) {
    return next_.async_write_some(buffers, std::forward<Token>(token));
  }

 private:
  template <class Buffers>
  bool feed(const Buffers& buffers, size_t n) {
    const auto read = beast::buffers_prefix(n, buffers);
    for (const asio::const_buffer b : beast::buffers_range_ref(read)) {
      const auto* p = static_cast<const uint8_t*>(b.data());
      size_t left = b.size();
      while (left > 0) {
        if (skip_ > 0) {  // payload: not ours to look at
          const size_t k = static_cast<size_t>(std::min<uint64_t>(skip_, left));
          skip_ -= k;
          p += k;
          left -= k;
          continue;
        }
        head_[have_++] = *p++;
        --left;
        if (have_ < 2) continue;
        const unsigned len7 = head_[1] & 0x7Fu;
        const size_t need = 2 + (len7 == 126 ? 2 : len7 == 127 ? 8 : 0) + ((head_[1] & 0x80u) ? 4 : 0);
        if (have_ < need) continue;
        uint64_t len = len7;
        if (len7 == 126) len = (uint64_t{head_[2]} << 8) | head_[3];
        if (len7 == 127) {
          len = 0;
          for (size_t i = 2; i < 10; ++i) len = (len << 8) | head_[i];
        }
        have_ = 0;
        skip_ = len;
        if (on_frame && !on_frame(head_[0] & 0x0Fu, (head_[0] & 0x80u) != 0)) return false;
      }
    }
    return true;
  }

  Next next_;
  uint8_t head_[14] = {};
  size_t have_ = 0;
  uint64_t skip_ = 0;
};

// How Beast closes a WebSocket's next layer: through the meter, as the layer under it would be.
template <class Next>
void teardown(beast::role_type role, FrameMeter<Next>& stream, beast::error_code& ec) {
  using beast::websocket::teardown;
  teardown(role, stream.next_layer(), ec);
}
template <class Next, class Handler>
void async_teardown(beast::role_type role, FrameMeter<Next>& stream, Handler&& handler) {
  using beast::websocket::async_teardown;
  async_teardown(role, stream.next_layer(), std::forward<Handler>(handler));
}

template <class Stream>
class WsSession final : public Socket, public std::enable_shared_from_this<WsSession<Stream>> {
 public:
  WsSession(Server::Impl& server, uint64_t id, HttpRequest request, std::string peer_address, Stream&& stream,
            Slot slot)
      : Socket(id, std::move(request), std::move(peer_address)),
        server_(server),
        slot_(std::move(slot)),
        ws_(std::move(stream)) {
    ws_.next_layer().on_frame = [this](unsigned opcode, bool fin) { return on_frame(opcode, fin); };
  }

  void start(http::request<http::string_body> upgrade) {
    // Idle pings find a peer that vanished without a close (Wi-Fi gone); a
    // peer that does not answer a close handshake is cut off after 2 s.
    websocket::stream_base::timeout t{};
    t.handshake_timeout = std::chrono::seconds(2);
    t.idle_timeout = std::chrono::seconds(10);
    t.keep_alive_pings = true;
    ws_.set_option(t);
    ws_.set_option(
        websocket::stream_base::decorator([](websocket::response_type& res) { set_security_headers(res); }));
    ws_.read_message_max(server_.options.max_message);
    ws_.async_accept(upgrade, [self = this->shared_from_this()](beast::error_code ec) {
      if (ec) return self->finish();
      self->open_ = true;
      {
        std::lock_guard lock(self->server_.mutex);
        self->server_.sockets[self->id()] = self;
      }
      if (!self->call([&] {
            if (self->server_.handlers.opened) self->server_.handlers.opened(self);
          }))
        return;
      self->read();
    });
  }

  void send(std::string text) override {
    asio::post(ws_.get_executor(), [self = this->shared_from_this(), text = std::move(text)]() mutable {
      if (!self->open_ || self->closing_) return;
      self->queued_ += text.size();
      self->queue_.push_back(std::move(text));
      // A client that does not read cannot take a close frame either: cut.
      if (self->queued_ > self->server_.options.max_queue) return self->cut();
      if (self->queue_.size() == 1) self->write();
    });
  }

  void close(std::string reason) override {
    asio::post(ws_.get_executor(), [self = this->shared_from_this(), reason = std::move(reason)]() {
      if (!self->open_ || self->closing_) return;
      self->closing_ = true;
      if (reason.size() > 120) return self->do_close(reason.substr(0, 120));
      self->do_close(reason);
    });
  }

  bool is_open() const override { return open_ && !closing_; }

 private:
  // Runs an application handler; one that throws closes this socket rather
  // than ending the server's thread (and with it every other client).
  template <class F>
  bool call(F&& f) {
    try {
      f();
      return true;
    } catch (...) {
      if (!closing_) {
        closing_ = true;
        do_close("internal error");
      }
      return false;
    }
  }

  // Called by the meter for each frame header, inside a read.
  bool on_frame(unsigned opcode, bool fin) {
    if (opcode & 0x8u) return within_rate();  // ping, pong, close: Beast answers them, but they cost
    if (++frames_ > server_.options.max_frames_per_message) return false;
    if (fin) frames_ = 0;
    return true;
  }

  void cut() {
    closing_ = true;
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().close(ignored);  // pending operations end: finish()
  }

  void do_close(const std::string& reason) {
    // A peer that does not answer the close handshake is cut off by the timeout.
    ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, reason),
                    [self = this->shared_from_this()](beast::error_code) { self->finish(); });
  }

  void read() {
    ws_.async_read(buffer_, [self = this->shared_from_this()](beast::error_code ec, size_t) {
      if (ec) return self->finish();
      if (!self->within_rate()) {
        self->buffer_.consume(self->buffer_.size());
        self->closing_ = true;
        return self->do_close("too many messages");
      }
      const std::string text = beast::buffers_to_string(self->buffer_.data());
      self->buffer_.consume(self->buffer_.size());
      if (!self->closing_ && self->server_.handlers.message &&
          !self->call([&] { self->server_.handlers.message(self, text); }))
        return;
      self->read();
    });
  }

  // `max_messages_per_s`, bursts up to two seconds' worth (guard.hpp); a
  // new connection starts with a full bucket.
  bool within_rate() {
    if (!rate_) rate_.emplace(server_.options.max_messages_per_s);
    return rate_->take(clock_or_steady(server_.options.clock).now());
  }

  void write() {
    ws_.text(true);
    ws_.async_write(asio::buffer(queue_.front()),
                    [self = this->shared_from_this()](beast::error_code ec, size_t) {
                      if (ec) return self->finish();
                      self->queued_ -= self->queue_.front().size();
                      self->queue_.pop_front();
                      if (!self->queue_.empty() && !self->closing_) self->write();
                    });
  }

  // Called once per ending path; the handlers hear of it once.
  void finish() {
    if (finished_) return;
    finished_ = true;
    const bool was_open = open_;
    open_ = false;
    {
      std::lock_guard lock(server_.mutex);
      server_.sockets.erase(id());
    }
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().close(ignored);
    if (was_open && server_.handlers.closed) {
      try {
        server_.handlers.closed(this->shared_from_this());
      } catch (...) {  // nothing left to close; the server goes on
      }
    }
  }

  Server::Impl& server_;
  Slot slot_;
  websocket::stream<FrameMeter<Stream>> ws_;
  beast::flat_buffer buffer_;
  std::deque<std::string> queue_;
  size_t queued_ = 0;
  size_t frames_ = 0;  ///< frames of the message being received
  bool open_ = false, closing_ = false, finished_ = false;
  std::optional<TokenBucket> rate_;  ///< the message rate, made at the first message
};

// Whether a request may reach the handlers (RFC 6455 section 10.2; DNS
// rebinding: a page on evil.example whose name now points here carries
// Host: evil.example). The reason of a refusal, or nullopt.
inline std::optional<std::string_view> refusal(const ListenerState& l,
                                               const http::request<http::string_body>& req) {
  if (req.count(http::field::host) != 1) return "Host not allowed";
  const auto raw_host = req[http::field::host];
  const std::string_view host(raw_host.data(), raw_host.size());
  std::string_view name, port_text;
  if (!host.empty() && host.front() == '[') {
    const size_t close = host.find(']');
    if (close == std::string_view::npos) return "Host not allowed";
    name = host.substr(1, close - 1);
    port_text = host.substr(close + 1);
  } else {
    const size_t colon = host.find(':');
    if (colon != std::string_view::npos && host.find(':', colon + 1) != std::string_view::npos)
      return "Host not allowed";  // an IPv6 address must be in brackets
    name = host.substr(0, colon);
    port_text = colon == std::string_view::npos ? std::string_view{} : host.substr(colon);
  }
  unsigned port = l.options.tls ? 443 : 80;  // left out: the scheme's default
  if (!port_text.empty()) {
    if (port_text.front() != ':') return "Host not allowed";
    port_text.remove_prefix(1);
    if (port_text.empty() || port_text.size() > 5 ||
        port_text.find_first_not_of("0123456789") != std::string_view::npos)
      return "Host not allowed";
    port = static_cast<unsigned>(std::stoul(std::string(port_text)));
  }
  if (name.empty() || port != l.port) return "Host not allowed";
  boost::system::error_code ec;
  const bool bracketed = host.front() == '[';
  bool allowed = false;
  if (bracketed) {
    (void)asio::ip::make_address_v6(std::string(name), ec);
    allowed = !ec;
  } else {
    (void)asio::ip::make_address_v4(std::string(name), ec);
    allowed = !ec || (l.loopback && iequals(name, "localhost"));
    for (const std::string& n : l.options.host_names) allowed = allowed || iequals(name, n);
  }
  if (!allowed) return "Host not allowed";

  const size_t origins = req.count(http::field::origin);
  if (origins == 0) return std::nullopt;  // not a browser: no page can steer it
  if (origins > 1) return "Origin not allowed";
  const std::string expected = std::string(l.options.tls ? "https://" : "http://") + std::string(host);
  const auto origin = req[http::field::origin];
  if (!iequals(std::string_view(origin.data(), origin.size()), expected)) return "Origin not allowed";
  return std::nullopt;
}

template <class Stream>
class HttpSession final : public std::enable_shared_from_this<HttpSession<Stream>> {
 public:
  HttpSession(Server::Impl& server, size_t listener, Slot slot, asio::ip::address source, std::string peer,
              Stream&& stream)
      : server_(server),
        listener_(listener),
        slot_(std::move(slot)),
        source_(std::move(source)),
        peer_(std::move(peer)),
        stream_(std::move(stream)) {}

  void start() {
    // One deadline from the connection's first byte to its first complete
    // request, TLS handshake included: a client that trickles (slowloris)
    // keeps its slot no longer than that.
    lowest().expires_after(timeout());
    if constexpr (kTls<Stream>) {
      stream_.async_handshake(
          ssl::stream_base::server, [self = this->shared_from_this()](beast::error_code ec) {
            if (ec) return;  // plain HTTP, a bad client hello, the deadline: closed as the session ends
            self->read();
          });
    } else {
      read();
    }
  }

 private:
  std::chrono::milliseconds timeout() const {
    return std::chrono::milliseconds(server_.options.request_timeout_ms);
  }
  beast::tcp_stream& lowest() { return beast::get_lowest_layer(stream_); }
  const ListenerState& listener() const { return server_.listeners[listener_]; }

  void read() {
    parser_.emplace();
    parser_->body_limit(server_.options.max_message);
    parser_->header_limit(16 * 1024);
    http::async_read(stream_, buffer_, *parser_,
                     [self = this->shared_from_this()](beast::error_code ec, size_t) {
                       if (ec == http::error::body_limit || ec == http::error::header_limit)
                         return self->reply_error(413, "request too large");
                       if (ec) return;  // closed, a timeout, garbage: the session ends, and its stream closes
                       self->handle(self->parser_->release());
                     });
  }

  HttpRequest convert(const http::request<http::string_body>& req) const {
    HttpRequest out;
    out.method = std::string(req.method_string());
    const std::string target(req.target());
    const size_t q = target.find('?');
    out.path = target.substr(0, q);
    if (q != std::string::npos) out.query = target.substr(q + 1);
    out.body = req.body();
    out.peer = peer_;
    out.listener = listener_;
    const auto field = [&](http::field f) {
      const auto it = req.find(f);
      return it == req.end() ? std::string() : std::string(it->value());
    };
    out.user_agent = field(http::field::user_agent);
    out.host = field(http::field::host);
    out.origin = field(http::field::origin);
    out.cookie = field(http::field::cookie);
    out.secure = kTls<Stream>;
    return out;
  }

  void handle(http::request<http::string_body> req) {
    if (const auto why = refusal(listener(), req))
      return reply(
          {.status = 403, .content_type = "text/plain; charset=utf-8", .body = std::string(*why) + "\n"},
          false);
    HttpRequest request = convert(req);
    if (websocket::is_upgrade(req)) {
      std::optional<HttpResponse> refused;
      try {
        if (server_.handlers.upgrade) refused = server_.handlers.upgrade(request);
      } catch (...) {
        refused = internal_error();
      }
      if (refused) return reply(*refused, false);
      lowest().expires_never();  // the WebSocket keeps its own time
      auto ws =
          std::make_shared<WsSession<Stream>>(server_, server_.next_id++, std::move(request),
                                              source_.to_string(), std::move(stream_), std::move(slot_));
      ws->start(std::move(req));
      return;
    }
    HttpResponse r{.status = 404, .content_type = "text/plain; charset=utf-8", .body = "not found\n"};
    try {
      if (server_.handlers.http) r = server_.handlers.http(request);
    } catch (...) {
      r = internal_error();
    }
    reply(r, req.keep_alive());
  }

  static HttpResponse internal_error() {
    return {.status = 500, .content_type = "text/plain; charset=utf-8", .body = "internal error\n"};
  }

  void reply_error(unsigned status, std::string text) {
    reply({.status = status, .content_type = "text/plain; charset=utf-8", .body = std::move(text) + "\n"},
          false);
  }

  void reply(const HttpResponse& r, bool keep_alive) {
    auto res = std::make_shared<http::response<http::string_body>>(static_cast<http::status>(r.status), 11);
    for (const auto& [name, value] : r.headers) {
      // A line break in a field would let the application's data write headers of its own.
      if (name.empty() || name.find_first_of("\r\n:") != std::string::npos ||
          value.find_first_of("\r\n") != std::string::npos)
        continue;
      res->insert(name, value);
    }
    res->set(http::field::content_type, r.content_type);
    res->set(http::field::cache_control, r.cache_control);
    set_security_headers(*res);
    res->body() = r.body;
    res->keep_alive(keep_alive);
    res->prepare_payload();
    lowest().expires_after(timeout());  // a client that does not read its answer does not keep the slot
    http::async_write(stream_, *res,
                      [self = this->shared_from_this(), res, keep_alive](beast::error_code ec, size_t) {
                        if (ec) return;
                        if (!keep_alive) return self->shut();
                        self->lowest().expires_after(self->timeout());  // for the next request
                        self->read();
                      });
  }

  void shut() {
    if constexpr (kTls<Stream>) {
      // close_notify, so the client knows the answer is whole; a client that
      // does not answer it is closed after a short wait.
      lowest().expires_after(std::chrono::seconds(2));
      stream_.async_shutdown([self = this->shared_from_this()](beast::error_code) {});
    } else {
      beast::error_code ignored;
      stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    }
  }

  Server::Impl& server_;
  size_t listener_;
  Slot slot_;
  asio::ip::address source_;
  std::string peer_;
  Stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

/// Starts the HTTP session of an accepted plain TCP connection (sessions_plain.cpp).
void serve_plain(Server::Impl& server, size_t listener, Slot slot, const asio::ip::address& source,
                 std::string peer, tcp::socket socket);
/// Starts the TLS handshake and HTTP session of an accepted connection (sessions_tls.cpp).
void serve_tls(Server::Impl& server, size_t listener, Slot slot, const asio::ip::address& source,
               std::string peer, tcp::socket socket, ssl::context& tls);

}  // namespace detail
}  // namespace rtukit::web
