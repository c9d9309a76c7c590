// The RTU framer on arbitrary bytes, in arbitrary chunks at arbitrary times.
// Properties: never crashes; every frame it returns has a valid CRC, is 4..256
// bytes long, and the framer never holds more than its buffer.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "rtukit/core.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  using namespace rtukit;
  const FrameShape shape = (data[0] & 1) ? FrameShape::request : FrameShape::response;
  const RtuTiming timing = (data[0] & 2) ? RtuTiming::for_serial(9600) : RtuTiming{};
  RtuFramer framer(shape, timing);
  if (data[0] & 4) framer.expect_response(data[1], static_cast<uint16_t>(data[1] * 3));
  if (data[0] & 8) framer.expect_echo({data, size < 16 ? size : 16});
  uint64_t now = 0;
  size_t pos = 2;
  while (pos < size) {
    const size_t chunk = 1 + data[pos - 1] % 64;
    const size_t n = chunk < size - pos ? chunk : size - pos;
    size_t fed = 0;
    while (fed < n) {
      fed += framer.feed({data + pos + fed, n - fed}, now);
      while (auto f = framer.next(now)) {
        if (f->adu.size() < 4 || f->adu.size() > kMaxRtuAduSize || !rtu_crc_ok(f->adu)) std::abort();
      }
      if (framer.buffered() > RtuFramer::kBufferSize) std::abort();
    }
    pos += n;
    now += (data[pos - 1] & 0x10) ? 10'000 : 100;
  }
  while (auto f = framer.next(now + 1'000'000)) {
    if (!rtu_crc_ok(f->adu)) std::abort();
  }
  return 0;
}
