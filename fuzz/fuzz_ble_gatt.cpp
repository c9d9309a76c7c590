// The Rehand 6600's BLE service layouts (devices/rehand6600/ble_gatt.hpp)
// on arbitrary bytes, as a phone (or anything in radio range) may write
// them to the command characteristic.
// Properties: never crashes; a command parsed is well formed (a version-1
// command of 10 bytes, a hold function pressed, renewed or released with a
// press id, a pulse function pulsed with press id 0 and value 1) and encodes back to the same bytes; its
// function's register is one of the phone's (0x006E..0x0075); a result is at most 20 bytes and its reason is
// never cut inside a UTF-8 character (valid UTF-8 in, valid UTF-8 out); the reference client's parsers never
// crash either.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>

#include "fuzz_support.hpp"
#include "rtukit/devices/rehand6600/ble_gatt.hpp"

using namespace rtukit::rehand6600;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> in(data, size);
  const rtukit::Outcome<ble::Command> c = ble::parse_command(in);
  if (c.ok()) {
    const auto back = ble::encode_command(*c);
    if (size != ble::kCommandSize || !std::equal(back.begin(), back.end(), data)) std::abort();
    const uint16_t r = ble::register_of(c->function);
    if (r < reg::kPhoneForward || r > reg::kPhoneLight) std::abort();
    if (ble::is_hold(c->function) == (c->op == ble::Op::pulse)) std::abort();
    if (c->op == ble::Op::pulse ? c->press != 0 : c->press == 0) std::abort();
  } else if (c.error().code() != rtukit::Errc::invalid_argument) {
    std::abort();
  }
  const std::string reason(reinterpret_cast<const char*>(data), size);
  const std::vector<uint8_t> result =
      ble::encode_result({.sequence = 1, .code = ble::ResultCode::refused, .reason = reason});
  if (result.size() > ble::kMaxValue) std::abort();
  // Byte 4 names the reason's entry (reasons.hpp); the text follows, cut at a character.
  if (result[4] != static_cast<uint8_t>(rtukit::rehand6600::reason_of(reason))) std::abort();
  const std::string_view out(reinterpret_cast<const char*>(result.data()) + 5, result.size() - 5);
  if (rtukit::fuzz::valid_utf8(reason) && !rtukit::fuzz::valid_utf8(out)) std::abort();
  (void)ble::parse_result(in);
  (void)ble::parse_state(in);
  return 0;
}
