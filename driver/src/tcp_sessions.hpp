// rtukit driver (internal): TCP connections that no client can use to stall
// a server. Shared by the slave servers and the gateway.
//
//  - answers leave through a bounded buffer written asynchronously: a client
//    that sends and never reads is disconnected when the buffer passes
//    ServerOptions::max_pending_output, and nobody else ever waits for it;
//  - a connection that sends nothing for idle_timeout is closed;
//  - at most max_connections at once; more are accepted and closed at once;
//  - accept() failing (EMFILE: out of descriptors) pauses 100 ms instead of
//    spinning.
// Everything runs on the io_context's thread, except reply_from_any_thread().
#pragma once

#include <array>
#include <asio.hpp>
#include <cstring>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "rtukit/core/mbap.hpp"
#include "rtukit/driver/slave_server.hpp"

namespace rtukit {

/// What an acceptor and its sessions share. Sessions hold it by shared_ptr,
/// so a session that outlives its server stays valid.
struct TcpShared {
  ServerOptions options;
  ServerStats stats;
  unsigned live = 0;
};

class TcpSession : public std::enable_shared_from_this<TcpSession> {
 public:
  TcpSession(asio::ip::tcp::socket socket, std::shared_ptr<TcpShared> shared)
      : socket_(std::move(socket)), idle_(socket_.get_executor()), shared_(std::move(shared)) {
    ++shared_->live;
  }
  virtual ~TcpSession() { --shared_->live; }
  TcpSession(const TcpSession&) = delete;
  TcpSession& operator=(const TcpSession&) = delete;

  void start() {
    arm_idle();
    read();
  }

  /// Queues `bytes` for this client from any thread (the gateway's bus
  /// thread). Dropped if the connection has closed meanwhile.
  void reply_from_any_thread(std::vector<uint8_t> bytes) {
    std::weak_ptr<TcpSession> weak = shared_from_this();
    asio::post(socket_.get_executor(), [weak, bytes = std::move(bytes)] {
      if (auto self = weak.lock()) {
        self->queue(bytes);
        self->flush();
      }
    });
  }

 protected:
  /// `n` new bytes are at the end of rx_ (rx_len_ not yet counting them for
  /// MBAP users: each_mbap_adu does). False: out of step, close.
  virtual bool on_received(size_t n) = 0;

  /// Counts `n` new bytes and calls `f` for each complete MBAP ADU buffered.
  /// False when the stream is out of step.
  template <class F>
  bool each_mbap_adu(size_t n, F&& f) {
    rx_len_ += n;
    size_t pos = 0;
    for (;;) {
      const Result<size_t> size = mbap_adu_size({rx_.data() + pos, rx_len_ - pos});
      if (!size.ok()) return false;
      if (*size == 0 || *size > rx_len_ - pos) break;
      f(std::span<const uint8_t>(rx_.data() + pos, *size));
      if (closed_) return true;
      pos += *size;
    }
    std::memmove(rx_.data(), rx_.data() + pos, rx_len_ - pos);
    rx_len_ -= pos;
    return true;
  }

  /// Adds an answer to the output buffer (sent by flush()).
  void queue(std::span<const uint8_t> out) {
    if (closed_) return;
    if (pending_.size() + in_flight_.size() + out.size() > shared_->options.max_pending_output) {
      ++shared_->stats.slow_closed;  // it sends but does not read: it would only grow
      close();
      return;
    }
    pending_.insert(pending_.end(), out.begin(), out.end());
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    std::error_code ignored;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
    idle_.cancel();
    on_closed();
  }
  /// Called once when the connection closes (the gateway drops its queue).
  virtual void on_closed() {}
  /// Sends what queue() added, outside a read (a timer's answer).
  void send_queued() { flush(); }
  /// The executor of the connection's loop (for a session's own timers).
  asio::any_io_executor executor() { return socket_.get_executor(); }
  bool closed() const { return closed_; }

  std::array<uint8_t, 2 * kMaxMbapAduSize> rx_{};
  size_t rx_len_ = 0;

 private:
  void read() {
    auto self = shared_from_this();
    socket_.async_read_some(asio::buffer(rx_.data() + rx_len_, rx_.size() - rx_len_),
                            [this, self](const std::error_code& ec, size_t n) {
                              if (ec || closed_) return close();
                              arm_idle();
                              if (!on_received(n)) return close();
                              if (closed_) return;
                              flush();
                              read();
                            });
  }

  void flush() {
    if (writing_ || pending_.empty() || closed_) return;
    writing_ = true;
    in_flight_.swap(pending_);
    pending_.clear();
    auto self = shared_from_this();
    asio::async_write(socket_, asio::buffer(in_flight_), [this, self](const std::error_code& ec, size_t) {
      writing_ = false;
      in_flight_.clear();
      if (ec) return close();
      flush();
    });
  }

  void arm_idle() {
    const auto timeout = shared_->options.idle_timeout;
    if (timeout.count() <= 0) return;
    idle_.expires_after(timeout);
    auto self = shared_from_this();
    idle_.async_wait([this, self](const std::error_code& ec) {
      if (ec || closed_) return;  // re-armed by a request, or closed
      ++shared_->stats.idle_closed;
      close();
    });
  }

  asio::ip::tcp::socket socket_;
  asio::steady_timer idle_;
  std::shared_ptr<TcpShared> shared_;
  std::vector<uint8_t> pending_;
  std::vector<uint8_t> in_flight_;
  bool writing_ = false;
  bool closed_ = false;
};

/// Accepts connections and makes a session of each, within the limits.
class TcpAcceptor {
 public:
  using MakeSession =
      std::function<std::shared_ptr<TcpSession>(asio::ip::tcp::socket, std::shared_ptr<TcpShared>)>;

  TcpAcceptor(asio::io_context& ctx, ServerOptions options, MakeSession make)
      : acceptor_(ctx), retry_(ctx), shared_(std::make_shared<TcpShared>()), make_(std::move(make)) {
    shared_->options = std::move(options);
  }
  ~TcpAcceptor() {
    std::error_code ignored;
    acceptor_.close(ignored);
    retry_.cancel();
  }

  /// Binds and starts accepting. `host` empty: 127.0.0.1. Errors: invalid_argument, io_error.
  Status listen(const std::string& host, uint16_t port) {
    std::error_code ec;
    const auto address = asio::ip::make_address(host.empty() ? "127.0.0.1" : host, ec);
    if (ec) return Status(Errc::invalid_argument, "not an IP address: " + host);
    const asio::ip::tcp::endpoint endpoint(address, port);
    acceptor_.open(endpoint.protocol(), ec);
    if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor_.bind(endpoint, ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
      return Status(Error(Errc::io_error, ec.value()),
                    "cannot listen on " + io::host_port_text(host, port) + ": " + ec.message());
    accept();
    return {};
  }

  /// "127.0.0.1:1502", "[::1]:1502".
  std::string endpoint_text() const {
    const auto ep = acceptor_.local_endpoint();
    return io::host_port_text(ep.address().to_string(), ep.port());
  }
  uint16_t port() const { return acceptor_.local_endpoint().port(); }
  ServerStats stats() const { return shared_->stats; }
  unsigned connections() const { return shared_->live; }

 private:
  void accept() {
    acceptor_.async_accept([this](const std::error_code& ec, asio::ip::tcp::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (ec) {
        // Out of descriptors (EMFILE/ENFILE) or a transient error: the
        // pending connection stays in the backlog, so accepting again at once
        // would fail again at once. Pause instead of spinning.
        ++shared_->stats.accept_errors;
        retry_.expires_after(std::chrono::milliseconds(100));
        retry_.async_wait([this](const std::error_code& e) {
          if (!e) accept();
        });
        return;
      }
      std::error_code ignored;
      if (shared_->live >= shared_->options.max_connections) {
        ++shared_->stats.connections_refused;  // a clean close: the client sees at once it was refused
        socket.close(ignored);
      } else {
        socket.set_option(asio::ip::tcp::no_delay(true), ignored);
        make_(std::move(socket), shared_)->start();
      }
      accept();
    });
  }

  asio::ip::tcp::acceptor acceptor_;
  asio::steady_timer retry_;
  std::shared_ptr<TcpShared> shared_;
  MakeSession make_;
};

}  // namespace rtukit
