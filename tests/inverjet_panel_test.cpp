// The Inverjet pool panel in Debian's Chromium (tests/browser/inverjet_panel_browser.py):
// a timer run started from the page runs on the simulator, live charts, a
// plan edited and saved then read back with the CLI, an invalid plan refused
// with the reason (on the page and by the server), a fault with advice,
// screenshots and a layout check at phone and tablet sizes.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "process.hpp"

namespace {

using namespace std::chrono_literals;

TEST(InverjetPanelBrowser, PanelInChromium) {
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/chromium")) << "scripts/setup.sh installs chromium";
  const std::string out = std::string(ARTIFACTS_DIR) + "/inverjet-panel";
  const rtukit::test::RunResult r = rtukit::test::run(
      {"/usr/bin/python3", std::string(SCRIPTS_DIR) + "/inverjet_panel_browser.py", RTUKIT_BIN, out},
      240000ms);
  std::cout << r.output;
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("\nPASS"), std::string::npos);
  EXPECT_EQ(r.output.find("FAIL "), std::string::npos);
  for (const char* shot : {"panel-phone-390x844.png", "panel-tablet-1024x768.png", "panel-fault.png"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + shot)) << shot;
}

}  // namespace
