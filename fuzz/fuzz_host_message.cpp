// The Rehand 6600 host daemon's WebSocket/HTTP message parser
// (parse_host_message, programs/rehand_host) on arbitrary text, as a
// display, an unauthenticated phone and an authenticated phone.
// Properties: never crashes and never throws (an exception would end the
// daemon's web thread, and with it the HMI); a command it returns is one the
// role may send: a display never drives, pairs, authenticates or sounds the
// phone horn, a phone never presses posture commands, changes settings,
// stops everyone or forgets phones, an unauthenticated phone gets nothing
// but "auth" and "pair" (everything else is refused), and an authenticated
// one never authenticates again; each press's register is one of that
// role's hold commands and its value a non-zero one the register accepts,
// with a press id; a refusal is invalid_argument or refused, and the result
// document with its reason serialises as JSON.
//
// Input: the client (1 byte: 0 display, 1 unauthenticated phone, 2 authenticated phone), then the message.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "fuzz_support.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/programs/rehand_message.hpp"
#include "rtukit/web/webcrypto.hpp"

namespace {

using namespace rtukit;
namespace rh = rehand6600;
using programs::HostCommand;
using Kind = HostCommand::Kind;

bool accepts(uint16_t address, uint16_t value) {
  const rh::Register* r = rh::find_register(address);
  return r && rh::table_of(*r) == rh::Table::command && rh::check_value(*r, value) == Errc::ok;
}

bool display_holdable(uint16_t address) {
  const rh::Register* r = rh::find_register(address);
  return r && r->role == profile::Role::hold &&
         ((address >= rh::reg::kStandSit && address <= rh::reg::kPlateTilt) ||
          address == rh::reg::kAntiPinch);
}

bool phone_holdable(uint16_t address) {
  return (address >= rh::reg::kPhoneForward && address <= rh::reg::kPhoneRight) ||
         address == rh::reg::kPhoneHorn;
}

void check_press(const HostCommand& c, bool (*holdable)(uint16_t)) {
  if (c.press == 0) std::abort();
  if (c.kind == Kind::press && (!holdable(c.address) || c.value == 0 || !accepts(c.address, c.value)))
    std::abort();
}

void check_display(const HostCommand& c) {
  switch (c.kind) {
    case Kind::press:
    case Kind::renew:
    case Kind::release:
      check_press(c, display_holdable);
      break;
    case Kind::pulse:
      if (c.address != rh::reg::kLight) std::abort();
      break;
    case Kind::set:
      if ((c.address != rh::reg::kDriveMode && c.address != rh::reg::kSpeedLevel) ||
          !accepts(c.address, c.value))
        std::abort();
      break;
    case Kind::forget:
      if (c.phone.empty()) std::abort();
      break;
    case Kind::stop:
    case Kind::pair_start:
    case Kind::pair_cancel:
    case Kind::forget_all:
      break;
    default:
      std::abort();  // a phone's command from the display
  }
}

void check_phone(const HostCommand& c, bool authenticated) {
  if (!authenticated && c.kind != Kind::pair && c.kind != Kind::auth) std::abort();
  if (authenticated && (c.kind == Kind::pair || c.kind == Kind::auth)) std::abort();
  switch (c.kind) {
    case Kind::pair:
      // The key is a point on P-256 (checked by OpenSSL), the signature r||s.
      if (c.public_key.size() != 65 || !web::valid_p256_key(c.public_key) || c.signature.size() != 64)
        std::abort();
      break;
    case Kind::auth:
      if (c.phone.empty() || c.signature.size() != 64) std::abort();
      break;
    case Kind::press:
    case Kind::renew:
    case Kind::release:
      check_press(c, phone_holdable);
      break;
    case Kind::pulse:
      if (c.address != rh::reg::kPhoneLight && c.address != rh::reg::kPhoneLeftSignal &&
          c.address != rh::reg::kPhoneRightSignal)
        std::abort();
      break;
    default:
      std::abort();  // a display's command from a phone
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool display = data[0] % 3 == 0;
  const bool paired = data[0] % 3 == 2;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  const programs::HostMessage m = programs::parse_host_message(
      text, display ? programs::HostRole::display : programs::HostRole::phone, paired);
  if (!m.envelope) return 0;
  nlohmann::json result{{"type", "result"}, {"op", m.op}};
  if (m.id) result["id"] = *m.id;
  if (m.command.ok()) {
    display ? check_display(*m.command) : check_phone(*m.command, paired);
  } else {
    const Status& e = m.command.error();
    if (e.code() != Errc::invalid_argument && e.code() != Errc::refused) std::abort();
    if (!display && !paired && m.op != "pair" && m.op != "auth" && e.code() != Errc::refused) std::abort();
    if (!fuzz::valid_utf8(e.reason())) std::abort();
    result["error"] = std::string(e.reason());
  }
  result["ok"] = m.command.ok();
  (void)result.dump();  // what the daemon sends back
  return 0;
}
