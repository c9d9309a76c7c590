// HTTP and WebSocket on Boost.Beast: one io_context, one thread. Each
// connection is a session object kept alive by its own pending operations
// (Beast's usual shape); the server only keeps weak references, so a
// connection that errors simply goes away. This file holds the server: its
// listeners, budgets, accept loop and timers; the sessions are in
// sessions.hpp.
#include <fmt/core.h>
#include <openssl/ssl.h>

#include "sessions.hpp"

namespace rtukit::web {
using namespace detail;
namespace {

std::string peer_of(const tcp::endpoint& e) {
  return e.address().is_v6() ? fmt::format("[{}]:{}", e.address().to_string(), e.port())
                             : fmt::format("{}:{}", e.address().to_string(), e.port());
}

// A v4 client of a dual-stack listener arrives as ::ffff:a.b.c.d; it is the
// same source as a.b.c.d for the budgets, and reads better as such.
asio::ip::address plain_address(const asio::ip::address& a) {
  if (a.is_v6() && a.to_v6().is_v4_mapped()) return asio::ip::make_address_v4(asio::ip::v4_mapped, a.to_v6());
  return a;
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

Listener Listener::from(std::string address) {
  Listener l(std::move(address));
  if (is_loopback(l.address)) l.max_per_source = l.max_connections;
  return l;
}

std::string url_of(std::string_view listen, uint16_t port) {
  std::string host;
  uint16_t ignored = 0;
  if (!split_listen(listen, host, ignored)) return std::string(listen);
  if (host.find(':') != std::string::npos) host = "[" + host + "]";
  return fmt::format("http://{}:{}", host, port);
}

std::string listener_url(const Listener& listener, uint16_t port) {
  std::string url = url_of(listener.address, port);
  if (listener.tls && url.rfind("http://", 0) == 0) url.insert(4, "s");
  return url;
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

void Server::Impl::accept(size_t index) {
  ListenerState& l = listeners[index];
  l.acceptor->async_accept(asio::make_strand(*io), [this, index](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted || stopped) return;
    if (!ec) {
      serve(index, std::move(socket));
      return accept(index);
    }
    // Out of descriptors (EMFILE) fails again at once: pause rather than spin.
    listeners[index].retry->expires_after(std::chrono::milliseconds(100));
    listeners[index].retry->async_wait([this, index](beast::error_code e) {
      if (!e && !stopped) accept(index);
    });
  });
}

void Server::Impl::serve(size_t index, tcp::socket socket) {
  beast::error_code ec;
  const tcp::endpoint remote = socket.remote_endpoint(ec);
  if (ec) return;  // gone already; the socket closes here
  const asio::ip::address source = plain_address(remote.address());
  std::optional<Slot> slot = Slot::take(*this, index, source);
  if (!slot) {
    socket.close(ec);  // over the listener's or the source's budget: closed at once
    return;
  }
  std::string peer = peer_of(tcp::endpoint(source, remote.port()));
  ListenerState& l = listeners[index];
  if (l.tls) {
    serve_tls(*this, index, std::move(*slot), source, std::move(peer), std::move(socket), *l.tls);
  } else {
    serve_plain(*this, index, std::move(*slot), source, std::move(peer), std::move(socket));
  }
}

namespace {

// TLS 1.2 and newer, forward-secret AEAD suites only (1.3's are all that).
rtukit::Status load_tls(ssl::context& ctx, const Listener& l) {
  ctx.set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 | ssl::context::no_sslv3 |
                  ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1 | ssl::context::single_dh_use |
                  ssl::context::no_compression);
  SSL_CTX_set_min_proto_version(ctx.native_handle(), TLS1_2_VERSION);
  SSL_CTX_set_cipher_list(ctx.native_handle(), "ECDHE+AESGCM:ECDHE+CHACHA20");
  // An encrypted key must fail to load, not ask for a passphrase on the terminal.
  ctx.set_password_callback([](size_t, ssl::context::password_purpose) { return std::string(); });
  beast::error_code ec;
  ctx.use_certificate_chain_file(l.tls->cert, ec);
  if (ec)
    return rtukit::Status(Errc::io_error,
                          fmt::format("{}: certificate {}: {}", l.address, l.tls->cert, ec.message()));
  ctx.use_private_key_file(l.tls->key, ssl::context::pem, ec);
  if (ec)
    return rtukit::Status(Errc::io_error, fmt::format("{}: key {}: {}", l.address, l.tls->key, ec.message()));
  if (SSL_CTX_check_private_key(ctx.native_handle()) != 1)
    return rtukit::Status(Errc::io_error,
                          fmt::format("{}: {} is not the key of {}", l.address, l.tls->key, l.tls->cert));
  return {};
}

}  // namespace

Server::Server(ServerOptions options, Handlers handlers) : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  impl_->handlers = std::move(handlers);
}

Server::~Server() {
  stop();
}

rtukit::Status Server::start() {
  Impl& s = *impl_;
  std::vector<ListenerState> ready;
  for (const Listener& spec : s.options.listen) {
    const std::string& listen = spec.address;
    std::string host;
    uint16_t port = 0;
    boost::system::error_code ec;
    if (!split_listen(listen, host, port))
      return rtukit::Status(Errc::invalid_argument, fmt::format("{}: expected HOST:PORT", listen));
    const auto address = asio::ip::make_address(host, ec);
    if (ec) return rtukit::Status(Errc::invalid_argument, fmt::format("{}: not an IP address", listen));
    if (spec.max_connections == 0 || spec.max_per_source == 0)
      return rtukit::Status(Errc::invalid_argument, fmt::format("{}: a connection budget of 0", listen));
    ListenerState l;
    l.options = spec;
    l.loopback = address.is_loopback();
    if (spec.tls) {
      l.tls = std::make_unique<ssl::context>(ssl::context::tls_server);
      if (rtukit::Status e = load_tls(*l.tls, spec)) return e;
    }
    l.acceptor = std::make_unique<tcp::acceptor>(*s.io);
    l.retry = std::make_unique<asio::steady_timer>(*s.io);
    const tcp::endpoint endpoint(address, port);
    l.acceptor->open(endpoint.protocol(), ec);
    if (!ec) l.acceptor->set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) l.acceptor->bind(endpoint, ec);
    if (!ec) l.acceptor->listen(asio::socket_base::max_listen_connections, ec);
    if (ec) return rtukit::Status(Errc::io_error, fmt::format("{}: {}", listen, ec.message()));
    l.port = l.acceptor->local_endpoint().port();
    ready.push_back(std::move(l));
  }
  s.listeners = std::move(ready);
  for (size_t i = 0; i < s.listeners.size(); ++i) s.accept(i);
  s.thread = std::thread([&s] { s.io->run(); });
  return {};
}

void Server::stop() {
  Impl& s = *impl_;
  if (!s.thread.joinable()) return;
  asio::post(*s.io, [&s] {
    s.stopped = true;
    for (ListenerState& l : s.listeners) {
      beast::error_code ignored;
      l.acceptor->close(ignored);
      l.retry->cancel();
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
  std::vector<uint16_t> out;
  for (const ListenerState& l : impl_->listeners) out.push_back(l.port);
  return out;
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
  ticker->timer = std::make_shared<asio::steady_timer>(*impl_->io, asio::steady_timer::duration::zero());
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
