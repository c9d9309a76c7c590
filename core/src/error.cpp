#include "rtukit/core/error.hpp"

namespace rtukit {

std::string_view errc_name(Errc code) noexcept {
  switch (code) {
    case Errc::ok:
      return "ok";
    case Errc::illegal_function:
      return "illegal function";
    case Errc::illegal_data_address:
      return "illegal data address";
    case Errc::illegal_data_value:
      return "illegal data value";
    case Errc::server_device_failure:
      return "server device failure";
    case Errc::acknowledge:
      return "acknowledge";
    case Errc::server_device_busy:
      return "server device busy";
    case Errc::memory_parity_error:
      return "memory parity error";
    case Errc::gateway_path_unavailable:
      return "gateway path unavailable";
    case Errc::gateway_target_failed:
      return "gateway target device failed to respond";
    case Errc::timeout:
      return "timeout";
    case Errc::bad_crc:
      return "bad CRC";
    case Errc::malformed:
      return "malformed frame";
    case Errc::unexpected_response:
      return "unexpected response";
    case Errc::invalid_argument:
      return "invalid argument";
    case Errc::buffer_too_small:
      return "buffer too small";
    case Errc::io_error:
      return "I/O error";
    case Errc::not_connected:
      return "not connected";
    case Errc::refused:
      return "refused";
  }
  // A code received from the wire that the standard does not name.
  return static_cast<uint16_t>(code) <= 0xFF ? "unknown exception" : "unknown error";
}

}  // namespace rtukit
