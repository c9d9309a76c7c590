// Test helpers: wire bytes typed from the documents, as hex strings.
#pragma once

#include <cstdint>
#include <span>
#include <sstream>
#include <string>
#include <vector>

namespace rtukit::test {

/// "15 03 00 00" -> {0x15, 0x03, 0x00, 0x00}.
inline std::vector<uint8_t> bytes(const std::string& hex) {
  std::vector<uint8_t> out;
  std::istringstream in(hex);
  std::string tok;
  while (in >> tok) out.push_back(static_cast<uint8_t>(std::stoul(tok, nullptr, 16)));
  return out;
}

/// {0x15, 0x03} -> "15 03".
inline std::string hex(std::span<const uint8_t> b) {
  static const char* digits = "0123456789ABCDEF";
  std::string s;
  for (uint8_t x : b) {
    if (!s.empty()) s += ' ';
    s += digits[x >> 4];
    s += digits[x & 15];
  }
  return s;
}

}  // namespace rtukit::test
