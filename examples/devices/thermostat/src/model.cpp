#include "rtukit/devices/thermostat/model.hpp"

#include <algorithm>

namespace rtukit::thermostat {

int64_t Thermostat::heat_percent() const noexcept {
  const int64_t mode = image().get(reg::mode);
  const int64_t below = image().get(reg::setpoint) - image().get(reg::temperature);  // tenths of a degree
  if (mode == kModes[0].value) return 0;
  if (mode == kModes[2].value) return below > -10 ? 100 : 0;
  return std::clamp<int64_t>(below * 10, 0, 100);
}

// In whole tenths of a degree: 6000 heater-ms at 100 % warm the room by 0.1
// degC; 12000 ms without heat cool it by 0.1 degC while it is above 15 degC.
void Thermostat::advance_to(uint64_t now_ms) noexcept {
  while (now_ms_ < now_ms) {
    const uint64_t step = std::min<uint64_t>(now_ms - now_ms_, 100);
    now_ms_ += step;
    const int64_t heat = heat_percent();
    image().set(reg::heating, heat);
    heat_ms_ += step * static_cast<uint64_t>(heat);
    cool_ms_ += step;
    int64_t t = image().get(reg::temperature);
    if (heat_ms_ >= 6000 * 100) {
      heat_ms_ -= 6000 * 100;
      ++t;
    }
    if (cool_ms_ >= 12000) {
      cool_ms_ -= 12000;
      if (t > 150) --t;
    }
    image().set(reg::temperature, t);
  }
}

}  // namespace rtukit::thermostat
