// The Rehand 6600's BLE service as bytes (devices/rehand6600/ble_gatt.hpp):
// the layouts docs/rehand6600-ble.md gives phone-app developers, byte by
// byte, and what a malformed write gets.
#include <gtest/gtest.h>

#include <vector>

#include "rtukit/devices/rehand6600/ble_gatt.hpp"

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

  // 20 bytes at most, cut at a character boundary ("é" is 2 bytes in UTF-8).
  const Result long_reason{.sequence = 0x0201,
                           .code = ResultCode::refused,
                           .reason = "no phone driving while the chair is not fully seated"};
  const std::vector<uint8_t> b = encode_result(long_reason);
  ASSERT_EQ(b.size(), kMaxValue);
  EXPECT_EQ(std::vector<uint8_t>(b.begin(), b.begin() + 4), bytes({1, 1, 2, 1}));
  EXPECT_EQ(parse_result(b)->reason, "no phone driving");
  const std::vector<uint8_t> accented = encode_result({.reason = "012345678901234é"});
  EXPECT_EQ(parse_result(accented)->reason, "012345678901234");
  EXPECT_EQ(parse_result(encode_result(long_reason, 200))->reason, long_reason.reason);
  EXPECT_FALSE(parse_result(bytes({1, 0, 0, 9})).ok());
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
  v.phone_driving = true;
  const auto b = encode_state(v);
  EXPECT_EQ(std::vector<uint8_t>(b.begin(), b.end()), bytes({1, 0b0110'1101, 87, 6, 2, 1, 0, 0, 0, 2, 0xC3,
                                                             0x10, 0b010, 0xDC, 0x05, 0x70, 0x11, 0x34}));
  const Outcome<State> back = parse_state(b);
  ASSERT_TRUE(back.ok());
  EXPECT_TRUE(back->link && back->clutch_drive && back->main_light && back->right_signal && back->driving);
  EXPECT_FALSE(back->charging || back->left_signal || back->emergency || back->all_disabled);
  EXPECT_TRUE(back->drive_disabled);
  EXPECT_EQ(back->battery, 87U);
  EXPECT_EQ(back->active_error, 0x10C3);
  EXPECT_EQ(back->distance_front_mm, 1500U);
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

}  // namespace
}  // namespace rtukit::rehand6600::ble
