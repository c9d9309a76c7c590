// The host daemon's message parser (rehand_message.hpp) against the Session's
// rule of which command a kind of client may press or send (session.hpp):
// the parser asks that rule and restates none of it, so for every command
// row and both page roles the parser accepts a press, a pulse or a setting
// exactly when the Session's may_press / may_send allows it.
#include "rtukit/programs/rehand_message.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/session.hpp"

namespace rtukit::programs {
namespace {

namespace rh = rehand6600;
using Json = nlohmann::json;

bool accepted(const Json& message, HostRole role) {
  const HostMessage m = parse_host_message(message.dump(), role, /*authenticated=*/true);
  return m.envelope && static_cast<bool>(m.command);
}

rh::ClientKind kind_of(HostRole role) {
  return role == HostRole::display ? rh::ClientKind::display : rh::ClientKind::phone;
}

std::set<std::string> keys(bool (*pick)(const rh::Register&)) {
  std::set<std::string> out;
  for (const rh::Register& r : rh::registers())
    if (rh::table_of(r) == rh::Table::command && pick(r)) out.insert(std::string(r.key));
  return out;
}

TEST(RehandMessage, PressPulseAndSetFollowTheSessionsRule) {
  for (const HostRole role : {HostRole::display, HostRole::phone}) {
    const rh::ClientKind kind = kind_of(role);
    for (const rh::Register& r : rh::registers()) {
      if (rh::table_of(r) != rh::Table::command) continue;
      const std::string key(r.key);
      const Json press{{"op", "press"}, {"command", key}, {"value", 1}, {"press", 1}};
      EXPECT_EQ(accepted(press, role), rh::may_press(kind, r.address)) << key;
      const Json pulse{{"op", "pulse"}, {"command", key}};
      EXPECT_EQ(accepted(pulse, role), r.role == rh::Role::pulse && rh::may_send(kind, r.address)) << key;
      const Json set{{"op", "set"}, {"key", key}, {"value", 1}};
      EXPECT_EQ(accepted(set, role),
                role == HostRole::display && r.role == rh::Role::setting && rh::may_send(kind, r.address))
          << key;
    }
  }
}

// The rule itself, as the daemon applied it before it asked the Session
// (docs/rehand6600-remote.md): unchanged.
TEST(RehandMessage, EachRoleMayNameTheCommandsItAlwaysCould) {
  using rh::ClientKind;
  EXPECT_EQ(keys([](const rh::Register& r) { return rh::may_press(ClientKind::display, r.address); }),
            (std::set<std::string>{"stand", "seat_lift", "backrest", "seat_tilt", "leg_rotate", "leg_extend",
                                   "plate_tilt", "anti_pinch"}));
  EXPECT_EQ(
      keys([](const rh::Register& r) { return rh::may_press(ClientKind::phone, r.address); }),
      (std::set<std::string>{"phone_forward", "phone_reverse", "phone_left", "phone_right", "phone_horn"}));
  EXPECT_EQ(keys([](const rh::Register& r) { return rh::may_send(ClientKind::display, r.address); }),
            (std::set<std::string>{"light", "drive_mode", "speed_level"}));
  EXPECT_EQ(keys([](const rh::Register& r) { return rh::may_send(ClientKind::phone, r.address); }),
            (std::set<std::string>{"phone_light", "phone_left_signal", "phone_right_signal"}));
  EXPECT_TRUE(rh::may_press(ClientKind::tool, rh::reg::kStandSit) &&
              rh::may_press(ClientKind::tool, rh::reg::kPhoneHorn));
  EXPECT_TRUE(rh::may_send(ClientKind::tool, rh::reg::kLight) &&
              rh::may_send(ClientKind::tool, rh::reg::kPhoneLight));
}

}  // namespace
}  // namespace rtukit::programs

namespace rtukit::programs {
namespace {

// A name is chosen by the phone (or by anyone in radio range, for a Bluetooth
// Alias): it must not forge a log line, reorder the display's text, or run on.
TEST(PhoneName, ControlAndBidiCharactersNeverReachTheLogOrTheDisplay) {
  EXPECT_EQ(phone_name("Anna's phone"), "Anna's phone");
  EXPECT_EQ(phone_name("Zoë  \t  Pixel"), "Zoë Pixel");  // one space
  EXPECT_EQ(phone_name("x\n2026-11-28 rehand6600 host: STOP lifted"),
            "x2026-11-28 rehand6600 host: STOP lifted");
  EXPECT_EQ(phone_name("\x1b[31mred\x1b[0m"), "[31mred[0m");    // no escape sequence
  EXPECT_EQ(phone_name("evil\u202Eenohp"), "evilenohp");        // right-to-left override
  EXPECT_EQ(phone_name("\u2066a\u2069\u200Fb\u061Cc"), "abc");  // isolates, marks
  EXPECT_EQ(phone_name("a\u200Bb\uFEFFc\u2028d"), "abcd");      // invisible, separators
  EXPECT_EQ(phone_name("a\xC2\x85"
                       "b"),
            "ab");                                                     // C1 (NEL)
  EXPECT_EQ(phone_name("bad \xFF\xC3 utf"), "bad \uFFFD\uFFFD utf");   // invalid bytes
  EXPECT_EQ(phone_name("\xC0\xAF"), "\uFFFD\uFFFD");                   // overlong '/'
  EXPECT_EQ(phone_name("\xED\xA0\x80"), "\uFFFD\uFFFD\uFFFD");         // a surrogate
  EXPECT_EQ(phone_name("😀 phone"), "😀 phone");                         // 4-byte characters stay
  EXPECT_EQ(phone_name(std::string(100, 'a')), std::string(40, 'a'));  // 40 characters
  EXPECT_EQ(phone_name(std::string(60, 'e') + "\u00e9"), std::string(40, 'e'));
  EXPECT_EQ(phone_name(""), "Phone");
  EXPECT_EQ(phone_name("\n\t \u202E"), "Phone");
  EXPECT_EQ(phone_name("", "AA:BB:CC:DD:EE:01"), "AA:BB:CC:DD:EE:01");
}

// A phone's key and its signature (WebCrypto's encodings, base64url): a
// point on P-256 and 64 bytes (the golden vector of webcrypto_test.cpp).
constexpr std::string_view kKey =
    "BL18c7iLLptM7aYgIrLai-Exk6W1btwm5994QuJM0LXrBgWtp72oOsaiuA1-MUBA-kf_Frg7rIXO2wFEUbt85xo";
constexpr std::string_view kSignature =
    "RxjGd4LyoUHKewPPVdZeP-gT2Jlk7e8uvxvXT2p1bvybwiluOMsx5HFEjAorsv6z1WYNiFe1iJDFQiAfBOWf1w";

std::string pair_message(std::string_view name, std::string_view key = kKey,
                         std::string_view signature = kSignature) {
  return std::string(R"({"op":"pair","code":"123456","name":")") + std::string(name) + R"(","key":")" +
         std::string(key) + R"(","signature":")" + std::string(signature) + R"("})";
}

TEST(PhoneName, APairMessagesNameIsCleaned) {
  const HostMessage m = parse_host_message(pair_message("a\\u202Eb\\nc"), HostRole::phone, false);
  ASSERT_TRUE(m.command) << m.command.error().reason();
  EXPECT_EQ(m.command->name, "abc");
  EXPECT_EQ(m.command->public_key.size(), 65U) << "the key decoded";
  EXPECT_EQ(m.command->signature.size(), 64U);
}

// A pairing or an authentication without what proves the key is refused
// before the daemon looks at it, each with what was expected.
TEST(PhoneKeyMessages, AKeyThatIsNoPointOrASignatureOfTheWrongSizeIsRefused) {
  const auto refused = [](const std::string& text, std::string_view why) {
    const HostMessage m = parse_host_message(text, HostRole::phone, false);
    ASSERT_FALSE(m.command) << text;
    EXPECT_EQ(m.command.error().code(), Errc::invalid_argument) << text;
    EXPECT_NE(m.command.error().reason().find(why), std::string_view::npos) << m.command.error().reason();
  };
  refused(R"({"op":"pair","code":"123456","name":"x"})", "signature");  // a page of before: no key
  refused(pair_message("x", "BAAA"), "public key");
  std::string off_curve(kKey);
  off_curve.back() = off_curve.back() == 'o' ? 'p' : 'o';
  refused(pair_message("x", off_curve), "public key");
  refused(pair_message("x", kKey, kSignature.substr(0, 40)), "signature");
  refused(pair_message("x", kKey, "not base64url!"), "signature");
  refused(R"({"op":"auth","token":"00112233445566778899aabbccddeeff"})", "signature");
  refused(std::string(R"({"op":"auth","signature":")") + std::string(kSignature) + R"("})", "phone");
  const HostMessage ok = parse_host_message(
      std::string(R"({"op":"auth","phone":"0123456789ab","signature":")") + std::string(kSignature) + R"("})",
      HostRole::phone, false);
  ASSERT_TRUE(ok.command) << ok.command.error().reason();
  EXPECT_EQ(ok.command->phone, "0123456789ab");
}

}  // namespace
}  // namespace rtukit::programs
