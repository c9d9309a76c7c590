// The Rehand 6600 host daemon's Bluetooth LE link against a mock BlueZ on a
// private system bus (tests/ble/rehand_ble_scenarios.py, with the fixture
// tests/ble/bluez_mock.py): registration (BlueZ calls back before
// RegisterApplication returns), an unbonded device refused, pairing only in
// the display's window with the passkey on the display, a press held by
// renewals, a lapse that stops, a late renewal that never restarts, a lost
// phone stopped with the emergency rate, forgetting that removes the bond.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "process.hpp"

namespace {

using namespace std::chrono_literals;

TEST(RehandBle, ThePhoneOverBluetoothKeepsTheSessionsRules) {
  const std::string out = std::string(ARTIFACTS_DIR) + "/rehand-ble";
  const rtukit::test::RunResult r = rtukit::test::run(
      {"/usr/bin/python3", std::string(SCRIPTS_DIR) + "/rehand_ble_scenarios.py", RTUKIT_BIN, out}, 280000ms);
  std::cout << r.output;
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("\nPASS"), std::string::npos);
  EXPECT_EQ(r.output.find("FAIL "), std::string::npos);
  for (const char* shot : {"hmi-ble-passkey-1280x800.png", "hmi-ble-passkey-1024x600.png"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + shot)) << shot;
}

}  // namespace
