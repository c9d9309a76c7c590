#include "rtukit/core/crc.hpp"

#include <array>

namespace rtukit {
namespace {

// Built at compile time so the table lands in flash on a microcontroller.
constexpr std::array<uint16_t, 256> make_table() {
  std::array<uint16_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    uint16_t crc = static_cast<uint16_t>(i);
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 1U) ? static_cast<uint16_t>((crc >> 1) ^ 0xA001U) : static_cast<uint16_t>(crc >> 1);
    }
    table[i] = crc;
  }
  return table;
}

constexpr std::array<uint16_t, 256> kTable = make_table();

}  // namespace

uint16_t crc16(std::span<const uint8_t> bytes, uint16_t seed) noexcept {
  uint16_t crc = seed;
  for (uint8_t b : bytes) {
    crc = static_cast<uint16_t>((crc >> 8) ^ kTable[(crc ^ b) & 0xFFU]);
  }
  return crc;
}

bool rtu_crc_ok(std::span<const uint8_t> frame) noexcept {
  if (frame.size() < 3) return false;
  const uint16_t crc = crc16(frame.first(frame.size() - 2));
  return frame[frame.size() - 2] == (crc & 0xFFU) && frame[frame.size() - 1] == (crc >> 8);
}

}  // namespace rtukit
