// The thermostat's behaviour, pure: device time comes in through
// advance_to(), nothing here reads a clock or does I/O. The room warms at
// 0.1 degC per 6 s at full heat and cools at 0.1 degC per 12 s toward 15
// degC; the heater is proportional (10 % per 0.1 degC below the set
// temperature; "boost": full heat up to the set temperature + 1 degC).
#pragma once

#include <cstdint>

#include "rtukit/devices/profile/model.hpp"
#include "rtukit/devices/thermostat/registers.hpp"

namespace rtukit::thermostat {

class Thermostat : private profile::ImageStorage<kMap.image_size()>, public profile::Model {
 public:
  Thermostat() noexcept : Model(kProfile, words) { image().set(reg::temperature, 180); }
  void advance_to(uint64_t now_ms) noexcept override;

 private:
  int64_t heat_percent() const noexcept;
  uint64_t now_ms_ = 0;
  uint64_t heat_ms_ = 0;  ///< heater-ms not yet turned into warmth
  uint64_t cool_ms_ = 0;
};

}  // namespace rtukit::thermostat
