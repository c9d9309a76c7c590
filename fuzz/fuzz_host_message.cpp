// The Rehand 6600 host daemon's WebSocket/HTTP message parser
// (parse_host_message, programs/rehand_host) on arbitrary text, as a
// display, an unpaired phone and a paired phone.
// Properties: never crashes and never throws (an exception would end the
// daemon's web thread, and with it the HMI); a command it returns is one the
// role may send: a display never drives, pairs or sounds the phone horn, a
// phone never holds posture commands, changes settings or revokes, an
// unpaired phone gets nothing but "pair" (everything else is refused); each
// command's register is one of that command's and its value one the
// register accepts (hold: non-zero); a refusal is invalid_argument or
// refused, and the result document with its reason serialises as JSON.
//
// Input: the client (1 byte: 0 display, 1 unpaired phone, 2 paired phone), then the message.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "fuzz_support.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/programs/rehand_message.hpp"

namespace {

using namespace rtukit;
namespace rh = rehand6600;
using programs::HostCommand;
using Kind = HostCommand::Kind;

bool accepts(uint16_t address, uint16_t value) {
  const rh::Register* r = rh::find_register(address);
  return r && rh::table_of(*r) == rh::Table::command && rh::check_value(*r, value) == Errc::ok;
}

bool holdable(uint16_t address) {
  const rh::Register* r = rh::find_register(address);
  return r && r->role == profile::Role::hold &&
         ((address >= rh::reg::kStandSit && address <= rh::reg::kPlateTilt) ||
          address == rh::reg::kAntiPinch);
}

void check_display(const HostCommand& c) {
  switch (c.kind) {
    case Kind::hold:
      if (!holdable(c.address) || c.value == 0 || !accepts(c.address, c.value)) std::abort();
      break;
    case Kind::release:
      if (!holdable(c.address)) std::abort();
      break;
    case Kind::pulse:
      if (c.address != rh::reg::kLight) std::abort();
      break;
    case Kind::set:
      if ((c.address != rh::reg::kDriveMode && c.address != rh::reg::kSpeedLevel) ||
          !accepts(c.address, c.value))
        std::abort();
      break;
    case Kind::one_touch:
      if (c.value > 2) std::abort();
      break;
    case Kind::pair_start:
    case Kind::pair_cancel:
    case Kind::revoke:
      break;
    default:
      std::abort();  // a phone's command from the display
  }
}

void check_phone(const HostCommand& c, bool paired) {
  if (!paired && c.kind != Kind::pair) std::abort();  // only pairing before the code
  switch (c.kind) {
    case Kind::pair:
      break;
    case Kind::drive:
      if (c.address != 0 && (c.address < rh::reg::kPhoneForward || c.address > rh::reg::kPhoneRight))
        std::abort();
      break;
    case Kind::horn:
      if (c.address != rh::reg::kPhoneHorn || c.value > 1) std::abort();
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
    if (!display && !paired && m.op != "pair" && e.code() != Errc::refused) std::abort();
    if (!fuzz::valid_utf8(e.reason())) std::abort();
    result["error"] = std::string(e.reason());
  }
  result["ok"] = m.command.ok();
  (void)result.dump();  // what the daemon sends back
  return 0;
}
