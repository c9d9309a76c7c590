// A sniffer times frames by when their bytes arrive, so a read stamps its
// chunk as the wait ends, and waits with a short timeout the caller picks:
// between reads it closes frames by the clock (silence ends a frame).
#include "rtukit/io/listen_port.hpp"

#include <poll.h>
#include <unistd.h>

#include <cerrno>

#include "rtukit/io/now.hpp"
#include "rtukit/io/serial_config.hpp"

namespace rtukit::io {

Result<std::unique_ptr<ListenPort>> ListenPort::open(const std::string& path,
                                                     const SerialSettings& settings) {
  Result<int> fd = open_serial_port(path, settings);
  if (!fd.ok()) return fd.error();
  return std::unique_ptr<ListenPort>(new ListenPort(*fd));
}

ListenPort::~ListenPort() {
  ::close(fd_);
}

Result<ListenPort::Chunk> ListenPort::read(std::chrono::milliseconds timeout) {
  pollfd p{fd_, POLLIN, 0};
  const int ready = ::poll(&p, 1, static_cast<int>(timeout.count()));
  Chunk chunk;
  chunk.at_us = now_us();
  if (ready <= 0) return chunk;
  chunk.bytes.resize(kMaxChunk);
  const ssize_t n = ::read(fd_, chunk.bytes.data(), chunk.bytes.size());
  if (n < 0) {
    const int e = errno;
    // The port is non-blocking: a wake-up with nothing to read is no error.
    if (e != EAGAIN && e != EINTR) return Error(Errc::io_error, e);
    chunk.bytes.clear();
    return chunk;
  }
  chunk.bytes.resize(static_cast<size_t>(n));
  return chunk;
}

}  // namespace rtukit::io
