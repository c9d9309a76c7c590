// rtukit io: the transports' time stamp. A received character is stamped
// with the OS's time of arrival, on the steady clock (base/clock.hpp's
// Clock), in microseconds: the time base the RTU framer measures its
// silences in. Only io/ and the servers that feed the framer read it.
#pragma once

#include <chrono>
#include <cstdint>

#include "rtukit/base/clock.hpp"

namespace rtukit::io {

/// Microseconds on the steady clock, the time base handed to the core.
inline uint64_t now_us() noexcept {
  return static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch()).count());
}

}  // namespace rtukit::io
