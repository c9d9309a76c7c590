// The Rehand 6600's registers and error codes as people read them (host side).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "rtukit/devices/rehand6600/registers.hpp"

namespace rtukit::rehand6600 {

/// "spin left (4)", "12 km/h", "on", "-5", "0x68", "1010 Master Error".
std::string format_value(const Register& reg, uint16_t raw);
/// Tables 1 and 2 as Markdown (docs/rehand6600.md).
std::string registers_markdown();
/// The UI text: "1010 Master Error"; unknown codes: "1234 Unknown Error".
std::string error_text(uint16_t code);
/// Every listed code, ascending.
std::span<const uint16_t> error_codes() noexcept;
/// Table 3 as Markdown.
std::string errors_markdown();

}  // namespace rtukit::rehand6600
