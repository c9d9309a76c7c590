// The tap's reader is a sniffer, which paces itself (it closes frames by
// the clock between reads), so the client is a plain blocking socket with a
// poll timeout rather than an Asio object: the caller decides how long a
// read may wait and does its own work between reads.
#include "rtukit/term/tap_client.hpp"

#include <fmt/core.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace rtukit::term {

namespace {

// "key=value" from a header; 0 when absent. The key must follow a space, so
// "baud=" never matches inside another key.
uint64_t header_value(const std::string& header, const std::string& key) {
  const size_t at = header.find(" " + key + "=");
  return at == std::string::npos ? 0 : std::strtoull(header.c_str() + at + key.size() + 2, nullptr, 10);
}

}  // namespace

std::string tap_header(uint32_t baud, uint32_t bits_per_char, uint64_t now_us) {
  const std::string columns =
      "# rtukit bus tap: start_us end_us sender(-1 stray) sent heard flags(c collision, d dropped);";
  return columns + " baud=" + std::to_string(baud) + " bits=" + std::to_string(bits_per_char) +
         " now_us=" + std::to_string(now_us) + "\n";
}

std::optional<TapHeader> parse_tap_header(const std::string& line) {
  const uint64_t baud = header_value(line, "baud"), bits = header_value(line, "bits");
  if (baud == 0 || bits == 0) return std::nullopt;
  return TapHeader{.baud = static_cast<uint32_t>(baud),
                   .bits_per_char = static_cast<uint32_t>(bits),
                   .now_us = header_value(line, "now_us")};
}

std::string tap_line(const TapCharacter& c) {
  return fmt::format("{} {} {} {:02X} {:02X}{}{}{}\n", c.start_us, c.end_us, c.sender, c.sent, c.heard,
                     c.collided || c.dropped ? " " : "", c.collided ? "c" : "", c.dropped ? "d" : "");
}

std::optional<TapCharacter> parse_tap_line(const std::string& line) {
  if (line.empty() || line[0] == '#') return std::nullopt;
  unsigned long long start = 0, end = 0;
  int sender = 0;
  unsigned sent = 0, heard = 0;
  char flags[8] = {};
  const int n =
      std::sscanf(line.c_str(), "%llu %llu %d %x %x %7s", &start, &end, &sender, &sent, &heard, flags);
  if (n < 5 || sent > 0xFF || heard > 0xFF) return std::nullopt;
  TapCharacter c;
  c.start_us = start;
  c.end_us = end;
  c.sender = sender;
  c.sent = static_cast<uint8_t>(sent);
  c.heard = static_cast<uint8_t>(heard);
  c.collided = std::strchr(flags, 'c') != nullptr;
  c.dropped = std::strchr(flags, 'd') != nullptr;
  return c;
}

Outcome<std::string> bus_tap_socket(const std::string& name) {
  // The name becomes part of a path: no '/', no "..", nothing a shell quotes.
  const bool good = !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  });
  if (!good)
    return Status(Errc::invalid_argument,
                  fmt::format("bus name '{}': use 1 to 64 letters, digits, '-' or '_'", name));
  // The user's runtime folder (private to them) when the session has one;
  // else one folder per user under /tmp.
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  const std::string dir =
      runtime && *runtime ? std::string(runtime) + "/rtukit" : fmt::format("/tmp/rtukit-{}", ::getuid());
  return dir + "/bus-" + name + ".sock";
}

Outcome<std::unique_ptr<TapClient>> TapClient::connect(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path)
    return Status(Errc::invalid_argument, path + ": too long for a Unix socket");
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    const int e = errno;
    return Status(Error(Errc::io_error, e), "cannot make a socket: " + std::string(std::strerror(e)));
  }
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    ::close(fd);
    return Status(Error(Errc::not_connected, e), path + ": " + std::strerror(e));
  }
  return std::unique_ptr<TapClient>(new TapClient(fd));
}

TapClient::~TapClient() {
  ::close(fd_);
}

Outcome<std::vector<std::string>> TapClient::read_lines(std::chrono::milliseconds timeout) {
  if (!ended_.ok()) return ended_;
  std::vector<std::string> lines;
  pollfd p{fd_, POLLIN, 0};
  // A poll cut short (a signal: Ctrl-C) is a read with nothing in it; the
  // caller looks at its own flags and calls again.
  if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return lines;
  char chunk[4096];
  const ssize_t n = ::read(fd_, chunk, sizeof chunk);
  if (n < 0) {
    const int e = errno;
    ended_ = Status(Error(Errc::io_error, e), "tap: " + std::string(std::strerror(e)));
    return ended_;
  }
  if (n == 0) {
    ended_ = Status(Errc::not_connected, "the tap's server closed the connection");
    return ended_;
  }
  buffer_.append(chunk, static_cast<size_t>(n));
  for (size_t nl; (nl = buffer_.find('\n')) != std::string::npos;) {
    lines.push_back(buffer_.substr(0, nl));
    buffer_.erase(0, nl + 1);
  }
  return lines;
}

}  // namespace rtukit::term
