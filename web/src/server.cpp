// HTTP and WebSocket on Boost.Beast: one io_context, one thread. Each
// connection is a session object kept alive by its own pending operations
// (Beast's usual shape); the server only keeps weak references, so a
// connection that errors simply goes away.
#include "rtukit/web/server.hpp"

#include <fmt/core.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

namespace rtukit::web {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;

std::string peer_of(const tcp::socket& s) {
  boost::system::error_code ec;
  const tcp::endpoint e = s.remote_endpoint(ec);
  if (ec) return "?";
  return e.address().is_v6() ? fmt::format("[{}]:{}", e.address().to_string(), e.port())
                             : fmt::format("{}:{}", e.address().to_string(), e.port());
}

// "host:port" or "[v6]:port".
bool split_listen(std::string_view listen, std::string& host, uint16_t& port) {
  const size_t colon = listen.rfind(':');
  if (colon == std::string_view::npos) return false;
  host = std::string(listen.substr(0, colon));
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  const std::string p(listen.substr(colon + 1));
  if (p.empty() || p.size() > 5 || p.find_first_not_of("0123456789") != std::string::npos) return false;
  const unsigned long n = std::stoul(p);
  if (n > 65535) return false;
  port = static_cast<uint16_t>(n);
  if (host == "localhost") host = "127.0.0.1";
  return !host.empty();
}

}  // namespace

std::string HttpRequest::param(std::string_view key) const {
  size_t at = 0;
  while (at <= query.size()) {
    size_t end = query.find('&', at);
    if (end == std::string::npos) end = query.size();
    const std::string_view pair(query.data() + at, end - at);
    const size_t eq = pair.find('=');
    if (pair.substr(0, eq) == key) {
      std::string v(eq == std::string_view::npos ? std::string_view{} : pair.substr(eq + 1));
      for (char& c : v)
        if (c == '+') c = ' ';
      return v;
    }
    at = end + 1;
  }
  return {};
}

std::string url_of(std::string_view listen, uint16_t port) {
  std::string host;
  uint16_t ignored = 0;
  if (!split_listen(listen, host, ignored)) return std::string(listen);
  if (host.find(':') != std::string::npos) host = "[" + host + "]";
  return fmt::format("http://{}:{}", host, port);
}

bool is_loopback(std::string_view listen) {
  std::string host;
  uint16_t port = 0;
  if (!split_listen(listen, host, port)) return false;
  boost::system::error_code ec;
  const auto a = asio::ip::make_address(host, ec);
  return !ec && a.is_loopback();
}

// ---------------------------------------------------------------- the server

struct Server::Impl {
  // Destroyed by hand, first: its pending handlers own sessions, and their
  // destructors use the members below.
  ~Impl() {
    acceptors.clear();
    timers.clear();
    io.reset();
  }
  ServerOptions options;
  Handlers handlers;
  std::optional<asio::io_context> io{std::in_place, 1};
  std::vector<std::unique_ptr<tcp::acceptor>> acceptors;
  std::vector<uint16_t> ports;
  std::thread thread;
  std::vector<std::shared_ptr<asio::steady_timer>> timers;
  uint64_t next_id = 1;
  mutable std::mutex mutex;  ///< guards sessions (connections() from other threads)
  std::map<uint64_t, std::weak_ptr<Socket>> sockets;
  size_t http_sessions = 0;
  bool stopped = false;

  size_t open_count() const {
    std::lock_guard lock(mutex);
    return sockets.size() + http_sessions;
  }
  void accept(size_t index);
};

namespace {

class WsSession final : public Socket, public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(Server::Impl& server, uint64_t id, HttpRequest request, tcp::socket socket)
      : Socket(id, std::move(request)), server_(server), ws_(std::move(socket)) {}

  void start(http::request<http::string_body> upgrade) {
    // Idle pings find a peer that vanished without a close (Wi-Fi gone); a
    // peer that does not answer a close handshake is cut off after 2 s.
    websocket::stream_base::timeout t{};
    t.handshake_timeout = std::chrono::seconds(2);
    t.idle_timeout = std::chrono::seconds(10);
    t.keep_alive_pings = true;
    ws_.set_option(t);
    ws_.read_message_max(server_.options.max_message);
    ws_.async_accept(upgrade, [self = shared_from_this()](beast::error_code ec) {
      if (ec) return self->finish();
      self->open_ = true;
      {
        std::lock_guard lock(self->server_.mutex);
        self->server_.sockets[self->id()] = self;
      }
      if (self->server_.handlers.opened) self->server_.handlers.opened(self);
      self->read();
    });
  }

  void send(std::string text) override {
    asio::post(ws_.get_executor(), [self = shared_from_this(), text = std::move(text)]() mutable {
      if (!self->open_ || self->closing_) return;
      self->queued_ += text.size();
      self->queue_.push_back(std::move(text));
      // A client that does not read cannot take a close frame either: cut.
      if (self->queued_ > self->server_.options.max_queue) return self->cut();
      if (self->queue_.size() == 1) self->write();
    });
  }

  void close(std::string reason) override {
    asio::post(ws_.get_executor(), [self = shared_from_this(), reason = std::move(reason)]() {
      if (!self->open_ || self->closing_) return;
      self->closing_ = true;
      if (reason.size() > 120) return self->do_close(reason.substr(0, 120));
      self->do_close(reason);
    });
  }

  bool is_open() const override { return open_ && !closing_; }

 private:
  void cut() {
    closing_ = true;
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().close(ignored);  // pending operations end: finish()
  }

  void do_close(const std::string& reason) {
    // A peer that does not answer the close handshake is cut off by the timeout.
    ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, reason),
                    [self = shared_from_this()](beast::error_code) { self->finish(); });
  }

  void read() {
    ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, size_t) {
      if (ec) return self->finish();
      if (!self->within_rate()) {
        self->buffer_.consume(self->buffer_.size());
        self->closing_ = true;
        return self->do_close("too many messages");
      }
      const std::string text = beast::buffers_to_string(self->buffer_.data());
      self->buffer_.consume(self->buffer_.size());
      if (!self->closing_ && self->server_.handlers.message) self->server_.handlers.message(self, text);
      self->read();
    });
  }

  // A token bucket: `max_messages_per_s`, bursts up to two seconds' worth.
  bool within_rate() {
    const auto now = Clock::now();
    const double rate = server_.options.max_messages_per_s;
    tokens_ = std::min(2 * rate, tokens_ + std::chrono::duration<double>(now - refilled_).count() * rate);
    refilled_ = now;
    if (tokens_ < 1) return false;
    tokens_ -= 1;
    return true;
  }

  void write() {
    ws_.text(true);
    ws_.async_write(asio::buffer(queue_.front()), [self = shared_from_this()](beast::error_code ec, size_t) {
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
    if (was_open && server_.handlers.closed) server_.handlers.closed(shared_from_this());
  }

  Server::Impl& server_;
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  std::deque<std::string> queue_;
  size_t queued_ = 0;
  bool open_ = false, closing_ = false, finished_ = false;
  double tokens_ = 0;
  Clock::time_point refilled_ = Clock::now() - std::chrono::seconds(2);
};

class HttpSession final : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(Server::Impl& server, size_t listener, tcp::socket socket)
      : server_(server), listener_(listener), stream_(std::move(socket)) {
    std::lock_guard lock(server_.mutex);
    ++server_.http_sessions;
  }
  ~HttpSession() {
    std::lock_guard lock(server_.mutex);
    --server_.http_sessions;
  }

  void read() {
    parser_.emplace();
    parser_->body_limit(server_.options.max_message);
    parser_->header_limit(16 * 1024);
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, size_t) {
      if (ec == http::error::body_limit || ec == http::error::header_limit)
        return self->reply_error(413, "request too large");
      if (ec) return self->shut();
      self->handle(self->parser_->release());
    });
  }

 private:
  HttpRequest convert(const http::request<http::string_body>& req) const {
    HttpRequest out;
    out.method = std::string(req.method_string());
    const std::string target(req.target());
    const size_t q = target.find('?');
    out.path = target.substr(0, q);
    if (q != std::string::npos) out.query = target.substr(q + 1);
    out.body = req.body();
    out.peer = peer_of(stream_.socket());
    out.listener = listener_;
    if (auto it = req.find(http::field::user_agent); it != req.end())
      out.user_agent = std::string(it->value());
    return out;
  }

  void handle(http::request<http::string_body> req) {
    HttpRequest request = convert(req);
    if (websocket::is_upgrade(req)) {
      if (server_.handlers.upgrade) {
        if (std::optional<HttpResponse> refusal = server_.handlers.upgrade(request))
          return reply(*refusal, false);
      }
      stream_.expires_never();
      auto ws = std::make_shared<WsSession>(server_, server_.next_id++, std::move(request),
                                            stream_.release_socket());
      ws->start(std::move(req));
      return;
    }
    HttpResponse r{.status = 404, .content_type = "text/plain; charset=utf-8", .body = "not found\n"};
    if (server_.handlers.http) r = server_.handlers.http(request);
    reply(r, req.keep_alive());
  }

  void reply_error(unsigned status, std::string text) {
    reply({.status = status, .content_type = "text/plain; charset=utf-8", .body = std::move(text) + "\n"},
          false);
  }

  void reply(const HttpResponse& r, bool keep_alive) {
    auto res = std::make_shared<http::response<http::string_body>>(static_cast<http::status>(r.status), 11);
    res->set(http::field::server, "rtukit");
    res->set(http::field::content_type, r.content_type);
    res->set(http::field::cache_control, r.cache_control);
    res->set("X-Content-Type-Options", "nosniff");
    res->body() = r.body;
    res->keep_alive(keep_alive);
    res->prepare_payload();
    http::async_write(stream_, *res,
                      [self = shared_from_this(), res, keep_alive](beast::error_code ec, size_t) {
                        if (ec || !keep_alive) return self->shut();
                        self->read();
                      });
  }

  void shut() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
  }

  Server::Impl& server_;
  size_t listener_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

}  // namespace

void Server::Impl::accept(size_t index) {
  acceptors[index]->async_accept(asio::make_strand(*io),
                                 [this, index](beast::error_code ec, tcp::socket socket) {
                                   if (ec == asio::error::operation_aborted || stopped) return;
                                   if (!ec) {
                                     if (open_count() >= options.max_connections) {
                                       beast::error_code ignored;
                                       socket.close(ignored);  // full: closed at once
                                     } else {
                                       std::make_shared<HttpSession>(*this, index, std::move(socket))->read();
                                     }
                                   }
                                   accept(index);
                                 });
}

Server::Server(ServerOptions options, Handlers handlers) : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  impl_->handlers = std::move(handlers);
}

Server::~Server() {
  stop();
}

rtukit::Status Server::start() {
  Impl& s = *impl_;
  for (const std::string& listen : s.options.listen) {
    std::string host;
    uint16_t port = 0;
    boost::system::error_code ec;
    if (!split_listen(listen, host, port))
      return rtukit::Status(Errc::invalid_argument, fmt::format("{}: expected HOST:PORT", listen));
    const auto address = asio::ip::make_address(host, ec);
    if (ec) return rtukit::Status(Errc::invalid_argument, fmt::format("{}: not an IP address", listen));
    auto acceptor = std::make_unique<tcp::acceptor>(*s.io);
    const tcp::endpoint endpoint(address, port);
    acceptor->open(endpoint.protocol(), ec);
    if (!ec) acceptor->set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor->bind(endpoint, ec);
    if (!ec) acceptor->listen(asio::socket_base::max_listen_connections, ec);
    if (ec) return rtukit::Status(Errc::io_error, fmt::format("{}: {}", listen, ec.message()));
    s.ports.push_back(acceptor->local_endpoint().port());
    s.acceptors.push_back(std::move(acceptor));
  }
  for (size_t i = 0; i < s.acceptors.size(); ++i) s.accept(i);
  s.thread = std::thread([&s] { s.io->run(); });
  return {};
}

void Server::stop() {
  Impl& s = *impl_;
  if (!s.thread.joinable()) return;
  asio::post(*s.io, [&s] {
    s.stopped = true;
    for (auto& a : s.acceptors) {
      beast::error_code ignored;
      a->close(ignored);
    }
    for (auto& t : s.timers) t->cancel();
  });
  // Close the WebSockets politely, then stop the loop whatever is left.
  std::vector<SocketPtr> open;
  {
    std::lock_guard lock(s.mutex);
    for (auto& [id, w] : s.sockets)
      if (auto p = w.lock()) open.push_back(p);
  }
  for (auto& p : open) p->close("server stopping");
  asio::steady_timer grace(*s.io, std::chrono::milliseconds(200));
  grace.async_wait([&s](beast::error_code) { s.io->stop(); });
  s.thread.join();
}

std::vector<uint16_t> Server::ports() const {
  return impl_->ports;
}

void Server::post(std::function<void()> fn) {
  asio::post(*impl_->io, std::move(fn));
}

namespace {

struct Ticker : std::enable_shared_from_this<Ticker> {
  std::shared_ptr<asio::steady_timer> timer;
  std::chrono::milliseconds period;
  std::function<void()> fn;
  void arm() {
    timer->expires_at(timer->expiry() + period);
    timer->async_wait([self = shared_from_this()](beast::error_code ec) {
      if (ec) return;  // cancelled: stop()
      self->fn();
      self->arm();
    });
  }
};

}  // namespace

void Server::every(unsigned period_ms, std::function<void()> fn) {
  auto ticker = std::make_shared<Ticker>();
  ticker->timer = std::make_shared<asio::steady_timer>(*impl_->io, std::chrono::steady_clock::now());
  ticker->period = std::chrono::milliseconds(period_ms);
  ticker->fn = std::move(fn);
  impl_->timers.push_back(ticker->timer);
  ticker->arm();
}

size_t Server::connections() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->sockets.size();
}

}  // namespace rtukit::web
