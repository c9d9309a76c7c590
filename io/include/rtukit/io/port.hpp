// rtukit io: naming a port. One syntax everywhere (CLI, tests, tools):
//   /dev/ttyUSB0          serial line (settings from SerialSettings)
//   tcp://HOST:PORT       Modbus TCP (MBAP)
//   rtu+tcp://HOST:PORT   RTU frames in a TCP stream (serial device servers)
//   pty / pty:/some/link  listening only: a new pseudo-terminal (and a symlink to it)
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "rtukit/core/error.hpp"
#include "rtukit/core/rtu.hpp"

namespace rtukit::io {

/// RS-485 direction control (Linux serial_rs485).
struct Rs485Settings {
  bool enabled = false;
  bool rts_on_send = true;       ///< RTS level while sending
  bool rts_after_send = false;   ///< RTS level after sending
  uint32_t delay_before_us = 0;  ///< before the first bit (kernel: rounded to ms)
  uint32_t delay_after_us = 0;   ///< after the last bit
};

struct SerialSettings {
  uint32_t baud = 9600;   ///< 1200..921600; non-standard rates via BOTHER
  char parity = 'N';      ///< 'N', 'E' or 'O'
  uint8_t data_bits = 8;  ///< 7 or 8
  uint8_t stop_bits = 1;  ///< 1 or 2
  Rs485Settings rs485{};
  bool low_latency = true;  ///< ASYNC_LOW_LATENCY where the driver has it

  /// Bits on the wire per character: start + data + parity + stop.
  uint32_t bits_per_char() const noexcept { return 1U + data_bits + (parity == 'N' ? 0U : 1U) + stop_bits; }
  /// Errors: invalid_argument, with the reason (Error::reason()).
  Error validate() const;
};

struct PortSpec {
  enum class Kind : uint8_t { serial, tcp, rtu_tcp, pty };
  Kind kind = Kind::serial;
  std::string path;   ///< serial device, or the pty symlink (may be empty)
  std::string host;   ///< tcp kinds
  uint16_t port = 0;  ///< tcp kinds
  SerialSettings serial{};

  std::string describe() const;
  bool is_tcp() const noexcept { return kind == Kind::tcp || kind == Kind::rtu_tcp; }
};

/// "HOST:PORT" as parse_port reads it back: an IPv6 address in brackets
/// ("[::1]:1502"), so a printed address can be pasted into --port.
std::string host_port_text(std::string_view host, uint16_t port);

/// For a TCP listener: what it exposes, or empty when it binds loopback only
/// (an empty host is 127.0.0.1). "every network interface" for 0.0.0.0 and
/// ::, "the network" for any other address that is not loopback.
std::string listener_exposure(const PortSpec& spec);

/// Parses the port syntax above. `listening` allows `pty`. Errors:
/// invalid_argument, with a one-line reason (Error::reason()).
Result<PortSpec> parse_port(std::string_view text, bool listening);

/// Silence that ends a frame on a Linux link, at least. USB serial adapters
/// deliver bytes in chunks up to 16 ms apart (FTDI's default latency timer)
/// when the low-latency flag is not honoured; a shorter silence would cut
/// slow frames in the middle. Frames are delimited by length prediction
/// anyway; silence only ends garbage and frames of unknown function.
inline constexpr uint32_t kLinuxSilenceFloorUs = 20000;

/// The framer timing to use on a link of this kind: the t3.5 of the baud
/// rate, never less than kLinuxSilenceFloorUs; t1.5 is not enforced (chunks).
RtuTiming link_timing(const PortSpec& spec) noexcept;

}  // namespace rtukit::io
