// Why the chair does not do what a client asks, or why a control is greyed
// out: one table, the words every front-end shows and the number a phone
// app is sent over Bluetooth (docs/rehand6600-ble.md), where a result or a
// state has room for a byte and not for the sentence.
//
// The session, the host controller and the daemon build their refusals from
// these texts; reason_of() finds the entry a refusal was built from. The
// numbers are part of the Bluetooth service: never renumbered, only added.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace rtukit::rehand6600 {

enum class Reason : uint8_t {
  none = 0,
  error_active = 1,     ///< an error of table 3 is active (its code is in the state)
  no_controller = 2,    ///< 1010: no communication with the controller
  stop_latched = 3,     ///< the display's STOP is on
  stopping = 4,         ///< a loss of control is being stopped (0x006A held until still)
  waiting = 5,          ///< no fresh state from the controller yet
  charging = 6,         ///< no driving while charging
  push_mode = 7,        ///< the clutch in push (free-wheel) mode
  not_seated = 8,       ///< the chair not fully seated
  joystick = 9,         ///< the joystick on the chair is in use
  not_static = 10,      ///< a phone starts driving only while the chair is still
  another_driver = 11,  ///< another phone holds the driver's seat
  not_allowed = 12,     ///< R-18: the display has not allowed this phone to drive yet
  speed_level = 13,     ///< D-14: the chair could not be set to speed level 1
  ended = 14,           ///< a press that ended (lapsed, stopped) is not renewed
  raise_charging = 15,  ///< no standing up or raising the seat while charging
  other = 255,          ///< a refusal without an entry: its text says why
};

struct ReasonText {
  Reason reason;
  /// The words. For entries whose refusal carries more (the error's name,
  /// the press's id), the part every such refusal contains.
  std::string_view text;
};

/// Every reason but none and other, in the table's order.
std::span<const ReasonText> reasons() noexcept;

/// The words of `r`; "" for none, "refused" for other.
std::string_view reason_text(Reason r) noexcept;

/// The reason a refusal's text was built from: the first entry whose words
/// the text contains; none for "", other when no entry matches.
Reason reason_of(std::string_view refusal) noexcept;

}  // namespace rtukit::rehand6600
