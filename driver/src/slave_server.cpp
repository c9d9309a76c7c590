#include "rtukit/driver/slave_server.hpp"

#include <termios.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <deque>

#include "rtukit/io/asio.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/now.hpp"
#include "rtukit/io/pty.hpp"
#include "rtukit/io/serial_config.hpp"
#include "tcp_sessions.hpp"

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
      note_crc_errors();  // those before this frame first, as on the line
      const auto [n, bank] = engine_.handle_rtu(frame->adu, tx_);
      if (log_) log_(frame->adu, {tx_.data(), n});
      if (n) send(std::span<const uint8_t>(tx_.data(), n));
      if (bank) bank->after_response();
    }
    note_crc_errors();
  }

  RtuFramer& framer() { return framer_; }
  const RtuFramer& framer() const { return framer_; }

 private:
  // The framer's CRC errors are the line's (FC08 0x0C): hand new ones to the engine.
  void note_crc_errors() {
    const uint32_t now_seen = framer_.counters().crc_errors;
    if (now_seen != crc_errors_seen_) engine_.note_crc_errors(now_seen - crc_errors_seen_);
    crc_errors_seen_ = now_seen;
  }
  uint32_t crc_errors_seen_ = 0;
  SlaveEngine& engine_;
  RtuFramer framer_;
  const RequestLog& log_;
  std::array<uint8_t, kMaxRtuAduSize> tx_{};
};

// RTU on a serial port or a pty master.
//
// Answers are queued and written asynchronously, each not before its
// turnaround has passed: a master that stops reading (a pty nobody reads)
// fills the queue and further answers are dropped, while the loop keeps
// serving timers and signals.
class RtuStreamServer final : public SlaveListener {
 public:
  RtuStreamServer(asio::io_context& ctx, SlaveEngine& engine, int fd, const io::PortSpec& spec,
                  std::string where, RequestLog log, io::Pty pty, ServerOptions options)
      : spec_(spec),
        options_(std::move(options)),
        stream_(ctx, fd),
        timer_(ctx),
        turnaround_timer_(ctx),
        log_(std::move(log)),
        responder_(engine, io::link_timing(spec), log_),
        where_(std::move(where)),
        pty_(std::move(pty)) {
    read();
  }
  ~RtuStreamServer() override {
    boost::system::error_code ec;
    stream_.close(ec);
    timer_.cancel();
    turnaround_timer_.cancel();
  }

  std::string where() const override { return where_; }
  void set_timing(RtuTiming t) override { responder_.framer().set_timing(t); }
  Error set_baud(uint32_t baud) override {
    if (writing_ || !queue_.empty()) {
      pending_baud_ = baud;  // after the answer has left, at the old rate
      return {};
    }
    return apply_baud(baud);
  }
  ServerStats stats() const override { return stats_; }

 private:
  struct Answer {
    std::vector<uint8_t> bytes;
    TimePoint not_before;
  };

  // The silence before an answer: t3.5 at the line's rate on a serial port.
  std::chrono::microseconds turnaround() const {
    if (options_.turnaround) return *options_.turnaround;
    if (spec_.kind != io::PortSpec::Kind::serial) return std::chrono::microseconds(0);
    return std::chrono::microseconds(
        RtuTiming::for_serial(spec_.serial.baud, spec_.serial.bits_per_char()).t35_us);
  }

  Error apply_baud(uint32_t baud) {
    spec_.serial.baud = baud;
    if (spec_.kind == io::PortSpec::Kind::serial) {
      Result<io::SerialCapabilities> r = io::configure_serial(stream_.native_handle(), spec_.serial);
      if (!r.ok()) return r.error();
    }
    set_timing(io::link_timing(spec_));
    return {};
  }

  void read() {
    stream_.async_read_some(asio::buffer(rx_), [this](const boost::system::error_code& ec, size_t n) {
      if (ec == asio::error::operation_aborted) return;
      if (ec) {
        // A pty whose client went away reports EIO until someone opens it
        // again; we hold the slave side open, so this is rare. Back off a bit.
        timer_.expires_after(std::chrono::milliseconds(50));
        timer_.async_wait([this](const boost::system::error_code& e) {
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
    if (queued_bytes_ + out.size() > options_.max_pending_output) {
      ++stats_.answers_dropped;  // nobody reads the line: the bus would drop it too
      return;
    }
    queued_bytes_ += out.size();
    queue_.push_back(Answer{{out.begin(), out.end()}, clock_.now() + turnaround()});
    write_next();
  }

  void write_next() {
    if (writing_ || waiting_turnaround_) return;
    if (queue_.empty()) {
      if (pending_baud_) change_baud_now();
      return;
    }
    const auto now = clock_.now();
    if (queue_.front().not_before > now) {
      waiting_turnaround_ = true;
      turnaround_timer_.expires_after(queue_.front().not_before - now);
      turnaround_timer_.async_wait([this](const boost::system::error_code& ec) {
        if (ec) return;
        waiting_turnaround_ = false;
        write_next();
      });
      return;
    }
    writing_ = true;
    in_flight_ = std::move(queue_.front().bytes);
    queue_.pop_front();
    asio::async_write(stream_, asio::buffer(in_flight_), [this](const boost::system::error_code& ec, size_t) {
      if (ec == asio::error::operation_aborted) return;
      writing_ = false;
      queued_bytes_ -= in_flight_.size();
      write_next();
    });
  }

  // Every answer is in the kernel; wait until the last bit is on the wire,
  // then switch (an answer reconfigured away mid-frame is an answer lost).
  void change_baud_now() {
    const uint32_t baud = *pending_baud_;
    pending_baud_.reset();
    if (spec_.kind == io::PortSpec::Kind::serial) ::tcdrain(stream_.native_handle());
    if (Error e = apply_baud(baud); e && options_.notice)
      options_.notice("cannot switch to " + std::to_string(baud) + " baud: " + std::string(e.text()));
  }

  // Frames of unknown length end at silence: look again when it has lasted.
  void arm_silence() {
    const auto deadline = responder_.framer().silence_deadline();
    if (!deadline) return;
    const uint64_t now = io::now_us();
    const auto wait = std::chrono::microseconds(*deadline > now ? *deadline - now : 0);
    timer_.expires_after(wait + std::chrono::microseconds(100));
    timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      responder_.drain(io::now_us(), [this](std::span<const uint8_t> out) { send(out); });
    });
  }

  io::PortSpec spec_;
  ServerOptions options_;
  asio::posix::stream_descriptor stream_;
  asio::steady_timer timer_;
  asio::steady_timer turnaround_timer_;
  // The turnaround is time on the wire, waited for on Asio's timer, which
  // runs on the steady clock: so is this.
  DriverClock& clock_ = SteadyClock::instance();
  RequestLog log_;
  RtuResponder responder_;
  std::string where_;
  io::Pty pty_;
  std::array<uint8_t, 512> rx_{};
  std::deque<Answer> queue_;
  size_t queued_bytes_ = 0;
  std::vector<uint8_t> in_flight_;
  bool writing_ = false;
  bool waiting_turnaround_ = false;
  std::optional<uint32_t> pending_baud_;
  ServerStats stats_;
};

// A connection served by the slave engine: Modbus TCP (MBAP) or RTU frames.
class EngineSession final : public TcpSession {
 public:
  EngineSession(asio::ip::tcp::socket socket, std::shared_ptr<TcpShared> shared, SlaveEngine& engine,
                Framing framing, RtuTiming timing, const RequestLog& log)
      : TcpSession(std::move(socket), std::move(shared)),
        engine_(engine),
        framing_(framing),
        log_(log),
        rtu_(engine, timing, log_),  // the session's own copy: it may outlive the server
        silence_(executor()) {}

 private:
  bool on_received(size_t n) override {
    if (framing_ == Framing::rtu) {
      rtu_.on_bytes({rx_.data(), n}, io::now_us(), [this](std::span<const uint8_t> out) { queue(out); });
      arm_silence();
      return true;
    }
    return each_mbap_adu(n, [this](std::span<const uint8_t> adu) {
      std::array<uint8_t, kMaxMbapAduSize> tx{};
      const auto [out, bank] = engine_.handle_tcp(adu, tx);
      if (log_) log_(adu, {tx.data(), out});
      if (out)
        queue({tx.data(), out});
      else
        answered_nothing();  // listen-only mode
      if (bank) bank->after_response();
    });
  }

  // Every request is answered as it arrives, on this thread: the connection
  // is busy only while a request is partly received.
  bool busy() const override { return partial_request(); }
  bool partial_request() const override {
    return framing_ == Framing::rtu ? rtu_.framer().buffered() > 0 : rx_len_ > 0;
  }
  // An RTU frame that silence will close is answered before an ending connection closes.
  bool answer_coming() const override {
    return framing_ == Framing::rtu && rtu_.framer().silence_deadline().has_value();
  }

  // A frame whose length its function does not tell (an unknown function
  // code, a byte count that disagrees with the bytes sent) ends at silence,
  // as on a pty. Without this timer it was answered only when the client
  // sent something more: a client waiting for its exception timed out.
  void arm_silence() {
    const auto deadline = rtu_.framer().silence_deadline();
    if (!deadline) return;
    const uint64_t now = io::now_us();
    silence_.expires_after(std::chrono::microseconds(*deadline > now ? *deadline - now : 0) +
                           std::chrono::microseconds(100));
    auto self = shared_from_this();
    silence_.async_wait([this, self](const boost::system::error_code& ec) {
      if (ec || closed()) return;
      rtu_.drain(io::now_us(), [this](std::span<const uint8_t> out) { queue(out); });
      request_progress();
      send_queued();
    });
  }
  void on_closed() override { silence_.cancel(); }

  SlaveEngine& engine_;
  Framing framing_;
  RequestLog log_;
  RtuResponder rtu_;
  asio::steady_timer silence_;
};

class TcpServer final : public SlaveListener {
 public:
  TcpServer(asio::io_context& ctx, SlaveEngine& engine, Framing framing, RtuTiming timing, RequestLog log,
            ServerOptions options)
      : framing_(framing),
        log_(std::move(log)),
        acceptor_(ctx, std::move(options),
                  [this, &engine, timing](asio::ip::tcp::socket socket, std::shared_ptr<TcpShared> shared) {
                    return std::make_shared<EngineSession>(std::move(socket), std::move(shared), engine,
                                                           framing_, timing, log_);
                  }) {}

  Status listen(const std::string& host, uint16_t port) { return acceptor_.listen(host, port); }
  std::string where() const override {
    return std::string(framing_ == Framing::tcp ? "tcp://" : "rtu+tcp://") + acceptor_.endpoint_text();
  }
  uint16_t tcp_port() const override { return acceptor_.port(); }
  ServerStats stats() const override { return acceptor_.stats(); }
  unsigned connections() const override { return acceptor_.connections(); }

 private:
  Framing framing_;
  RequestLog log_;
  TcpAcceptor acceptor_;
};

}  // namespace

Outcome<std::unique_ptr<SlaveListener>> SlaveListener::start(asio::io_context& ctx, SlaveEngine& engine,
                                                             const io::PortSpec& spec, RequestLog log,
                                                             ServerOptions options) {
  const RtuTiming timing = io::link_timing(spec);
  switch (spec.kind) {
    case io::PortSpec::Kind::pty: {
      Outcome<io::Pty> pty = io::Pty::create(spec.path);
      if (!pty.ok()) return pty.error();
      const int fd = ::dup(pty->master_fd());
      if (fd < 0) return Status(Error(Errc::io_error, errno), std::string("dup: ") + std::strerror(errno));
      std::string where = pty->name();
      return std::unique_ptr<SlaveListener>(new RtuStreamServer(
          ctx, engine, fd, spec, std::move(where), std::move(log), std::move(*pty), std::move(options)));
    }
    case io::PortSpec::Kind::serial: {
      Result<int> fd = io::open_serial_port(spec.path, spec.serial);
      if (!fd.ok())
        return Status(fd.error(), "cannot open " + spec.path + ": " + std::strerror(fd.error().os_error()));
      return std::unique_ptr<SlaveListener>(new RtuStreamServer(
          ctx, engine, *fd, spec, spec.path, std::move(log), io::Pty{}, std::move(options)));
    }
    case io::PortSpec::Kind::tcp:
    case io::PortSpec::Kind::rtu_tcp: {
      auto server = std::make_unique<TcpServer>(
          ctx, engine, spec.kind == io::PortSpec::Kind::tcp ? Framing::tcp : Framing::rtu, timing,
          std::move(log), std::move(options));
      if (Status e = server->listen(spec.host, spec.port)) return e;
      return std::unique_ptr<SlaveListener>(std::move(server));
    }
  }
  return Status(Errc::invalid_argument, "not a listening port");
}

}  // namespace rtukit
