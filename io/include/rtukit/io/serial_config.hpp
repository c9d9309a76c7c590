// rtukit io: configuring a serial file descriptor (Linux only).
//
// Kept apart from Asio because <asm/termbits.h> (termios2, BOTHER for any baud
// rate) cannot be included next to <termios.h>.
#pragma once

#include <string>

#include "rtukit/core/error.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit::io {

/// What configure_serial found out about the port.
struct SerialCapabilities {
  bool kernel_rs485 = false;  ///< TIOCSRS485 accepted: the kernel drives RTS
  bool low_latency = false;   ///< ASYNC_LOW_LATENCY set
};

/// Puts `fd` in raw mode with `settings`: baud (BOTHER when not a standard
/// rate), parity, data and stop bits; exclusive (TIOCEXCL, and an advisory
/// flock that also holds against root: EBUSY when taken); RS-485 through
/// TIOCSRS485 when the driver supports it (else the caller toggles RTS).
/// Errors: io_error with the OS error number. A pty accepts all of this
/// except RS-485 and low latency, which are then reported as unavailable.
/// Unread input is discarded, output never: this is also how a port in use
/// changes its baud rate at run time (after tcdrain), and what was written
/// just before must still go out.
Result<SerialCapabilities> configure_serial(int fd, const SerialSettings& settings);

/// Opens `path` non-blocking and configures it (configure_serial). Returns the
/// file descriptor, which the caller owns. Errors: io_error with the OS error.
Result<int> open_serial_port(const std::string& path, const SerialSettings& settings);

/// Sets (true) or clears RTS. For RS-485 without kernel support.
Error set_rts(int fd, bool on);

/// Waits until everything written to `fd` has left the UART (tcdrain).
Error drain(int fd);

/// Puts a pty end in raw mode (no echo, no line discipline).
Error make_raw(int fd);

/// Whether the driver of the port at `path` has a kernel RS-485 mode
/// (TIOCGRS485 answers). Asked without taking the port: opened non-blocking,
/// nothing configured, closed at once. False when the port cannot be opened.
bool kernel_rs485_available(const std::string& path);

}  // namespace rtukit::io
