// The Bluetooth phone app (web/assets/rehand/app.html) end to end in
// Chromium, the central, against the host daemon's GATT application, the
// peripheral, over the mock BlueZ (tests/ble/rehand_app_browser.py): a
// stranger refused, pairing with the display's passkey, a held button that
// drives, a release, a frozen page and a crashed tab stopped with 0x006A
// within the stop paths' bound, Forget on the display ending the access.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "process.hpp"

namespace {

using namespace std::chrono_literals;

TEST(RehandApp, ThePhoneAppOverWebBluetoothInChromium) {
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/chromium")) << "scripts/setup.sh installs chromium";
  const std::string out = std::string(ARTIFACTS_DIR) + "/rehand-app";
  const rtukit::test::RunResult r = rtukit::test::run(
      {"/usr/bin/python3", std::string(SCRIPTS_DIR) + "/rehand_app_browser.py", RTUKIT_BIN, out}, 280000ms);
  std::cout << r.output;
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("\nPASS"), std::string::npos);
  EXPECT_EQ(r.output.find("FAIL "), std::string::npos);
  for (const char* shot :
       {"app-connect-390x844.png", "app-rest-390x844.png", "app-driving-390x844.png", "app-lost-390x844.png"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + shot)) << shot;
}

}  // namespace
