// The BLE service's byte layouts (ble_gatt.hpp). Why each choice:
//  - little-endian, versioned, at most 20 bytes: what every phone's BLE API
//    reads without a negotiated MTU;
//  - functions by number, not registers: a phone app never names a register
//    it may not write, and the table can move without the app changing;
//  - a renewal refused is "ended", its own code: the app then lifts the
//    button instead of retrying, as the session never restarts a press.
#include "rtukit/devices/rehand6600/ble_gatt.hpp"

#include <fmt/core.h>

#include <algorithm>

namespace rtukit::rehand6600::ble {
namespace {

rtukit::Status bad(std::string reason) {
  return rtukit::Status(Errc::invalid_argument, std::move(reason));
}

uint16_t u16_at(std::span<const uint8_t> b, size_t at) {
  return static_cast<uint16_t>(b[at] | (b[at + 1] << 8));
}

void put_u16(uint8_t* out, unsigned v) {
  const unsigned clamped = std::min(v, 0xFFFFu);
  out[0] = static_cast<uint8_t>(clamped & 0xFF);
  out[1] = static_cast<uint8_t>(clamped >> 8);
}

uint8_t u8_of(unsigned v) {
  return static_cast<uint8_t>(std::min(v, 0xFFu));
}

}  // namespace

uint16_t register_of(Function f) noexcept {
  switch (f) {
    case Function::forward:
      return reg::kPhoneForward;
    case Function::reverse:
      return reg::kPhoneReverse;
    case Function::left:
      return reg::kPhoneLeft;
    case Function::right:
      return reg::kPhoneRight;
    case Function::horn:
      return reg::kPhoneHorn;
    case Function::left_signal:
      return reg::kPhoneLeftSignal;
    case Function::right_signal:
      return reg::kPhoneRightSignal;
    case Function::light:
      return reg::kPhoneLight;
  }
  return 0;
}

bool is_hold(Function f) noexcept {
  return f >= Function::forward && f <= Function::horn;
}

Outcome<Command> parse_command(std::span<const uint8_t> b) {
  if (b.size() != kCommandSize)
    return bad(fmt::format("a command is {} bytes, not {}", kCommandSize, b.size()));
  if (b[0] != kVersion) return bad(fmt::format("version {}: this chair speaks {}", b[0], kVersion));
  if (b[1] < static_cast<uint8_t>(Op::press) || b[1] > static_cast<uint8_t>(Op::pulse))
    return bad(fmt::format("op {}: 1 press, 2 renew, 3 release, 4 pulse", b[1]));
  if (b[2] < static_cast<uint8_t>(Function::forward) || b[2] > static_cast<uint8_t>(Function::light))
    return bad(fmt::format("function {}: 1..8", b[2]));
  Command c{
      .op = static_cast<Op>(b[1]),
      .function = static_cast<Function>(b[2]),
      .value = b[3],
      .press = static_cast<uint32_t>(b[4] | (b[5] << 8) | (b[6] << 16)) | (static_cast<uint32_t>(b[7]) << 24),
      .sequence = u16_at(b, 8)};
  if (is_hold(c.function) == (c.op == Op::pulse))
    return bad(is_hold(c.function) ? "a hold function is pressed, renewed and released, not pulsed"
                                   : "a pulse function is op 4 (pulse)");
  if (c.op == Op::pulse) {
    if (c.press != 0) return bad("a pulse has press id 0");
    if (c.value != 1) return bad(fmt::format("a pulse's value is 1, not {}", c.value));
    return c;
  }
  if (c.press == 0) return bad("press id 0: a press id starts at 1");
  if (c.op == Op::press && c.value != 1) return bad(fmt::format("a hold's value is 1, not {}", c.value));
  return c;
}

std::array<uint8_t, kCommandSize> encode_command(const Command& c) {
  std::array<uint8_t, kCommandSize> b{};
  b[0] = kVersion;
  b[1] = static_cast<uint8_t>(c.op);
  b[2] = static_cast<uint8_t>(c.function);
  b[3] = c.value;
  for (int i = 0; i < 4; ++i) b[4 + i] = static_cast<uint8_t>((c.press >> (8 * i)) & 0xFF);
  put_u16(&b[8], c.sequence);
  return b;
}

std::vector<uint8_t> encode_result(const Result& r, size_t max_size) {
  size_t room = max_size > 5 ? max_size - 5 : 0;
  std::string_view text = r.reason;
  if (text.size() > room) {
    // Cut at a character boundary: never half a UTF-8 sequence.
    while (room > 0 && (static_cast<uint8_t>(text[room]) & 0xC0) == 0x80) --room;
    text = text.substr(0, room);
  }
  std::vector<uint8_t> b(5 + text.size());
  b[0] = kResultVersion;
  put_u16(&b[1], r.sequence);
  b[3] = static_cast<uint8_t>(r.code);
  b[4] = static_cast<uint8_t>(r.why != Reason::none ? r.why : reason_of(r.reason));
  for (size_t i = 0; i < text.size(); ++i) b[5 + i] = static_cast<uint8_t>(text[i]);
  return b;
}

Outcome<Result> parse_result(std::span<const uint8_t> b) {
  if (b.size() < 5) return bad(fmt::format("a result is at least 5 bytes, not {}", b.size()));
  if (b[0] != kResultVersion)
    return bad(fmt::format("result version {}: this client speaks {}", b[0], kResultVersion));
  if (b[3] > static_cast<uint8_t>(ResultCode::ended)) return bad(fmt::format("result code {}", b[3]));
  return Result{.sequence = u16_at(b, 1),
                .code = static_cast<ResultCode>(b[3]),
                .reason = std::string(b.begin() + 5, b.end()),
                .why = static_cast<Reason>(b[4])};
}

Result result_of(const Command& c, const rtukit::Status& answer) {
  Result r{.sequence = c.sequence, .code = ResultCode::accepted, .reason = std::string(answer.reason())};
  if (answer.ok())
    r.reason.clear();
  else if (answer.code() == Errc::invalid_argument)
    r.code = ResultCode::invalid;
  else
    r.code = c.op == Op::renew && answer.code() == Errc::refused ? ResultCode::ended : ResultCode::refused;
  return r;
}

std::array<uint8_t, kStateSize> encode_state(const StateView& v) {
  const Snapshot& s = v.snapshot;
  std::array<uint8_t, kStateSize> b{};
  b[0] = kVersion;
  const bool flags[] = {v.active_error != kMasterCommunicationError && s.valid,
                        s.charging(),
                        s.clutch_drive(),
                        s[reg::kMainLight] != 0,
                        s[reg::kLeftSignal] != 0,
                        s[reg::kRightSignal] != 0,
                        v.phone_driving,
                        v.emergency};
  for (unsigned i = 0; i < 8; ++i) b[1] |= static_cast<uint8_t>(flags[i] ? 1u << i : 0u);
  b[2] = u8_of(s.battery());
  b[3] = u8_of(s.speed_kmh());
  b[4] = u8_of(s.motion());
  const uint16_t postures[] = {reg::kStandStatus, reg::kSeatLiftStatus, reg::kBackrestStatus,
                               reg::kSeatTiltStatus, reg::kLegRestStatus};
  for (unsigned i = 0; i < 5; ++i) b[5 + i] = u8_of(s[postures[i]]);
  put_u16(&b[10], v.active_error);
  b[12] = static_cast<uint8_t>((v.disabled.all.empty() ? 0 : 1) | (v.disabled.drive.empty() ? 0 : 2) |
                               (v.disabled.raise.empty() ? 0 : 4));
  put_u16(&b[13], s[reg::kDistanceFront]);
  put_u16(&b[15], s[reg::kDistanceRear]);
  b[17] = static_cast<uint8_t>(s.sequence & 0xFF);
  b[18] = static_cast<uint8_t>(v.disabled.all_reason);
  b[19] = static_cast<uint8_t>(v.disabled.drive_reason);
  return b;
}

Outcome<State> parse_state(std::span<const uint8_t> b) {
  constexpr size_t kFirstSize = 18;  // the first layout, without the reasons
  if (b.size() < kFirstSize) return bad(fmt::format("a state is {} bytes, not {}", kStateSize, b.size()));
  if (b[0] != kVersion) return bad(fmt::format("version {}: this client speaks {}", b[0], kVersion));
  const auto bit = [&](size_t at, unsigned n) { return (b[at] >> n & 1) != 0; };
  State s{.link = bit(1, 0),
          .charging = bit(1, 1),
          .clutch_drive = bit(1, 2),
          .main_light = bit(1, 3),
          .left_signal = bit(1, 4),
          .right_signal = bit(1, 5),
          .driving = bit(1, 6),
          .emergency = bit(1, 7),
          .battery = b[2],
          .speed_kmh = b[3],
          .motion = b[4],
          .postures = {b[5], b[6], b[7], b[8], b[9]},
          .active_error = u16_at(b, 10),
          .all_disabled = bit(12, 0),
          .drive_disabled = bit(12, 1),
          .raise_disabled = bit(12, 2),
          .distance_front_mm = u16_at(b, 13),
          .distance_rear_mm = u16_at(b, 15),
          .counter = b[17]};
  if (b.size() >= kStateSize) {
    s.all_reason = static_cast<Reason>(b[18]);
    s.drive_reason = static_cast<Reason>(b[19]);
  }
  return s;
}

}  // namespace rtukit::rehand6600::ble
