// The Bluetooth phone app (web/assets/rehand/app.html) reads the chair's
// state as bytes and names what they mean with two files the device layer
// decides: chair-text.js (the motion states, table 3's errors with their
// advice and the reasons' words, generated from the register table and
// reasons.hpp) and gatt.js (the UUIDs and
// function numbers of ble_gatt.hpp). These tests fail when either drifts
// from the device layer; RTUKIT_UPDATE_WEB_TEXT=1 rewrites chair-text.js.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "rtukit/devices/rehand6600/ble_gatt.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/views.hpp"

namespace {

namespace rh = rtukit::rehand6600;

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// What chair-text.js must hold, from the device layer.
std::string chair_text_js() {
  nlohmann::ordered_json motions = nlohmann::ordered_json::object();
  for (const auto& m : rh::find_register("motion")->names)
    motions[std::to_string(m.value)] = std::string(m.name);
  nlohmann::ordered_json errors = nlohmann::ordered_json::object();
  for (uint16_t code : rh::error_codes()) {
    const nlohmann::ordered_json e = rh::error_json(code);
    errors[e["code"].get<std::string>()] = e;
  }
  nlohmann::ordered_json reasons = nlohmann::ordered_json::object();
  for (const rh::ReasonText& r : rh::reasons())
    reasons[std::to_string(static_cast<int>(r.reason))] = std::string(r.text);
  return "// Generated from the device layer (the register table, table 3, reasons.hpp): do not edit.\n"
         "// tests/web_app_text_test.cpp fails when it drifts; RTUKIT_UPDATE_WEB_TEXT=1 with that\n"
         "// test rewrites it.\n"
         "export const MOTIONS = " +
         motions.dump(2) + ";\nexport const ERRORS = " + errors.dump(2) +
         ";\nexport const REASONS = " + reasons.dump(2) + ";\n";
}

TEST(WebAppText, ChairTextIsTheDeviceLayers) {
  const std::string path = std::string(WEB_ASSETS_DIR) + "/rehand/chair-text.js";
  const std::string want = chair_text_js();
  if (std::getenv("RTUKIT_UPDATE_WEB_TEXT")) std::ofstream(path) << want;
  EXPECT_EQ(read_file(path), want) << path << " drifted from the device layer: run this test with "
                                   << "RTUKIT_UPDATE_WEB_TEXT=1 to regenerate it";
}

TEST(WebAppText, GattJsSpeaksBleGattHpp) {
  const std::string js = read_file(std::string(WEB_ASSETS_DIR) + "/rehand/gatt.js");
  ASSERT_FALSE(js.empty());
  for (std::string_view uuid :
       {rh::ble::kServiceUuid, rh::ble::kStateUuid, rh::ble::kCommandUuid, rh::ble::kResultUuid})
    EXPECT_NE(js.find("'" + std::string(uuid) + "'"), std::string::npos) << uuid;
  // Each function as the register key the page sends and the number the chair reads.
  for (uint8_t n = 1; n <= 8; ++n) {
    const auto f = static_cast<rh::ble::Function>(n);
    const auto* r = rh::find_register(rh::ble::register_of(f));
    ASSERT_NE(r, nullptr);
    EXPECT_NE(js.find(std::string(r->key) + ": " + std::to_string(n)), std::string::npos)
        << r->key << " is function " << int(n);
  }
}

}  // namespace
