// The MBAP stream of Modbus TCP: arbitrary bytes arriving in arbitrary
// chunks, cut into ADUs with mbap_adu_size exactly as the servers
// (driver/src/tcp_sessions.hpp, each_mbap_adu) and the master do: a receive
// buffer of 2 x kMaxMbapAduSize, each read at most the room left, complete
// ADUs taken from its front, the rest moved down.
// Properties: never crashes; every ADU is 8..260 bytes with protocol id 0 and
// a length field of size - 6; its header fields and PDU re-encode
// (mbap_encode) to exactly its bytes; the buffer always has room for the next
// read (a stream never stalls); the ADUs, and where the stream is declared
// out of step, are the same whatever the chunking (compared with reads as
// large as the buffer takes and with one byte at a time).
//
// Input: n (1 byte), n chunk sizes (1 byte each), then the stream.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "rtukit/core.hpp"

namespace {

using namespace rtukit;

struct Cut {
  std::vector<std::vector<uint8_t>> adus;
  bool out_of_step = false;
  friend bool operator==(const Cut&, const Cut&) = default;
};

void check_adu(std::span<const uint8_t> adu) {
  if (adu.size() < kMbapHeaderSize + 1 || adu.size() > kMaxMbapAduSize) std::abort();
  const MbapHeader h = mbap_header(adu);
  if (h.protocol != 0 || h.length != adu.size() - 6) std::abort();
  std::array<uint8_t, kMaxMbapAduSize> again{};
  const Result<size_t> n = mbap_encode(h.transaction, h.unit, mbap_pdu(adu), again);
  if (!n.ok() || *n != adu.size() || std::memcmp(again.data(), adu.data(), adu.size()) != 0) std::abort();
}

// The stream through a session's buffer, each read `chunk(k)` bytes at most.
template <class Chunk>
Cut cut_stream(std::span<const uint8_t> stream, Chunk chunk) {
  Cut out;
  std::array<uint8_t, 2 * kMaxMbapAduSize> rx{};
  size_t len = 0, fed = 0;
  for (size_t k = 0; fed < stream.size(); ++k) {
    const size_t room = rx.size() - len;
    if (room == 0) std::abort();  // a read of 0 bytes: the session would stall
    size_t n = chunk(k);
    if (n > room) n = room;
    if (n > stream.size() - fed) n = stream.size() - fed;
    std::memcpy(rx.data() + len, stream.data() + fed, n);
    len += n;
    fed += n;
    size_t pos = 0;
    for (;;) {
      const Result<size_t> size = mbap_adu_size({rx.data() + pos, len - pos});
      if (!size.ok()) {
        if (size.error().code() != Errc::malformed) std::abort();
        out.out_of_step = true;  // the session closes here
        return out;
      }
      if (*size == 0 || *size > len - pos) break;
      check_adu({rx.data() + pos, *size});
      out.adus.emplace_back(rx.data() + pos, rx.data() + pos + *size);
      pos += *size;
    }
    std::memmove(rx.data(), rx.data() + pos, len - pos);
    len -= pos;
  }
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const size_t sizes = data[0] % 16;
  if (size < 1 + sizes) return 0;
  const std::span<const uint8_t> chunks(data + 1, sizes);
  const std::span<const uint8_t> stream(data + 1 + sizes, size - 1 - sizes);

  const Cut chunked = cut_stream(stream, [&](size_t k) -> size_t {
    return chunks.empty() ? 7 : 1 + chunks[k % chunks.size()] * 2;  // 1..511: past the room too
  });
  const Cut largest = cut_stream(stream, [](size_t) { return SIZE_MAX; });
  const Cut bytewise = cut_stream(stream, [](size_t) { return size_t{1}; });
  if (!(chunked == largest) || !(bytewise == largest)) std::abort();
  return 0;
}
