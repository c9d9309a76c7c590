// The Rehand 6600's registers and error codes as people read them (host side).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "rtukit/devices/rehand6600/registers.hpp"

namespace rtukit::rehand6600 {

/// "spin left (4)", "12 km/h", "on", "-5", "0x68", "1010 Master Error".
std::string format_value(const Register& reg, uint16_t raw);
/// Tables 1 and 2 as Markdown (docs/rehand6600.md).
std::string registers_markdown();
/// The UI text: "1010 Master Error"; unknown codes: "1234 Unknown Error".
std::string error_text(uint16_t code);
/// What `code` means and what to check, for the person at the chair:
/// "the seat-lift actuator (actuator 1) or its drive reports a fault; check:
/// nothing blocks ...". 1010 as the host raises it: no answer from the
/// controller. Every code gets advice (an unknown one: the controller's).
std::string error_advice(uint16_t code);
/// Every listed code, ascending.
std::span<const uint16_t> error_codes() noexcept;
/// Table 3 as Markdown.
std::string errors_markdown();

/// How the chair stops from its top speed for one speed level and drive mode
/// (D-9), measured on the model's clock: driving forward from the phone at
/// full speed, then either a release (the host writes 0: normal braking) or a
/// host that falls silent (the watchdog trips: emergency braking). Times and
/// distances count from the last request the controller executed.
struct StoppingEntry {
  unsigned level = 1;  ///< 1..5
  uint16_t mode = 1;   ///< 1 normal, 2 indoor, 3 outdoor
  double top_kmh = 0;
  double release_s = 0, release_m = 0;
  double host_lost_s = 0, host_lost_m = 0;
  struct Stop {
    double seconds = 0, metres = 0;
  };
};
/// Every level x mode, level-major, with the default model and a 500-ms watchdog.
std::vector<StoppingEntry> stopping_table();
/// The table as Markdown (docs/rehand6600.md).
std::string stopping_markdown();

}  // namespace rtukit::rehand6600
