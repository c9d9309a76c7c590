// The simulated flash. JSON so a person can read it; a CRC-16/Modbus over the
// canonical dump of the settings so a damaged file is noticed, not half-used.
#include "rtukit/devices/inverjet/state_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "rtukit/core/crc.hpp"

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

// mkdir -p for the directory part of `path`.
void make_parents(const std::string& path) {
  for (size_t at = path.find('/', 1); at != std::string::npos; at = path.find('/', at + 1))
    ::mkdir(path.substr(0, at).c_str(), 0755);
}

Error fail(std::string* why, const std::string& what, int err) {
  if (why) *why = what + ": " + std::strerror(err);
  return Error(Errc::io_error, err);
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
  make_parents(path);
  const std::string text = settings_to_text(settings);
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return fail(why, "cannot create " + tmp, errno);
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      return fail(why, "cannot write " + tmp, err);
    }
    done += static_cast<size_t>(n);
  }
  // The data must be on disk before the rename makes it the file.
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    return fail(why, "cannot flush " + tmp, err);
  }
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return fail(why, "cannot replace " + path, err);
  }
  // And the rename itself must survive a power cut.
  const size_t slash = path.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return {};
}

}  // namespace rtukit::inverjet
