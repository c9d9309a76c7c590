// What device simulators share: device time scaled from a DriverClock, a
// periodic tick on an io_context (so a model advances even when nobody
// polls), and the small parsers their consoles use.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/io/asio_fwd.hpp"

namespace rtukit {

/// Device milliseconds = milliseconds of `clock` since construction x
/// `scale` (60: a device minute per real second). Models take this as their
/// "now". `clock` must outlive the DeviceClock.
class DeviceClock {
 public:
  explicit DeviceClock(double scale = 1.0, const DriverClock& clock = SteadyClock::instance()) noexcept
      : scale_(scale), clock_(clock), t0_(clock.now()) {}
  uint64_t now_ms() const noexcept {
    const auto real = std::chrono::duration<double, std::milli>(clock_.now() - t0_).count();
    return static_cast<uint64_t>(real * scale_);
  }
  double scale() const noexcept { return scale_; }
  /// The scales simulators accept: > 0 and at most 100000.
  static bool valid_scale(double scale) noexcept { return scale > 0 && scale <= 100000; }

 private:
  double scale_;
  const DriverClock& clock_;
  Clock::time_point t0_;
};

/// Calls `tick` every `period` on `ctx`'s thread until destroyed.
class PeriodicTimer {
 public:
  PeriodicTimer(asio::io_context& ctx, std::chrono::milliseconds period, std::function<void()> tick);
  ~PeriodicTimer();
  PeriodicTimer(const PeriodicTimer&) = delete;
  PeriodicTimer& operator=(const PeriodicTimer&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "fault  motor-drive on" -> {"fault", "motor-drive", "on"}.
std::vector<std::string> split_words(std::string_view line);
/// A whole integer in `base`, or in hex with a 0x prefix; nullopt otherwise.
std::optional<long> parse_long(std::string_view text, int base = 10) noexcept;
/// A whole decimal number ("95", "-12.5"); nullopt otherwise.
std::optional<double> parse_double(std::string_view text) noexcept;

}  // namespace rtukit
