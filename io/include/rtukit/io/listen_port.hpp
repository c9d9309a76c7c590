// rtukit io: a serial port opened to listen only (`rtukit sniff --port`):
// configured like any port, never written to.
//
// Blocking, with a timeout per read, on the caller's thread; not
// thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rtukit/core/error.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit::io {

class ListenPort {
 public:
  /// Bytes that arrived together, and when.
  struct Chunk {
    std::vector<uint8_t> bytes;  ///< at most kMaxChunk; empty when none came
    uint64_t at_us = 0;          ///< now_us() when the wait ended, before the bytes were read
  };

  static constexpr size_t kMaxChunk = 512;

  /// Opens `path` with `settings` (open_serial_port: raw, exclusive).
  /// Errors: those of open_serial_port (io_error with the OS error).
  static Result<std::unique_ptr<ListenPort>> open(const std::string& path, const SerialSettings& settings);
  /// Closes the port.
  ~ListenPort();
  ListenPort(const ListenPort&) = delete;
  ListenPort& operator=(const ListenPort&) = delete;

  /// Waits at most `timeout` for input and returns what has arrived (up to
  /// kMaxChunk bytes; more waits for the next call). A wait cut short by a
  /// signal returns no bytes. Errors: io_error with the OS error when the
  /// read fails (an unplugged USB adapter: EIO, at once on every call).
  Result<Chunk> read(std::chrono::milliseconds timeout);

 private:
  explicit ListenPort(int fd) : fd_(fd) {}
  int fd_;
};

}  // namespace rtukit::io
