// The MQTT bridge's command rules, pure (mqtt_command_body): what gets
// through to the machine and what is refused, at the edges of the "ts"
// window. The whole path against Mosquitto is tests/mqtt/ (InverjetBridgeMqtt).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "rtukit/programs/inverjet_bridge.hpp"

namespace {

using rtukit::Errc;
using rtukit::programs::mqtt_command_body;
using Json = nlohmann::json;

constexpr double kNow = 1.8e9;

std::string stamped(double ts) {
  return Json{{"mode", "free"}, {"ts", ts}}.dump();
}

rtukit::Status check(const std::string& payload, bool retained = false) {
  Json body;
  return mqtt_command_body("start", payload, retained, kNow, 10, body);
}

TEST(InverjetCommand, OnlyAFreshJsonObjectGetsThrough) {
  Json body;
  EXPECT_FALSE(mqtt_command_body("start", stamped(kNow), false, kNow, 10, body));
  EXPECT_EQ(body["mode"], "free");
  // Each of these once started the machine, or was taken as a command.
  for (const char* bad :
       {"", "PRESS", "false", "true", "0", "null", "[]", "\"start\"", "{", "{\"mode\":\"free\"}",
        "{\"mode\":\"free\",\"ts\":\"1800000000\"}", "{\"mode\":\"free\",\"ts\":null}"}) {
    const rtukit::Status e = check(bad);
    ASSERT_TRUE(e) << bad;
    EXPECT_EQ(e.code(), Errc::refused) << bad;
    // The reason shows the form that works.
    EXPECT_NE(std::string(e.reason()).find("\"ts\""), std::string::npos) << bad << ": " << e.reason();
  }
}

TEST(InverjetCommand, TsWindowIsTenSecondsBackAndTwoAhead) {
  EXPECT_FALSE(check(stamped(kNow - 10)));
  EXPECT_TRUE(check(stamped(kNow - 10.5)));
  EXPECT_NE(std::string(check(stamped(kNow - 60)).reason()).find("stale"), std::string::npos);
  EXPECT_FALSE(check(stamped(kNow + 2)));
  EXPECT_TRUE(check(stamped(kNow + 2.5)));
  EXPECT_NE(std::string(check(stamped(4102444800)).reason()).find("future"), std::string::npos);  // year 2100
  // Milliseconds are read as such, with the same window.
  EXPECT_FALSE(check(stamped(kNow * 1000 - 5000)));
  EXPECT_TRUE(check(stamped(kNow * 1000 - 11000)));
  EXPECT_TRUE(check(stamped(kNow * 1000 + 3000)));
}

TEST(InverjetCommand, ARetainedCommandIsRefusedWhateverItSays) {
  const rtukit::Status e = check(stamped(kNow), /*retained=*/true);
  ASSERT_TRUE(e);
  EXPECT_NE(std::string(e.reason()).find("retained"), std::string::npos);
  EXPECT_TRUE(check("", /*retained=*/true));  // mosquitto_pub -r -n
}

TEST(InverjetCommand, EveryCommandHasADocumentedExample) {
  for (const char* name : {"start", "pause", "resume", "stop", "speed", "plan"}) {
    const std::string example = rtukit::inverjet::command_example(name);
    ASSERT_FALSE(example.empty()) << name;
    const Json j = Json::parse(example);
    EXPECT_TRUE(j.is_object() && j.contains("ts")) << name;
  }
  EXPECT_TRUE(rtukit::inverjet::command_example("fly").empty());
}

}  // namespace
