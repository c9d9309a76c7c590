// The Rehand 6600's BLE service as bytes (devices/rehand6600/ble_gatt.hpp):
// the layouts docs/rehand6600-ble.md gives phone-app developers, byte by
// byte, and what a malformed write gets.
#include <gtest/gtest.h>

#include <vector>

#include "rtukit/devices/rehand6600/ble_gatt.hpp"
#include "rtukit/devices/rehand6600/ble_remote.hpp"

namespace rtukit::rehand6600::ble {
namespace {

std::vector<uint8_t> bytes(std::initializer_list<int> list) {
  std::vector<uint8_t> out;
  for (const int b : list) out.push_back(static_cast<uint8_t>(b));
  return out;
}

// The document's example: press 7 of forward, sequence 0x0102.
TEST(RehandBleGatt, ACommandAsTheDocumentWritesIt) {
  const auto press = bytes({1, 1, 1, 1, 7, 0, 0, 0, 0x02, 0x01});
  const Outcome<Command> c = parse_command(press);
  ASSERT_TRUE(c.ok()) << c.error().reason();
  EXPECT_EQ(c->op, Op::press);
  EXPECT_EQ(c->function, Function::forward);
  EXPECT_EQ(c->press, 7U);
  EXPECT_EQ(c->sequence, 0x0102);
  EXPECT_EQ(register_of(c->function), reg::kPhoneForward);
  const auto round = encode_command(*c);
  EXPECT_EQ(std::vector<uint8_t>(round.begin(), round.end()), press);
  // A large press id is little-endian on all four bytes.
  const Command big{.op = Op::renew, .function = Function::horn, .press = 0x0A0B0C0D, .sequence = 9};
  EXPECT_EQ(parse_command(encode_command(big))->press, 0x0A0B0C0DU);
  // Every function is one phone register of table 2.
  const uint16_t registers[] = {reg::kPhoneForward,     reg::kPhoneReverse, reg::kPhoneLeft,
                                reg::kPhoneRight,       reg::kPhoneHorn,    reg::kPhoneLeftSignal,
                                reg::kPhoneRightSignal, reg::kPhoneLight};
  for (uint8_t f = 1; f <= 8; ++f) EXPECT_EQ(register_of(static_cast<Function>(f)), registers[f - 1]);
}

TEST(RehandBleGatt, AMalformedCommandIsRefusedSayingWhy) {
  const std::pair<std::vector<uint8_t>, std::string> cases[] = {
      {bytes({1, 1, 1}), "a command is 10 bytes, not 3"},
      {bytes({2, 1, 1, 1, 7, 0, 0, 0, 0, 0}), "version 2: this chair speaks 1"},
      {bytes({1, 9, 1, 1, 7, 0, 0, 0, 0, 0}), "op 9: 1 press, 2 renew, 3 release, 4 pulse"},
      {bytes({1, 1, 0, 1, 7, 0, 0, 0, 0, 0}), "function 0: 1..8"},
      {bytes({1, 1, 1, 2, 7, 0, 0, 0, 0, 0}), "a hold's value is 1, not 2"},
      {bytes({1, 1, 1, 1, 0, 0, 0, 0, 0, 0}), "press id 0: a press id starts at 1"},
      {bytes({1, 4, 1, 1, 0, 0, 0, 0, 0, 0}), "a hold function is pressed, renewed and released, not pulsed"},
      {bytes({1, 1, 8, 1, 7, 0, 0, 0, 0, 0}), "a pulse function is op 4 (pulse)"},
      {bytes({1, 4, 8, 5, 0, 0, 0, 0, 0, 0}), "a pulse's value is 1, not 5"},
      {bytes({1, 4, 6, 1, 3, 0, 0, 0, 0, 0}), "a pulse has press id 0"},
  };
  for (const auto& [input, reason] : cases) {
    const Outcome<Command> c = parse_command(input);
    ASSERT_FALSE(c.ok()) << reason;
    EXPECT_EQ(c.error().code(), Errc::invalid_argument);
    EXPECT_EQ(c.error().reason(), reason);
  }
  EXPECT_TRUE(parse_command(bytes({1, 4, 8, 1, 0, 0, 0, 0, 0, 0})).ok());  // the light
  EXPECT_TRUE(parse_command(bytes({1, 3, 1, 0, 7, 0, 0, 0, 0, 0})).ok());  // a release's value is any
}

// The session's answer becomes the result: a renewal refused is "ended",
// so the app lifts the button instead of retrying.
TEST(RehandBleGatt, TheSessionsAnswerBecomesTheResult) {
  const Command renew{.op = Op::renew, .function = Function::forward, .press = 3, .sequence = 41};
  const Command press{.op = Op::press, .function = Function::forward, .press = 4, .sequence = 42};
  EXPECT_EQ(result_of(press, {}).code, ResultCode::accepted);
  EXPECT_TRUE(result_of(press, {}).reason.empty());
  const Result ended = result_of(renew, rtukit::Status(Errc::refused, "press 3 has ended"));
  EXPECT_EQ(ended.code, ResultCode::ended);
  EXPECT_EQ(ended.sequence, 41);
  EXPECT_EQ(result_of(press, rtukit::Status(Errc::refused, "no driving while charging")).code,
            ResultCode::refused);
  EXPECT_EQ(result_of(press, rtukit::Status(Errc::invalid_argument, "not new")).code, ResultCode::invalid);

  // 20 bytes at most, cut at a character boundary ("é" is 2 bytes in UTF-8);
  // the reason's code in byte 4 names it in full (reasons.hpp).
  const Result long_reason{.sequence = 0x0201,
                           .code = ResultCode::refused,
                           .reason = "no phone driving while the chair is not fully seated"};
  const std::vector<uint8_t> b = encode_result(long_reason);
  ASSERT_EQ(b.size(), kMaxValue);
  EXPECT_EQ(std::vector<uint8_t>(b.begin(), b.begin() + 5), bytes({2, 1, 2, 1, 8}));
  EXPECT_EQ(parse_result(b)->reason, "no phone drivin");
  EXPECT_EQ(parse_result(b)->why, rtukit::rehand6600::Reason::not_seated);
  const std::vector<uint8_t> accented = encode_result({.reason = "01234567890123é"});
  EXPECT_EQ(parse_result(accented)->reason, "01234567890123");
  EXPECT_EQ(parse_result(accented)->why, rtukit::rehand6600::Reason::other) << "no entry: its text says why";
  EXPECT_EQ(parse_result(encode_result(long_reason, 200))->reason, long_reason.reason);
  EXPECT_EQ(parse_result(encode_result({}))->why, rtukit::rehand6600::Reason::none);
  EXPECT_FALSE(parse_result(bytes({2, 0, 0, 9, 0})).ok());
  EXPECT_FALSE(parse_result(bytes({1, 0, 0, 1, 0})).ok()) << "version 1 results had no code";
  EXPECT_FALSE(parse_result(bytes({2, 0, 0, 1})).ok()) << "5 bytes at least";
}

// Every refusal a phone can get names its reason by number: the R-18
// sentence, cut to "not allowed to d" in the first layout, is code 12.
TEST(RehandBleGatt, EachReasonIsFoundFromTheRefusalsBuiltFromIt) {
  namespace rh = rtukit::rehand6600;
  for (const rh::ReasonText& r : rh::reasons()) {
    EXPECT_EQ(rh::reason_of(r.text), r.reason) << r.text;
    EXPECT_EQ(rh::reason_text(r.reason), r.text);
  }
  EXPECT_EQ(rh::reason_of("press 7 has ended: lift the finger and press again"), rh::Reason::ended);
  EXPECT_EQ(rh::reason_of("10C3 Seat lift Error is active; only releasing is possible"),
            rh::Reason::error_active);
  EXPECT_EQ(rh::reason_of("1010 Master Error: no communication with the controller"),
            rh::Reason::no_controller);
  EXPECT_EQ(rh::reason_of("no standing up or raising the seat while charging"), rh::Reason::raise_charging);
  EXPECT_EQ(rh::reason_of("something new"), rh::Reason::other);
  EXPECT_EQ(rh::reason_of(""), rh::Reason::none);
  const Result r18{.code = ResultCode::refused,
                   .reason = std::string(rh::reason_text(rh::Reason::not_allowed))};
  EXPECT_EQ(parse_result(encode_result(r18))->why, rh::Reason::not_allowed);
}

TEST(RehandBleGatt, TheStateByteByByte) {
  StateView v;
  Snapshot& s = v.snapshot;
  s.valid = true;
  s.sequence = 0x1234;
  s.regs[reg::kBattery] = 87;
  s.regs[reg::kCharging] = 0;
  s.regs[reg::kClutch] = 1;
  s.regs[reg::kSpeed] = 6;
  s.regs[reg::kMotion] = 2;
  s.regs[reg::kMainLight] = 1;
  s.regs[reg::kRightSignal] = 1;
  s.regs[reg::kStandStatus] = 1;
  s.regs[reg::kLegRestStatus] = 2;
  s.regs[reg::kDistanceFront] = 1500;
  s.regs[reg::kDistanceFront + 1] = 70000 & 0xFFFF;
  v.active_error = 0x10C3;
  v.disabled.drive = "the joystick on the chair is in use";
  v.disabled.drive_reason = rtukit::rehand6600::Reason::joystick;
  v.phone_driving = true;
  const auto b = encode_state(v);
  EXPECT_EQ(std::vector<uint8_t>(b.begin(), b.end()),
            bytes({1,    0b0110'1101, 87,    6,    2,    1,    0,    0,    0, 2,
                   0xC3, 0x10,        0b010, 0xDC, 0x05, 0x70, 0x11, 0x34, 0, 9}));
  const Outcome<State> back = parse_state(b);
  ASSERT_TRUE(back.ok());
  EXPECT_TRUE(back->link && back->clutch_drive && back->main_light && back->right_signal && back->driving);
  EXPECT_FALSE(back->charging || back->left_signal || back->emergency || back->all_disabled);
  EXPECT_TRUE(back->drive_disabled);
  EXPECT_EQ(back->battery, 87U);
  EXPECT_EQ(back->active_error, 0x10C3);
  EXPECT_EQ(back->distance_front_mm, 1500U);
  EXPECT_EQ(back->drive_reason, rtukit::rehand6600::Reason::joystick);
  // A state of the first layout (18 bytes) still reads, without reasons.
  const Outcome<State> first = parse_state(std::span<const uint8_t>(b.data(), 18));
  ASSERT_TRUE(first.ok());
  EXPECT_TRUE(first->drive_disabled);
  EXPECT_EQ(first->drive_reason, rtukit::rehand6600::Reason::none);
  // The link down (1010): bit 0 clear, everything disabled.
  v.active_error = kMasterCommunicationError;
  v.disabled.all = "1010: no communication";
  const auto down = encode_state(v);
  EXPECT_EQ(down[1] & 1, 0);
  EXPECT_EQ(down[12] & 1, 1);
  EXPECT_EQ(down[10], 0x10);
  EXPECT_FALSE(parse_state(bytes({1, 2, 3})).ok());
  EXPECT_LE(kStateSize, kMaxValue);
}

// ------------------------------------------------ the reference client's keys (virtual time)

using namespace std::chrono_literals;
using T = RemoteKeys::TimePoint;

// A held key: pressed at its first byte, renewed every 100 ms while the
// terminal repeats it, released when it stops repeating for key_gap.
TEST(RemoteKeys, AHeldKeyPressesRenewsWhileRepeated_ReleasesWhenLetGo) {
  RemoteKeys keys({.renew_every = 100ms, .key_gap = 400ms});
  T t{};
  auto out = keys.on_byte('w', t);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0].op, Op::press);
  EXPECT_EQ(out[0].function, Function::forward);
  const uint32_t press = out[0].press;
  EXPECT_NE(press, 0U);
  EXPECT_EQ(keys.wake_at(), t + 100ms);
  int renewals = 0;
  for (int ms = 10; ms <= 1000; ms += 10) {  // repeats every 30 ms, after a first delay of 300 ms
    const T now = t + std::chrono::milliseconds(ms);
    if (ms >= 300 && ms % 30 == 0) EXPECT_TRUE(keys.on_byte('w', now).empty());
    for (const Command& c : keys.due(now)) {
      EXPECT_EQ(c.op, Op::renew);
      EXPECT_EQ(c.press, press);
      ++renewals;
    }
  }
  EXPECT_EQ(renewals, 10);
  EXPECT_EQ(keys.held(), Function::forward);
  // The last repeat was at 990 ms: let go at 990 + 400.
  EXPECT_TRUE(keys.due(t + 1380ms).size() <= 1U);
  out = keys.due(t + 1390ms);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0].op, Op::release);
  EXPECT_EQ(out[0].press, press);
  EXPECT_FALSE(keys.held());
  EXPECT_FALSE(keys.wake_at());
}

// Sequences grow with every command; another key releases the first; arrows
// are escape sequences; space releases; x quits, releasing what is held.
TEST(RemoteKeys, AnotherKeyReleasesTheFirst_ArrowsSpaceAndQuit) {
  RemoteKeys keys({});
  T t{};
  auto a = keys.on_byte('w', t);
  EXPECT_TRUE(keys.on_byte(0x1B, t).empty());
  EXPECT_TRUE(keys.on_byte('[', t).empty());
  auto b = keys.on_byte('D', t);  // left arrow
  ASSERT_EQ(b.size(), 2U);
  EXPECT_EQ(b[0].op, Op::release);
  EXPECT_EQ(b[0].press, a[0].press);
  EXPECT_EQ(b[1].op, Op::press);
  EXPECT_EQ(b[1].function, Function::left);
  EXPECT_GT(b[1].press, a[0].press);
  EXPECT_EQ(b[0].sequence, a[0].sequence + 1);
  EXPECT_EQ(b[1].sequence, a[0].sequence + 2);
  auto stop = keys.on_byte(' ', t);
  ASSERT_EQ(stop.size(), 1U);
  EXPECT_EQ(stop[0].op, Op::release);
  EXPECT_TRUE(keys.on_byte('?', t).empty());
  keys.on_byte('h', t);
  auto quit = keys.on_byte('x', t);
  EXPECT_TRUE(keys.quit());
  ASSERT_EQ(quit.size(), 1U);
  EXPECT_EQ(quit[0].function, Function::horn);
  EXPECT_EQ(quit[0].op, Op::release);
}

// A pulse key fires once per press of the key, not once per repeat; its
// command has press id 0, as the service requires.
TEST(RemoteKeys, APulseKeyFiresOncePerPress) {
  RemoteKeys keys({.key_gap = 400ms});
  T t{};
  auto out = keys.on_byte('l', t);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0].op, Op::pulse);
  EXPECT_EQ(out[0].press, 0U);
  EXPECT_TRUE(parse_command(encode_command(out[0])).ok());
  for (int ms = 300; ms < 1000; ms += 30)
    EXPECT_TRUE(keys.on_byte('l', t + std::chrono::milliseconds(ms)).empty());
  EXPECT_EQ(keys.on_byte('l', t + 1500ms).size(), 1U);  // let go, pressed again
  EXPECT_EQ(keys.on_byte('e', t + 1500ms).size(), 1U);  // another pulse key at once
}

// A press the chair ended (a lapse, a refusal) is never pressed again by the
// same held key: no renewals, no new press until the key is let go.
TEST(RemoteKeys, APressTheChairEndedIsNotRenewedNorPressedAgainWhileTheKeyIsHeld) {
  RemoteKeys keys({.renew_every = 100ms, .key_gap = 400ms});
  T t{};
  const Command press = keys.on_byte('w', t)[0];
  keys.on_result({.sequence = static_cast<uint16_t>(press.sequence - 1), .code = ResultCode::refused});
  EXPECT_EQ(keys.held(), Function::forward) << "an older command's answer is not about this press";
  keys.on_result({.sequence = press.sequence, .code = ResultCode::refused, .reason = "charging"});
  EXPECT_FALSE(keys.held());
  for (int ms = 30; ms < 600; ms += 30) {
    EXPECT_TRUE(keys.on_byte('w', t + std::chrono::milliseconds(ms)).empty());
    EXPECT_TRUE(keys.due(t + std::chrono::milliseconds(ms)).empty());
  }
  EXPECT_TRUE(keys.due(t + 1100ms).empty());  // let go: nothing to release (it had ended)
  const auto again = keys.on_byte('w', t + 1200ms);
  ASSERT_EQ(again.size(), 1U);
  EXPECT_EQ(again[0].op, Op::press);
  EXPECT_GT(again[0].press, press.press);
}

TEST(RemoteKeys, TheStateAsOneLine) {
  State s;
  EXPECT_EQ(describe(s), "no controller (1010)  battery 0 %");
  s.link = true;
  s.battery = 80;
  s.motion = 1;
  s.main_light = true;
  s.driving = true;
  s.active_error = 0x10C3;
  const std::string line = describe(s);
  EXPECT_NE(line.find("battery 80 %"), std::string::npos) << line;
  EXPECT_NE(line.find("static"), std::string::npos) << line;
  EXPECT_NE(line.find("light on"), std::string::npos) << line;
  EXPECT_NE(line.find("a phone drives"), std::string::npos) << line;
  EXPECT_NE(line.find("10C3 Seat lift Error"), std::string::npos) << line;
}

}  // namespace
}  // namespace rtukit::rehand6600::ble
