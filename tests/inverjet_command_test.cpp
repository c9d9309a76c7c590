// The MQTT bridge's command rules, pure (mqtt_command_body): what gets
// through to the machine and what is refused, at the edges of the "ts"
// window. And the warnings the bridge prints at start about its broker
// (Bridge::warnings(), a function of the options until start() met a broker).
// The whole path against Mosquitto is tests/mqtt/ (InverjetBridgeMqtt).
#include <gtest/gtest.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/driver/memory_link.hpp"
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

// The warnings of a bridge that was never started: no broker, no bus (a
// link in memory that never answers), nothing connects.
std::vector<std::string> warnings(const std::string& host, const std::string& user,
                                  const std::string& tls_ca) {
  rtukit::programs::BridgeOptions o;
  o.machines = {{.unit = 21, .id = "pool1"}};
  o.host = host;
  o.user = user;
  o.tls_ca = tls_ca;
  rtukit::programs::Bridge bridge(
      std::make_unique<rtukit::MemoryLink>(rtukit::SteadyClock::instance(),
                                           [](auto) { return rtukit::MemoryLink::Reply{}; }),
      o);
  return bridge.warnings();
}

bool says(const std::vector<std::string>& lines, const std::string& what) {
  for (const std::string& l : lines)
    if (l.find(what) != std::string::npos) return true;
  return false;
}

TEST(InverjetBridgeWarnings, NoUserIsANoCredentialsWarning) {
  const auto w = warnings("127.0.0.1", "", "");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_TRUE(says(w, "no broker credentials (--user)")) << w[0];
  EXPECT_TRUE(says(w, "127.0.0.1")) << w[0];
  EXPECT_TRUE(warnings("127.0.0.1", "pool1", "").empty());
}

TEST(InverjetBridgeWarnings, PlainMqttToAnotherMachineIsWarnedAbout) {
  for (const char* host : {"192.168.10.2", "broker.pool.lan", "10.0.0.1", "::2"}) {
    const auto w = warnings(host, "pool1", "");
    ASSERT_EQ(w.size(), 1u) << host;
    EXPECT_TRUE(says(w, std::string("plain MQTT to ") + host)) << w[0];
    EXPECT_TRUE(says(w, "--tls-ca")) << w[0];
  }
  // Both at once: no credentials, in the clear.
  const auto w = warnings("192.168.10.2", "", "");
  EXPECT_EQ(w.size(), 2u);
  EXPECT_TRUE(says(w, "no broker credentials") && says(w, "plain MQTT"));
}

TEST(InverjetBridgeWarnings, LoopbackIsNotPlaintextOnTheNetwork) {
  for (const char* host : {"127.0.0.1", "127.0.1.1", "localhost", "::1", "[::1]"})
    EXPECT_FALSE(says(warnings(host, "pool1", ""), "plain MQTT")) << host;
}

TEST(InverjetBridgeWarnings, TlsToAnotherMachineIsNotWarnedAbout) {
  EXPECT_TRUE(warnings("broker.pool.lan", "pool1", "/etc/rtukit/ca.crt").empty());
  // The CA file is not read before start(): only that one is given counts here.
  const auto w = warnings("192.168.10.2", "", "/etc/rtukit/ca.crt");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_FALSE(says(w, "plain MQTT"));
  EXPECT_TRUE(says(w, "no broker credentials"));
}

}  // namespace
