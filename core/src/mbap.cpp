#include "rtukit/core/mbap.hpp"

#include <cstring>

#include "rtukit/core/pdu.hpp"

#if RTUKIT_CORE_TCP
namespace rtukit {

Result<size_t> mbap_encode(uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu,
                           std::span<uint8_t> out) noexcept {
  if (pdu.empty() || pdu.size() > kMaxPduSize) return Errc::invalid_argument;
  const size_t n = kMbapHeaderSize + pdu.size();
  if (out.size() < n) return Errc::buffer_too_small;
  store_be16(&out[0], transaction);
  store_be16(&out[2], 0);
  store_be16(&out[4], static_cast<uint16_t>(pdu.size() + 1));
  out[6] = unit;
  std::memcpy(&out[kMbapHeaderSize], pdu.data(), pdu.size());
  return n;
}

Result<size_t> mbap_adu_size(std::span<const uint8_t> stream) noexcept {
  if (stream.size() < kMbapHeaderSize) return size_t{0};
  const uint16_t protocol = load_be16(&stream[2]);
  const uint16_t length = load_be16(&stream[4]);
  if (protocol != 0 || length < 2 || length > kMaxPduSize + 1) return Errc::malformed;
  return size_t{6} + length;
}

MbapHeader mbap_header(std::span<const uint8_t> adu) noexcept {
  return MbapHeader{load_be16(&adu[0]), load_be16(&adu[2]), load_be16(&adu[4]), adu[6]};
}

}  // namespace rtukit
#endif  // RTUKIT_CORE_TCP
