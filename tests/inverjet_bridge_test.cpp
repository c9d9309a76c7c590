// The Inverjet MQTT bridge against a real Mosquitto broker, with Debian's
// mosquitto_sub / mosquitto_pub as the independent peers
// (tests/mqtt/inverjet_bridge_mqtt.py): state and availability, last will,
// every command and refusal, stale commands, Home Assistant discovery against
// its schema, a broker restart, a machine unplugged, the ACL, 20 machines.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "process.hpp"

namespace {

using namespace std::chrono_literals;

TEST(InverjetBridgeMqtt, AgainstMosquitto) {
  ASSERT_TRUE(std::filesystem::exists("/usr/sbin/mosquitto")) << "scripts/setup.sh installs mosquitto";
  const rtukit::test::RunResult r = rtukit::test::run(
      {"/usr/bin/python3", std::string(SCRIPTS_DIR) + "/inverjet_bridge_mqtt.py", RTUKIT_BIN}, 240000ms);
  std::cout << r.output;
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("\nPASS"), std::string::npos);
  EXPECT_EQ(r.output.find("FAIL "), std::string::npos);
}

}  // namespace
