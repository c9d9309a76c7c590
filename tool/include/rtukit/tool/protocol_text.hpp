// rtukit device profiles, host side: protocol facts in words, for the
// diagnostics and identification a host shows (`rtukit diag`, `rtukit
// ident`, a generic slave's --init file). Host side, not the core: a
// firmware never shows them, and the core keeps to its flash budget.
#pragma once

#include <cstdint>
#include <string>

namespace rtukit::tool {

/// One FC0C event byte (core's comm_event::k*) in words: "communications
/// restart", "entered listen-only mode", "received broadcast, communication
/// error", "sent, busy exception, in listen-only mode"; "event 0x05" for a
/// byte that is none of these.
std::string comm_event_text(uint8_t event);

/// FC2B/0E: the standard objects 0..6 (basic and regular categories):
/// "vendor", "product code", "revision", "vendor URL", "product name",
/// "model name", "application"; nullptr for any other id.
const char* device_object_name(uint8_t id) noexcept;
/// The same objects as keys (files, JSON): "vendor", "product_code",
/// "revision", "vendor_url", "product_name", "model_name", "application";
/// nullptr for any other id.
const char* device_object_key(uint8_t id) noexcept;
/// FC2B/0E's conformity level (bit 7, individual access, ignored): "basic",
/// "regular", "extended", or "unknown".
const char* conformity_level_name(uint8_t conformity) noexcept;

}  // namespace rtukit::tool
