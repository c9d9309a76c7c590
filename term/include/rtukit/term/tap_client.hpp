// rtukit io: the client side of a TapServer (tap_server.hpp): reads the text
// lines a virtual bus's tap sends (`rtukit sniff --bus NAME`), the format of
// those lines (the header a tap starts with, then one character a line), and
// where a named bus offers its tap.
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

#include "rtukit/base/status.hpp"

namespace rtukit::term {

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

/// A character as the bus tap reports it: when it was on the line, who sent
/// it, what was sent and what the listeners heard.
struct TapCharacter {
  uint64_t start_us = 0;
  uint64_t end_us = 0;
  int sender = -1;    ///< the port that sent it; -1 for a stray byte
  uint8_t sent = 0;   ///< what the sender sent
  uint8_t heard = 0;  ///< what the listeners got (differs after a collision or bit error)
  bool collided = false;
  bool dropped = false;
};

/// One character as a tap line (docs/bus-tools.md), ending with '\n':
/// "start_us end_us sender sent heard [flags]", sent and heard as two hex
/// digits, flags c (collision) and d (dropped), e.g. "0 520 1 01 01 c\n".
std::string tap_line(const TapCharacter& c);

/// One tap line read back (with or without its '\n'); nullopt for a comment
/// (it starts with '#', as the header does), an empty line, or a line that
/// is not one (fewer than five fields, a byte above FF).
std::optional<TapCharacter> parse_tap_line(const std::string& line);

/// Where the bus named `name` offers its tap (`rtukit bus --name NAME`, read
/// by `rtukit sniff --bus NAME`): $XDG_RUNTIME_DIR/rtukit/bus-NAME.sock, else
/// (unset or empty) /tmp/rtukit-UID/bus-NAME.sock. Nothing is created.
/// Errors: invalid_argument unless the name is 1..64 letters, digits, '-'
/// or '_', reason "bus name 'NAME': use 1 to 64 letters, digits, '-' or '_'".
Outcome<std::string> bus_tap_socket(const std::string& name);

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

}  // namespace rtukit::term
