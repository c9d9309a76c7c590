// rtukit core: the MBAP header of Modbus TCP (Modbus Messaging on TCP/IP v1.0b).
//
// An MBAP ADU = transaction id (2) + protocol id (2, always 0) + length (2,
// counts unit id + PDU) + unit id (1) + PDU. No CRC: TCP guards the bytes.
// All fields big-endian. The functions are compiled in with RTUKIT_CORE_TCP
// (config.hpp); the sizes are always there.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "rtukit/core/config.hpp"
#include "rtukit/core/error.hpp"

namespace rtukit {

inline constexpr size_t kMbapHeaderSize = 7;
inline constexpr size_t kMaxMbapAduSize = kMbapHeaderSize + 253;

#if RTUKIT_CORE_TCP

struct MbapHeader {
  uint16_t transaction = 0;
  uint16_t protocol = 0;
  uint16_t length = 0;  ///< unit id + PDU
  uint8_t unit = 0;
};

/// Writes header + `pdu` into `out`. Errors: invalid_argument (PDU empty or
/// over 253 bytes), buffer_too_small.
Result<size_t> mbap_encode(uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu,
                           std::span<uint8_t> out) noexcept;

/// Size of the ADU that starts `stream`: 0 when fewer than 7 bytes have
/// arrived (need more). Errors: malformed (protocol id not 0, length < 2 or
/// > 254): the connection is out of step and should be closed.
Result<size_t> mbap_adu_size(std::span<const uint8_t> stream) noexcept;

/// The header of a complete ADU. Precondition: adu.size() >= 7.
MbapHeader mbap_header(std::span<const uint8_t> adu) noexcept;

/// The PDU of a complete ADU. Precondition: adu.size() >= 8.
inline std::span<const uint8_t> mbap_pdu(std::span<const uint8_t> adu) noexcept {
  return adu.subspan(kMbapHeaderSize);
}
#endif  // RTUKIT_CORE_TCP

}  // namespace rtukit
