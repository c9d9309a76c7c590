// The reasons' words (reasons.hpp). Entries whose refusals carry more than
// their words (an error's name, a press id) hold the part those refusals
// all contain, and come first where a shorter entry's words could also
// match.
#include "rtukit/devices/rehand6600/reasons.hpp"

#include <array>

namespace rtukit::rehand6600 {
namespace {

constexpr std::array kReasons = {
    ReasonText{Reason::no_controller, "no communication with the controller"},
    ReasonText{Reason::error_active, " is active"},
    ReasonText{Reason::stop_latched, "STOP is on: lift it on the display to use the chair again"},
    ReasonText{Reason::stopping, "stopping: wait until the chair is still"},
    ReasonText{Reason::waiting, "waiting for the controller's state"},
    ReasonText{Reason::raise_charging, "no standing up or raising the seat while charging"},
    ReasonText{Reason::charging, "no driving while charging"},
    ReasonText{Reason::push_mode, "no driving with the clutch in push (free-wheel) mode"},
    ReasonText{Reason::not_seated, "no phone driving while the chair is not fully seated"},
    ReasonText{Reason::joystick, "the joystick on the chair is in use"},
    ReasonText{Reason::not_static, "phone drive only while the chair is static"},
    ReasonText{Reason::another_driver, "another phone is driving"},
    ReasonText{
        Reason::not_allowed,
        "not allowed to drive yet: on the display, tap \"Allow to drive\" beside this phone's name (R-18)"},
    ReasonText{Reason::speed_level, "the chair could not be set to speed level 1, as a phone drives (D-14)"},
    ReasonText{Reason::ended, "has ended: lift the finger and press again"},
};

}  // namespace

std::span<const ReasonText> reasons() noexcept {
  return kReasons;
}

std::string_view reason_text(Reason r) noexcept {
  if (r == Reason::none) return "";
  for (const ReasonText& e : kReasons)
    if (e.reason == r) return e.text;
  return "refused";
}

Reason reason_of(std::string_view refusal) noexcept {
  if (refusal.empty()) return Reason::none;
  for (const ReasonText& e : kReasons)
    if (refusal.find(e.text) != std::string_view::npos) return e.reason;
  return Reason::other;
}

}  // namespace rtukit::rehand6600
