// rtukit core: CRC-16/Modbus (poly 0xA001 reflected, init 0xFFFF).
//
// On the wire the CRC is sent low byte first, after the frame bytes it covers.
// A frame with its CRC appended has a CRC of 0 over all of its bytes, which is
// how `rtu_crc_ok` checks a received frame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace rtukit {

/// CRC-16/Modbus of `bytes`, table-driven. `crc16({})` is 0xFFFF.
/// Pass a previous result as `seed` to continue over several pieces.
uint16_t crc16(std::span<const uint8_t> bytes, uint16_t seed = 0xFFFF) noexcept;

/// True when the last two bytes of `frame` are the CRC (low byte first) of the
/// bytes before them. False for frames shorter than 3 bytes.
bool rtu_crc_ok(std::span<const uint8_t> frame) noexcept;

}  // namespace rtukit
