// rtukit io: a Link is a byte stream to one peer with deadlines: a serial
// line, a pty, or a TCP connection. It is the only place (with pty.hpp and
// the slave servers) where the stack touches the operating system.
//
// Links are blocking with deadlines (each owns a private Asio io_context and
// runs it until the deadline), which is what a master needs: one request,
// wait for the answer or time out. Not thread-safe: the Master serialises.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/core/master.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit::io {

class Link {
 public:
  virtual ~Link() = default;
  /// Opens the link, or reopens it after a failure. Errors: io_error with the
  /// OS error number (ENOENT: no such device; EACCES: permission;
  /// ECONNREFUSED: nobody listens; EBUSY: another program has the port).
  virtual Error open() = 0;
  virtual void close() noexcept = 0;
  virtual bool is_open() const noexcept = 0;
  /// Sends all of `bytes`. Errors: io_error (the link is closed), timeout.
  virtual Error write(std::span<const uint8_t> bytes, Clock::time_point deadline) = 0;
  /// Waits until some bytes arrive or `deadline` passes; returns how many
  /// arrived, 0 when the deadline passed first. Errors: io_error (link closed:
  /// unplugged device, peer closed the connection).
  virtual Result<size_t> read_some(std::span<uint8_t> out, Clock::time_point deadline) = 0;
  /// Drops input received but not yet read (stale bytes before a new request).
  virtual void discard_input() noexcept = 0;
  /// RTU frames, or MBAP (Modbus TCP).
  virtual Framing framing() const noexcept = 0;
  /// Framer timing for RTU links.
  virtual RtuTiming timing() const noexcept = 0;
  /// The silence the line needs between two frames: t3.5 at the line's rate
  /// on a serial port (3.6 ms at 9600 8N1), 0 where there is no line (TCP).
  virtual std::chrono::microseconds frame_gap() const noexcept { return std::chrono::microseconds(0); }
  virtual std::string describe() const = 0;
};

/// A link for `spec` (serial, tcp or rtu_tcp; not pty, which only listens).
/// Not opened yet. Returns nullptr for a pty spec.
std::unique_ptr<Link> make_link(const PortSpec& spec);

}  // namespace rtukit::io
