// rtukit driver: serving a SlaveEngine's units on an Asio io_context.
//
//  - RtuStreamServer: RTU frames on a byte stream: a serial port or the master
//    side of a pty. One framer, silence timer for frames of unknown length.
//  - TcpServer: many connections at once, each with its own framing state;
//    Modbus TCP (MBAP) or RTU-over-TCP. Binds 127.0.0.1 unless told otherwise.
//  - SlaveListener: the one to use: builds the right server from a PortSpec
//    (`pty`, `pty:/link`, a serial device, `tcp://`, `rtu+tcp://`).
//
// Everything runs on the io_context's thread; the engine and its banks are
// only touched from there, so banks need no locks against the server.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "rtukit/core/error.hpp"
#include "rtukit/core/master.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/io/port.hpp"
#include "rtukit/io/status.hpp"

namespace asio {
class io_context;
}

namespace rtukit {

/// Called after each request the engine saw: the request frame and the
/// response sent (empty: silence). For logging (`rtukit slave -v`).
using RequestLog = std::function<void(std::span<const uint8_t> request, std::span<const uint8_t> response)>;

class SlaveListener {
 public:
  /// Starts serving `engine` on `spec` (listening form). Errors: io_error
  /// with a one-line reason (port busy, no permission, address in use),
  /// invalid_argument (not an IP address).
  static Outcome<std::unique_ptr<SlaveListener>> start(asio::io_context& ctx, SlaveEngine& engine,
                                                       const io::PortSpec& spec, RequestLog log = {});
  virtual ~SlaveListener() = default;
  /// Where clients connect: the pty path (or its symlink), the device, or HOST:PORT.
  virtual std::string where() const = 0;
  /// The TCP port bound (useful with port 0); 0 for non-TCP listeners.
  virtual uint16_t tcp_port() const { return 0; }
  /// Changes the framer timing (a device that switches baud rate).
  virtual void set_timing(RtuTiming) {}
  /// A device that switches baud rate: a serial port is reconfigured (other
  /// settings kept) and the framer timing follows; ptys and TCP only take
  /// the new timing. Errors: io_error (the port refused the rate).
  virtual Error set_baud(uint32_t /*baud*/) { return {}; }
};

}  // namespace rtukit
