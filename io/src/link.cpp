// Links on Boost.Asio. Each link owns a private io_context: a blocking
// call starts one async operation and runs the context until the operation
// completes or the deadline passes (then cancels it and reaps the handler).
#include "rtukit/io/link.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <optional>

#include "rtukit/io/asio.hpp"
#include "rtukit/io/pty.hpp"
#include "rtukit/io/serial_config.hpp"

namespace rtukit::io {
namespace {

Error to_error(const boost::system::error_code& ec) {
  if (ec == asio::error::timed_out || ec == asio::error::would_block) return Errc::timeout;
  return Error(Errc::io_error, ec.category() == asio::error::get_system_category() ? ec.value() : EIO);
}

// Runs `ctx` until `done` or `deadline`; cancels `stream` on timeout.
template <class Stream>
bool run_until(asio::io_context& ctx, Stream& stream, const bool& done, Clock::time_point deadline) {
  ctx.restart();
  while (!done && Clock::now() < deadline) {
    if (ctx.run_one_until(deadline) == 0) break;
  }
  if (done) return true;
  boost::system::error_code ignored;
  stream.cancel(ignored);
  ctx.restart();
  while (!done) ctx.run_one();  // reap the cancelled handler
  return false;
}

template <class Stream>
Result<size_t> timed_read(asio::io_context& ctx, Stream& stream, std::span<uint8_t> out,
                          Clock::time_point deadline) {
  // Bytes already waiting: take them without going through the reactor.
  boost::system::error_code ec;
  stream.non_blocking(true, ec);
  size_t n = stream.read_some(asio::buffer(out.data(), out.size()), ec);
  if (!ec) return n;
  if (ec != asio::error::would_block && ec != asio::error::try_again) return to_error(ec);
  bool done = false;
  stream.async_wait(Stream::wait_read, [&](const boost::system::error_code& e) {
    ec = e;
    done = true;
  });
  if (!run_until(ctx, stream, done, deadline)) return size_t{0};
  if (ec == asio::error::operation_aborted) return size_t{0};
  if (ec) return to_error(ec);
  n = stream.read_some(asio::buffer(out.data(), out.size()), ec);
  if (ec == asio::error::would_block || ec == asio::error::try_again) return size_t{0};
  if (ec) return to_error(ec);
  return n;
}

template <class Stream>
Error timed_write(asio::io_context& ctx, Stream& stream, std::span<const uint8_t> bytes,
                  Clock::time_point deadline) {
  boost::system::error_code ec;
  stream.non_blocking(true, ec);
  size_t sent = 0;
  while (sent < bytes.size()) {
    const size_t n = stream.write_some(asio::buffer(bytes.data() + sent, bytes.size() - sent), ec);
    if (!ec) {
      sent += n;
      continue;
    }
    if (ec != asio::error::would_block && ec != asio::error::try_again) return to_error(ec);
    bool done = false;
    stream.async_wait(Stream::wait_write, [&](const boost::system::error_code& e) {
      ec = e;
      done = true;
    });
    if (!run_until(ctx, stream, done, deadline)) return Errc::timeout;
    if (ec) return to_error(ec);
  }
  return {};
}

template <class Stream>
void drain_input(Stream& stream) {
  boost::system::error_code ec;
  stream.non_blocking(true, ec);
  uint8_t scratch[512];
  while (!ec) stream.read_some(asio::buffer(scratch), ec);
}

// Serial line or a pty's slave side opened by path.
class SerialLink final : public Link {
 public:
  explicit SerialLink(PortSpec spec) : spec_(std::move(spec)), stream_(ctx_) {}
  ~SerialLink() override { close(); }

  Error open() override {
    close();
    // A simulator that died left its link; the pty number it points at may
    // now be another program's: that line is not ours to take.
    if (stale_pty_link(spec_.path)) return Error(Errc::io_error, ENOENT);
    const int fd = ::open(spec_.path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return Error(Errc::io_error, errno);
    const Result<SerialCapabilities> caps = configure_serial(fd, spec_.serial);
    if (!caps.ok()) {
      ::close(fd);
      return caps.error();
    }
    caps_ = *caps;
    boost::system::error_code ec;
    stream_.assign(fd, ec);
    if (ec) {
      ::close(fd);
      return to_error(ec);
    }
    if (spec_.serial.rs485.enabled && !caps_.kernel_rs485) {
      (void)set_rts(fd, spec_.serial.rs485.rts_after_send);
    }
    return {};
  }

  void close() noexcept override {
    boost::system::error_code ec;
    if (stream_.is_open()) stream_.close(ec);
  }
  bool is_open() const noexcept override { return stream_.is_open(); }

  Error write(std::span<const uint8_t> bytes, Clock::time_point deadline) override {
    if (!is_open()) return Errc::not_connected;
    const bool toggle = spec_.serial.rs485.enabled && !caps_.kernel_rs485;
    const int fd = stream_.native_handle();
    if (toggle) {
      if (Error e = set_rts(fd, spec_.serial.rs485.rts_on_send)) return fail(e);
      if (spec_.serial.rs485.delay_before_us) ::usleep(spec_.serial.rs485.delay_before_us);
    }
    if (Error e = timed_write(ctx_, stream_, bytes, deadline)) return fail(e);
    if (toggle) {
      // RTS may only drop once the last bit has left the UART.
      if (Error e = drain(fd)) return fail(e);
      if (spec_.serial.rs485.delay_after_us) ::usleep(spec_.serial.rs485.delay_after_us);
      if (Error e = set_rts(fd, spec_.serial.rs485.rts_after_send)) return fail(e);
    }
    return {};
  }

  Result<size_t> read_some(std::span<uint8_t> out, Clock::time_point deadline) override {
    if (!is_open()) return Errc::not_connected;
    Result<size_t> r = timed_read(ctx_, stream_, out, deadline);
    if (!r.ok()) return fail(r.error());
    return r;
  }

  void discard_input() noexcept override {
    if (is_open()) drain_input(stream_);
  }
  Framing framing() const noexcept override { return Framing::rtu; }
  RtuTiming timing() const noexcept override { return link_timing(spec_); }
  std::chrono::microseconds frame_gap() const noexcept override {
    return std::chrono::microseconds(
        RtuTiming::for_serial(spec_.serial.baud, spec_.serial.bits_per_char()).t35_us);
  }
  std::string describe() const override { return spec_.describe(); }

 private:
  Error fail(Error e) {
    if (e.code() == Errc::io_error) close();  // unplugged: reopen on the next request
    return e;
  }

  PortSpec spec_;
  asio::io_context ctx_;
  asio::posix::stream_descriptor stream_;
  SerialCapabilities caps_{};
};

// Modbus TCP or RTU-over-TCP client connection.
class TcpLink final : public Link {
 public:
  explicit TcpLink(PortSpec spec) : spec_(std::move(spec)), socket_(ctx_) {}
  ~TcpLink() override { close(); }

  Error open() override {
    close();
    boost::system::error_code ec;
    asio::ip::tcp::resolver resolver(ctx_);
    const auto endpoints = resolver.resolve(spec_.host, std::to_string(spec_.port), ec);
    if (ec) return Error(Errc::io_error, "cannot resolve the host name");
    bool done = false;
    asio::async_connect(socket_, endpoints,
                        [&](const boost::system::error_code& e, const asio::ip::tcp::endpoint&) {
                          ec = e;
                          done = true;
                        });
    if (!run_until(ctx_, socket_, done, Clock::now() + std::chrono::seconds(3))) {
      close();
      return Error(Errc::io_error, ETIMEDOUT);
    }
    if (ec) {
      close();
      return to_error(ec);
    }
    socket_.set_option(asio::ip::tcp::no_delay(true), ec);
    return {};
  }

  void close() noexcept override {
    boost::system::error_code ec;
    if (socket_.is_open()) socket_.close(ec);
  }
  bool is_open() const noexcept override { return socket_.is_open(); }

  Error write(std::span<const uint8_t> bytes, Clock::time_point deadline) override {
    if (!is_open()) return Errc::not_connected;
    Error e = timed_write(ctx_, socket_, bytes, deadline);
    if (e.code() == Errc::io_error) close();
    return e;
  }

  Result<size_t> read_some(std::span<uint8_t> out, Clock::time_point deadline) override {
    if (!is_open()) return Errc::not_connected;
    Result<size_t> r = timed_read(ctx_, socket_, out, deadline);
    if (!r.ok() && r.error().code() == Errc::io_error) close();
    return r;
  }

  void discard_input() noexcept override {
    if (is_open()) drain_input(socket_);
  }
  Framing framing() const noexcept override {
    return spec_.kind == PortSpec::Kind::tcp ? Framing::tcp : Framing::rtu;
  }
  RtuTiming timing() const noexcept override { return link_timing(spec_); }
  std::string describe() const override { return spec_.describe(); }

 private:
  PortSpec spec_;
  asio::io_context ctx_;
  asio::ip::tcp::socket socket_;
};

}  // namespace

std::unique_ptr<Link> make_link(const PortSpec& spec) {
  switch (spec.kind) {
    case PortSpec::Kind::serial:
      return std::make_unique<SerialLink>(spec);
    case PortSpec::Kind::tcp:
    case PortSpec::Kind::rtu_tcp:
      return std::make_unique<TcpLink>(spec);
    case PortSpec::Kind::pty:
      return nullptr;
  }
  return nullptr;
}

}  // namespace rtukit::io
