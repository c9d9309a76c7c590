// The Rehand 6600 host daemon end to end, in a real browser: Debian's
// Chromium headless, driven by Selenium (tests/browser/rehand_host_browser.py),
// against `rtukit rehand6600 host` and the simulated controller on a pty. The
// script starts and stops everything itself and saves the screenshots under
// the build tree (tests/artifacts/rehand-host/) to be looked at.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "process.hpp"

namespace {

using namespace std::chrono_literals;

TEST(RehandHostBrowser, HmiAndPhonePagesInChromium) {
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/chromium")) << "scripts/setup.sh installs chromium";
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/chromedriver"))
      << "scripts/setup.sh installs chromium-driver";
  const std::string out = std::string(ARTIFACTS_DIR) + "/rehand-host";
  const rtukit::test::RunResult r = rtukit::test::run(
      {"/usr/bin/python3", std::string(SCRIPTS_DIR) + "/rehand_host_browser.py", RTUKIT_BIN, out}, 240000ms);
  std::cout << r.output;
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("\nPASS"), std::string::npos);
  EXPECT_EQ(r.output.find("FAIL "), std::string::npos);
  for (const char* shot :
       {"hmi-1280x800.png", "hmi-1920x1080.png", "phone-remote-390x844.png", "hmi-error-overlay.png"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + shot)) << shot;
}

}  // namespace
