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

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/core/master.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit {

/// Called after each request the engine saw: the request frame and the
/// response sent (empty: silence). For logging (`rtukit slave -v`).
using RequestLog = std::function<void(std::span<const uint8_t> request, std::span<const uint8_t> response)>;

/// How a server protects itself and the bus. The defaults are what a
/// device on a real line needs; tests and tools may tighten them.
///
/// No client can stall a server: answers are written asynchronously, so the
/// event loop (and the device models and watchdogs on it) never waits for a
/// client that does not read.
struct ServerOptions {
  /// TCP: connections served at once. When all are taken, a new connection
  /// closes the one idle longest (no request being received, executed or
  /// answered) and takes its place; when none is idle it is closed at once.
  unsigned max_connections = 64;
  /// TCP: connections one client address may hold at once (its share). A
  /// newcomer from an address at its share may only take the place of that
  /// address's own idle connection. When the table is full and nothing is
  /// idle, a newcomer from an address holding fewer connections takes the
  /// place of the least active connection of the address holding the most
  /// (never one answering a request): no address can fill the table, evict
  /// or starve another. IPv4-mapped IPv6 addresses count as their IPv4 one.
  /// 0: no share (one address may take every connection).
  unsigned max_per_source = 16;
  /// TCP: a connection that sends no request for this long is closed (0: never).
  std::chrono::milliseconds idle_timeout{60000};
  /// TCP: a request must be whole this long after its first byte, or the
  /// connection is closed (a client that trickles a frame: slowloris). 0: never.
  std::chrono::milliseconds request_timeout{5000};
  /// Bytes of answers waiting for a peer that does not read. Past it a TCP
  /// connection is closed; on a serial port or pty the answer is dropped.
  size_t max_pending_output = 16 * 1024;
  /// Serial links: the silence between the request's last byte and the
  /// answer. Unset: t3.5 on serial ports (the Modbus serial line rule, 3.6 ms
  /// at 9600 8N1), none on ptys (no line to turn around) and TCP.
  std::optional<std::chrono::microseconds> turnaround;
  /// One-line notices (a baud change that failed after the answer went out).
  std::function<void(std::string_view)> notice;
};

/// Counters of what a server refused or dropped (to check the protections).
struct ServerStats {
  uint64_t connections_refused = 0;  ///< over max_connections or max_per_source, no place to take
  uint64_t idle_evicted = 0;         ///< closed to admit a new connection: the one idle longest
  uint64_t share_evicted = 0;        ///< closed to admit an address with fewer connections (max_per_source)
  uint64_t request_timeouts = 0;     ///< closed: a request not whole within request_timeout
  uint64_t idle_closed = 0;          ///< closed by idle_timeout
  uint64_t slow_closed = 0;          ///< closed: a client that does not read its answers
  uint64_t answers_dropped = 0;      ///< serial/pty: the peer does not read
  uint64_t accept_errors = 0;        ///< EMFILE and friends (retried after a pause, never in a spin)
};

class SlaveListener {
 public:
  /// Starts serving `engine` on `spec` (listening form). Errors: io_error
  /// with a one-line reason (port busy, no permission, address in use),
  /// invalid_argument (not an IP address).
  static Outcome<std::unique_ptr<SlaveListener>> start(asio::io_context& ctx, SlaveEngine& engine,
                                                       const io::PortSpec& spec, RequestLog log = {},
                                                       ServerOptions options = {});
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
  /// When an answer is still on its way out, the change waits until it has
  /// left the wire (tcdrain): the answer goes out at the old rate.
  virtual Error set_baud(uint32_t /*baud*/) { return {}; }
  /// What the protections did so far.
  virtual ServerStats stats() const { return {}; }
  /// Connections open now (TCP), 0 otherwise.
  virtual unsigned connections() const { return 0; }
};

}  // namespace rtukit
