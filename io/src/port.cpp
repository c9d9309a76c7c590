#include "rtukit/io/port.hpp"

#include <boost/asio/ip/address.hpp>
#include <charconv>
#include <string>

#include "rtukit/io/asio_fwd.hpp"

namespace rtukit::io {

Error SerialSettings::validate() const {
  auto fail = [](const char* reason) { return Error(Errc::invalid_argument, reason); };
  if (baud < 1200 || baud > 921600) return fail("baud rate must be 1200..921600");
  if (parity != 'N' && parity != 'E' && parity != 'O') return fail("parity must be N, E or O");
  if (data_bits != 7 && data_bits != 8) return fail("data bits must be 7 or 8");
  if (stop_bits != 1 && stop_bits != 2) return fail("stop bits must be 1 or 2");
  return {};
}

std::string PortSpec::describe() const {
  switch (kind) {
    case Kind::serial:
      return path + " " + std::to_string(serial.baud) + " " + std::to_string(serial.data_bits) +
             serial.parity + std::to_string(serial.stop_bits);
    case Kind::tcp:
      return "tcp://" + host_port_text(host, port);
    case Kind::rtu_tcp:
      return "rtu+tcp://" + host_port_text(host, port);
    case Kind::pty:
      return path.empty() ? "pty" : "pty:" + path;
  }
  return "?";
}

std::string host_port_text(std::string_view host, uint16_t port) {
  const bool v6 = host.find(':') != std::string_view::npos && !host.starts_with("[");
  return (v6 ? "[" + std::string(host) + "]" : std::string(host)) + ":" + std::to_string(port);
}

std::string listener_exposure(const PortSpec& spec) {
  if (!spec.is_tcp() || spec.host.empty()) return {};
  boost::system::error_code ec;
  const asio::ip::address a = asio::ip::make_address(spec.host, ec);
  if (ec || a.is_loopback()) return {};  // a bad address is refused when listening, not here
  return a.is_unspecified() ? "every network interface" : "the network";
}

namespace {

Result<PortSpec> parse_host_port(std::string_view rest, PortSpec spec) {
  const auto colon = rest.rfind(':');
  if (colon == std::string_view::npos || colon == 0) {
    return Error(Errc::invalid_argument, "expected HOST:PORT");
  }
  spec.host = std::string(rest.substr(0, colon));
  if (spec.host.size() > 2 && spec.host.front() == '[' && spec.host.back() == ']') {
    spec.host = spec.host.substr(1, spec.host.size() - 2);  // [::1]
  }
  const std::string_view num = rest.substr(colon + 1);
  unsigned value = 0;
  const auto [ptr, ec] = std::from_chars(num.data(), num.data() + num.size(), value);
  if (ec != std::errc() || ptr != num.data() + num.size() || value > 65535) {
    return Error(Errc::invalid_argument, "port number must be 0..65535");
  }
  spec.port = static_cast<uint16_t>(value);
  return spec;
}

}  // namespace

Result<PortSpec> parse_port(std::string_view text, bool listening) {
  PortSpec spec;
  if (text.starts_with("tcp://")) {
    spec.kind = PortSpec::Kind::tcp;
    return parse_host_port(text.substr(6), spec);
  }
  if (text.starts_with("rtu+tcp://")) {
    spec.kind = PortSpec::Kind::rtu_tcp;
    return parse_host_port(text.substr(10), spec);
  }
  if (text == "pty" || text.starts_with("pty:")) {
    if (!listening) {
      return Error(Errc::invalid_argument, "pty is for listening; to talk to a pty, give its path");
    }
    spec.kind = PortSpec::Kind::pty;
    if (text.size() > 4) spec.path = std::string(text.substr(4));
    return spec;
  }
  if (text.empty() || text.find("://") != std::string_view::npos) {
    return Error(Errc::invalid_argument, "expected a device path, tcp://HOST:PORT or rtu+tcp://HOST:PORT");
  }
  spec.kind = PortSpec::Kind::serial;
  spec.path = std::string(text);
  return spec;
}

RtuTiming link_timing(const PortSpec& spec) noexcept {
  if (spec.is_tcp()) return RtuTiming{0, kLinuxSilenceFloorUs};
  RtuTiming t = RtuTiming::for_serial(spec.serial.baud, spec.serial.bits_per_char());
  t.t15_us = 0;
  if (t.t35_us < kLinuxSilenceFloorUs) t.t35_us = kLinuxSilenceFloorUs;
  return t;
}

}  // namespace rtukit::io
