#include "rtukit/driver/slave_server.hpp"

#include <unistd.h>

#include <array>
#include <asio.hpp>
#include <cstring>
#include <deque>

#include "rtukit/io/link.hpp"
#include "rtukit/io/pty.hpp"
#include "rtukit/io/serial_config.hpp"

namespace rtukit {
namespace {

// Feeds received bytes to a framer and answers each frame through `send`.
// Shared by the stream server and the RTU-over-TCP sessions.
class RtuResponder {
 public:
  RtuResponder(SlaveEngine& engine, RtuTiming timing, const RequestLog& log)
      : engine_(engine), framer_(FrameShape::request, timing), log_(log) {}

  template <class Send>
  void on_bytes(std::span<const uint8_t> bytes, uint64_t now, Send&& send) {
    // The frame forms to recognise are those of the units hosted now.
    framer_.set_quirks(engine_.quirks());
    size_t fed = 0;
    do {
      fed += framer_.feed(bytes.subspan(fed), now);
      drain(now, send);
    } while (fed < bytes.size());
  }

  template <class Send>
  void drain(uint64_t now, Send&& send) {
    while (auto frame = framer_.next(now)) {
      const auto [n, bank] = engine_.handle_rtu(frame->adu, tx_);
      if (log_) log_(frame->adu, {tx_.data(), n});
      if (n) send(std::span<const uint8_t>(tx_.data(), n));
      if (bank) bank->after_response();
    }
  }

  RtuFramer& framer() { return framer_; }

 private:
  SlaveEngine& engine_;
  RtuFramer framer_;
  const RequestLog& log_;
  std::array<uint8_t, kMaxRtuAduSize> tx_{};
};

// RTU on a serial port or a pty master.
class RtuStreamServer final : public SlaveListener {
 public:
  RtuStreamServer(asio::io_context& ctx, SlaveEngine& engine, int fd, const io::PortSpec& spec,
                  std::string where, RequestLog log, io::Pty pty)
      : spec_(spec),
        stream_(ctx, fd),
        timer_(ctx),
        log_(std::move(log)),
        responder_(engine, io::link_timing(spec), log_),
        where_(std::move(where)),
        pty_(std::move(pty)) {
    read();
  }
  ~RtuStreamServer() override {
    std::error_code ec;
    stream_.close(ec);
    timer_.cancel();
  }

  std::string where() const override { return where_; }
  void set_timing(RtuTiming t) override { responder_.framer().set_timing(t); }
  Error set_baud(uint32_t baud) override {
    spec_.serial.baud = baud;
    if (spec_.kind == io::PortSpec::Kind::serial) {
      Result<io::SerialCapabilities> r = io::configure_serial(stream_.native_handle(), spec_.serial);
      if (!r.ok()) return r.error();
    }
    set_timing(io::link_timing(spec_));
    return {};
  }

 private:
  void read() {
    stream_.async_read_some(asio::buffer(rx_), [this](const std::error_code& ec, size_t n) {
      if (ec == asio::error::operation_aborted) return;
      if (ec) {
        // A pty whose client went away reports EIO until someone opens it
        // again; we hold the slave side open, so this is rare. Back off a bit.
        timer_.expires_after(std::chrono::milliseconds(50));
        timer_.async_wait([this](const std::error_code& e) {
          if (!e) read();
        });
        return;
      }
      responder_.on_bytes({rx_.data(), n}, io::now_us(), [this](std::span<const uint8_t> out) { send(out); });
      arm_silence();
      read();
    });
  }

  void send(std::span<const uint8_t> out) {
    std::error_code ec;
    asio::write(stream_, asio::buffer(out.data(), out.size()), ec);
  }

  // Frames of unknown length end at silence: look again when it has lasted.
  void arm_silence() {
    const auto deadline = responder_.framer().silence_deadline();
    if (!deadline) return;
    const uint64_t now = io::now_us();
    const auto wait = std::chrono::microseconds(*deadline > now ? *deadline - now : 0);
    timer_.expires_after(wait + std::chrono::microseconds(100));
    timer_.async_wait([this](const std::error_code& ec) {
      if (ec) return;
      responder_.drain(io::now_us(), [this](std::span<const uint8_t> out) { send(out); });
    });
  }

  io::PortSpec spec_;
  asio::posix::stream_descriptor stream_;
  asio::steady_timer timer_;
  RequestLog log_;
  RtuResponder responder_;
  std::string where_;
  io::Pty pty_;
  std::array<uint8_t, 512> rx_{};
};

// One TCP connection.
class TcpSession : public std::enable_shared_from_this<TcpSession> {
 public:
  TcpSession(asio::ip::tcp::socket socket, SlaveEngine& engine, Framing framing, RtuTiming timing,
             const RequestLog& log)
      : socket_(std::move(socket)),
        engine_(engine),
        framing_(framing),
        log_(log),
        rtu_(engine, timing, log_) {}  // the session's own copy: it may outlive the server

  void start() { read(); }

 private:
  void read() {
    auto self = shared_from_this();
    socket_.async_read_some(asio::buffer(rx_.data() + rx_len_, rx_.size() - rx_len_), [this, self](
                                                                                          const std::
                                                                                              error_code& ec,
                                                                                          size_t n) {
      if (ec) return;  // closed: the session ends with its last reference
      if (framing_ == Framing::rtu) {
        rtu_.on_bytes({rx_.data(), n}, io::now_us(), [this](std::span<const uint8_t> out) { queue(out); });
      } else if (!on_mbap(n)) {
        std::error_code ignored;
        socket_.close(ignored);
        return;
      }
      flush();
      read();
    });
  }

  // Handles every complete MBAP ADU buffered. False: the stream is out of step.
  bool on_mbap(size_t n) {
    rx_len_ += n;
    size_t pos = 0;
    for (;;) {
      const Result<size_t> size = mbap_adu_size({rx_.data() + pos, rx_len_ - pos});
      if (!size.ok()) return false;
      if (*size == 0 || *size > rx_len_ - pos) break;
      const std::span<const uint8_t> adu(rx_.data() + pos, *size);
      std::array<uint8_t, kMaxMbapAduSize> tx{};
      const auto [out, bank] = engine_.handle_tcp(adu, tx);
      if (log_) log_(adu, {tx.data(), out});
      if (out) queue({tx.data(), out});
      if (bank) bank->after_response();
      pos += *size;
    }
    std::memmove(rx_.data(), rx_.data() + pos, rx_len_ - pos);
    rx_len_ -= pos;
    return true;
  }

  void queue(std::span<const uint8_t> out) { pending_.insert(pending_.end(), out.begin(), out.end()); }

  // Responses go out synchronously: they are small and the socket buffer is
  // empty in request/response traffic; a slow reader only delays its own session.
  void flush() {
    if (pending_.empty()) return;
    std::error_code ec;
    asio::write(socket_, asio::buffer(pending_.data(), pending_.size()), ec);
    pending_.clear();
  }

  asio::ip::tcp::socket socket_;
  SlaveEngine& engine_;
  Framing framing_;
  RequestLog log_;
  RtuResponder rtu_;
  std::array<uint8_t, 2 * kMaxMbapAduSize> rx_{};
  size_t rx_len_ = 0;
  std::vector<uint8_t> pending_;
};

class TcpServer final : public SlaveListener {
 public:
  TcpServer(asio::io_context& ctx, SlaveEngine& engine, Framing framing, RtuTiming timing, RequestLog log)
      : acceptor_(ctx), engine_(engine), framing_(framing), timing_(timing), log_(std::move(log)) {}

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
                    "cannot listen on " + host + ":" + std::to_string(port) + ": " + ec.message());
    accept();
    return {};
  }

  std::string where() const override {
    const auto ep = acceptor_.local_endpoint();
    return std::string(framing_ == Framing::tcp ? "tcp://" : "rtu+tcp://") + ep.address().to_string() + ":" +
           std::to_string(ep.port());
  }
  uint16_t tcp_port() const override { return acceptor_.local_endpoint().port(); }

 private:
  void accept() {
    acceptor_.async_accept([this](const std::error_code& ec, asio::ip::tcp::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) {
        std::error_code ignored;
        socket.set_option(asio::ip::tcp::no_delay(true), ignored);
        std::make_shared<TcpSession>(std::move(socket), engine_, framing_, timing_, log_)->start();
      }
      accept();
    });
  }

  asio::ip::tcp::acceptor acceptor_;
  SlaveEngine& engine_;
  Framing framing_;
  RtuTiming timing_;
  RequestLog log_;
};

}  // namespace

Outcome<std::unique_ptr<SlaveListener>> SlaveListener::start(asio::io_context& ctx, SlaveEngine& engine,
                                                             const io::PortSpec& spec, RequestLog log) {
  const RtuTiming timing = io::link_timing(spec);
  switch (spec.kind) {
    case io::PortSpec::Kind::pty: {
      Outcome<io::Pty> pty = io::Pty::create(spec.path);
      if (!pty.ok()) return pty.error();
      const int fd = ::dup(pty->master_fd());
      if (fd < 0) return Status(Error(Errc::io_error, errno), std::string("dup: ") + std::strerror(errno));
      std::string where = pty->name();
      return std::unique_ptr<SlaveListener>(
          new RtuStreamServer(ctx, engine, fd, spec, std::move(where), std::move(log), std::move(*pty)));
    }
    case io::PortSpec::Kind::serial: {
      Result<int> fd = io::open_serial_port(spec.path, spec.serial);
      if (!fd.ok())
        return Status(fd.error(), "cannot open " + spec.path + ": " + std::strerror(fd.error().os_error()));
      return std::unique_ptr<SlaveListener>(
          new RtuStreamServer(ctx, engine, *fd, spec, spec.path, std::move(log), io::Pty{}));
    }
    case io::PortSpec::Kind::tcp:
    case io::PortSpec::Kind::rtu_tcp: {
      auto server = std::make_unique<TcpServer>(
          ctx, engine, spec.kind == io::PortSpec::Kind::tcp ? Framing::tcp : Framing::rtu, timing,
          std::move(log));
      if (Status e = server->listen(spec.host, spec.port)) return e;
      return std::unique_ptr<SlaveListener>(std::move(server));
    }
  }
  return Status(Errc::invalid_argument, "not a listening port");
}

}  // namespace rtukit
