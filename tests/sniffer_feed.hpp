// Feeding a Sniffer in tests: bytes on a 9600-baud line, on time stamps the
// test chooses (the sniffer is sans-IO: time is passed in).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rtukit/driver/sniffer.hpp"

namespace rtukit::test {

constexpr uint64_t kChar = 1041;  // us, one character at 9600 8N1

/// Feeds `bytes` back to back from `t` (each byte's end time), with `gap_us`
/// more before byte `gap_after` (0: no gap); returns the end of the last.
inline uint64_t send(Sniffer& s, const std::vector<uint8_t>& bytes, uint64_t t, size_t gap_after = 0,
                     uint64_t gap_us = 0) {
  for (size_t i = 0; i < bytes.size(); ++i) {
    t += kChar;
    if (gap_after && i == gap_after) t += gap_us;
    s.feed(bytes[i], t);
  }
  return t;
}

}  // namespace rtukit::test
