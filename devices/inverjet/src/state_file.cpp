// The simulated flash. JSON so a person can read it; a CRC-16/Modbus over the
// canonical dump of the settings so a damaged file is noticed, not half-used.
#include "rtukit/devices/inverjet/state_file.hpp"

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "rtukit/core/crc.hpp"
#include "rtukit/io/atomic_file.hpp"

namespace rtukit::inverjet {
namespace {

constexpr const char* kFormat = "rtukit-inverjet-state";
constexpr int kVersion = 1;

using nlohmann::json;

json settings_json(const Settings& s) {
  json plans = json::array();
  for (const Plan& p : s.plans) {
    json segments = json::array();
    for (const Segment& seg : p) segments.push_back({seg.speed, seg.end});
    plans.push_back(segments);
  }
  return json{{"address", s.address},           {"baud_code", s.baud_code},
              {"control_mask", s.control_mask}, {"free_speed", s.free_speed},
              {"free_time", s.free_time},       {"timer_speed", s.timer_speed},
              {"timer_time", s.timer_time},     {"plans", plans}};
}

uint16_t checksum(const json& settings) {
  const std::string text = settings.dump();
  return crc16({reinterpret_cast<const uint8_t*>(text.data()), text.size()});
}

}  // namespace

std::string default_state_path() {
  if (const char* xdg = std::getenv("XDG_STATE_HOME"); xdg && *xdg)
    return std::string(xdg) + "/rtukit/inverjet.json";
  const char* home = std::getenv("HOME");
  return std::string(home && *home ? home : ".") + "/.local/state/rtukit/inverjet.json";
}

std::string settings_to_text(const Settings& settings) {
  const json s = settings_json(settings);
  char crc[8];
  std::snprintf(crc, sizeof crc, "0x%04X", checksum(s));
  const json file{{"format", kFormat}, {"version", kVersion}, {"settings", s}, {"checksum", crc}};
  return file.dump(1) + "\n";
}

Result<Settings> settings_from_text(const std::string& text, std::string* why) {
  const auto bad = [why](Errc code, const std::string& reason) {
    if (why) *why = reason;
    return Result<Settings>(code);
  };
  const json file = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (file.is_discarded()) return bad(Errc::malformed, "not valid JSON (truncated?)");
  if (!file.is_object() || file.value("format", "") != kFormat)
    return bad(Errc::malformed, "not an rtukit Inverjet state file");
  if (file.value("version", 0) != kVersion) return bad(Errc::malformed, "unknown version");
  if (!file.contains("settings") || !file.contains("checksum") || !file["checksum"].is_string())
    return bad(Errc::malformed, "settings or checksum missing");
  const json& s = file["settings"];
  char crc[8];
  std::snprintf(crc, sizeof crc, "0x%04X", checksum(s));
  if (file["checksum"].get<std::string>() != crc)
    return bad(Errc::bad_crc, "checksum does not match the settings");
  Settings out;
  try {
    out.address = s.at("address").get<uint16_t>();
    out.baud_code = s.at("baud_code").get<uint16_t>();
    out.control_mask = s.at("control_mask").get<uint16_t>();
    out.free_speed = s.at("free_speed").get<uint16_t>();
    out.free_time = s.at("free_time").get<uint16_t>();
    out.timer_speed = s.at("timer_speed").get<uint16_t>();
    out.timer_time = s.at("timer_time").get<uint16_t>();
    const json& plans = s.at("plans");
    if (plans.size() != kPlanCount) return bad(Errc::malformed, "expected 4 plans");
    for (unsigned p = 0; p < kPlanCount; ++p) {
      if (plans[p].size() != kSegmentsPerPlan) return bad(Errc::malformed, "expected 50 segments per plan");
      for (unsigned k = 0; k < kSegmentsPerPlan; ++k)
        out.plans[p][k] = Segment{plans[p][k].at(0).get<uint16_t>(), plans[p][k].at(1).get<uint16_t>()};
    }
  } catch (const json::exception& e) {
    return bad(Errc::malformed, std::string("bad field: ") + e.what());
  }
  if (!out.valid()) return bad(Errc::invalid_argument, "a value is out of its register's range");
  return out;
}

LoadedSettings load_settings(const std::string& path) {
  LoadedSettings loaded;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    loaded.warning = "no state file at " + path + "; starting with factory settings";
    return loaded;
  }
  std::stringstream text;
  text << in.rdbuf();
  std::string why;
  Result<Settings> s = settings_from_text(text.str(), &why);
  if (!s.ok()) {
    loaded.warning = "state file " + path + " is damaged (" + why + "); starting with factory settings";
    return loaded;
  }
  loaded.settings = *s;
  loaded.from_file = true;
  return loaded;
}

Error save_settings(const std::string& path, const Settings& settings, std::string* why) {
  return io::write_file_atomically(path, settings_to_text(settings), why);
}

}  // namespace rtukit::inverjet
