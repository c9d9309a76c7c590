// Helpers several fuzz targets share (core only: no heap, no third-party
// headers, so the core targets can use it too).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string_view>

namespace rtukit::fuzz {

/// True when `part` lies inside `whole` (an empty part anywhere counts): a
/// decoded view never reaches past the bytes it was decoded from.
inline bool within(std::span<const uint8_t> part, std::span<const uint8_t> whole) {
  if (part.empty()) return true;
  // std::less gives a total order on pointers into unrelated objects too.
  const std::less<const uint8_t*> before;
  return !before(part.data(), whole.data()) &&
         !before(whole.data() + whole.size(), part.data() + part.size());
}

/// True when `s` is valid UTF-8 (no overlong forms, no surrogates, at most
/// U+10FFFF): what JSON text sent to a client must be. nlohmann::json::dump()
/// throws on anything else, so a reason that echoes raw input bytes would
/// take its caller down.
inline bool valid_utf8(std::string_view s) {
  size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<uint8_t>(s[i]);
    size_t n = 0;
    uint32_t cp = 0, min = 0;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xE0) == 0xC0) {
      n = 1, cp = c & 0x1F, min = 0x80;
    } else if ((c & 0xF0) == 0xE0) {
      n = 2, cp = c & 0x0F, min = 0x800;
    } else if ((c & 0xF8) == 0xF0) {
      n = 3, cp = c & 0x07, min = 0x10000;
    } else {
      return false;
    }
    if (s.size() - i <= n) return false;  // cut short
    for (size_t k = 1; k <= n; ++k) {
      const auto d = static_cast<uint8_t>(s[i + k]);
      if ((d & 0xC0) != 0x80) return false;
      cp = cp << 6 | (d & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += n + 1;
  }
  return true;
}

}  // namespace rtukit::fuzz
