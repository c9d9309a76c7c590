// rtukit io: the client side of a TapServer (tap_server.hpp): reads the text
// lines a virtual bus's tap sends (`rtukit sniff --bus NAME`), and the
// format of the header line such a tap starts with.
//
// Blocking, with a timeout per read, on the caller's thread; not
// thread-safe. Nothing is ever written to the server.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rtukit/io/status.hpp"

namespace rtukit::io {

/// What a bus tap's header says: the bus's rate and its clock when the
/// header was made (docs/bus-tools.md).
struct TapHeader {
  uint32_t baud = 0;
  uint32_t bits_per_char = 0;
  uint64_t now_us = 0;  ///< the bus's clock when the header was written
};

/// The header line a bus tap starts with (a '#' comment, ends with '\n'):
/// "# rtukit bus tap: ... baud=B bits=N now_us=T".
std::string tap_header(uint32_t baud, uint32_t bits_per_char, uint64_t now_us);

/// Reads back `line` (with or without its '\n'). A key that is absent reads
/// as 0; nullopt when baud or bits is 0 (not a bus tap's header).
std::optional<TapHeader> parse_tap_header(const std::string& line);

class TapClient {
 public:
  /// Connects to the tap server listening on the Unix socket `path`.
  /// Errors: invalid_argument when `path` is too long for a Unix socket;
  /// io_error with the OS error when no socket can be made; not_connected
  /// with the OS error when nothing accepts on `path` (ENOENT: no such
  /// socket, ECONNREFUSED: its server is gone), reason "PATH: OS reason".
  static Outcome<std::unique_ptr<TapClient>> connect(const std::string& path);
  /// Closes the connection.
  ~TapClient();
  TapClient(const TapClient&) = delete;
  TapClient& operator=(const TapClient&) = delete;

  /// Waits at most `timeout` for input and returns the complete lines
  /// (without their '\n') that have arrived, in order; none when nothing
  /// did. A line split across reads is returned once whole. The first line
  /// a TapServer sends is its header.
  /// Errors: not_connected when the server closed the connection ("the
  /// tap's server closed the connection"; an unfinished last line is
  /// dropped); io_error with the OS error when the read fails. After an
  /// error, every later read fails the same way.
  Outcome<std::vector<std::string>> read_lines(std::chrono::milliseconds timeout);

 private:
  explicit TapClient(int fd) : fd_(fd) {}
  int fd_;
  std::string buffer_;  // what arrived after the last '\n'
  Status ended_;        // set once the connection is over
};

}  // namespace rtukit::io
