// The simulated flash of any device: its persisted rows as JSON (a person
// can read it), with a CRC-16/Modbus over the canonical dump of the
// registers so a damaged file is noticed, not half-used.
#include "rtukit/devices/profile/state_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <nlohmann/json.hpp>
#include <vector>

#include "rtukit/core/crc.hpp"
#include "rtukit/io/atomic_file.hpp"

namespace rtukit::profile {
namespace {

constexpr const char* kFormat = "rtukit-state";
constexpr int kVersion = 1;
constexpr size_t kMaxFileSize = 1 << 20;  // a state file is a few KB; anything larger is not ours

using nlohmann::json;

json registers_json(const Profile& profile, const Image& image) {
  json regs = json::object();
  for (const Row& r : profile.rows) {
    if (!r.has(kPersisted)) continue;
    if (r.repeat == 1) {
      regs[std::string(r.key)] = image.get(r);
      continue;
    }
    json values = json::array();
    for (unsigned i = 0; i < r.repeat; ++i) values.push_back(image.get(r, i));
    regs[std::string(r.key)] = values;
  }
  return regs;
}

std::string checksum_text(const json& registers) {
  const std::string text = registers.dump();
  char crc[8];
  std::snprintf(crc, sizeof crc, "0x%04X",
                crc16({reinterpret_cast<const uint8_t*>(text.data()), text.size()}));
  return crc;
}

}  // namespace

std::string default_state_path(std::string_view device) {
  const std::string file = "/rtukit/" + std::string(device) + ".json";
  if (const char* xdg = std::getenv("XDG_STATE_HOME"); xdg && *xdg) return std::string(xdg) + file;
  const char* home = std::getenv("HOME");
  return std::string(home && *home ? home : ".") + "/.local/state" + file;
}

std::string state_to_text(const Profile& profile, const Image& image) {
  const json regs = registers_json(profile, image);
  const json file{{"format", kFormat},
                  {"version", kVersion},
                  {"device", std::string(profile.name)},
                  {"registers", regs},
                  {"checksum", checksum_text(regs)}};
  return file.dump(1) + "\n";
}

Status state_from_text(const Profile& profile, std::string_view text, Image& image) {
  const json file = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (file.is_discarded()) return Status(Errc::malformed, "not valid JSON (truncated?)");
  if (!file.is_object() || !file.contains("format") || file["format"] != kFormat)
    return Status(Errc::malformed, "not an rtukit state file");
  if (!file.contains("device") || file["device"] != std::string(profile.name))
    return Status(Errc::malformed, "the state file of another device, not the " + std::string(profile.name));
  if (!file.contains("version") || file["version"] != kVersion)
    return Status(Errc::malformed, "unknown version");
  if (!file.contains("registers") || !file["registers"].is_object() || !file.contains("checksum") ||
      !file["checksum"].is_string())
    return Status(Errc::malformed, "registers or checksum missing");
  const json& regs = file["registers"];
  if (file["checksum"].get<std::string>() != checksum_text(regs))
    return Status(Errc::bad_crc, "checksum does not match the registers");

  // Everything is checked into a copy first: all or nothing.
  std::vector<uint16_t> words(image.words().begin(), image.words().end());
  Image staged(image.map(), words);
  for (const Row& r : profile.rows) {
    if (!r.has(kPersisted)) continue;
    const std::string key(r.key);
    if (!regs.contains(key)) return Status(Errc::malformed, key + " missing");
    const json& v = regs[key];
    const auto take = [&](const json& item, unsigned index) -> Status {
      if (!item.is_number_integer()) return Status(Errc::malformed, key + " is not a whole number");
      const auto raw = item.get<int64_t>();
      if (!r.valid_range().contains(raw))
        return Status(Errc::illegal_data_value, key + " is out of its range");
      staged.set(r, raw, index);
      return {};
    };
    if (r.repeat == 1) {
      if (Status s = take(v, 0)) return s;
      continue;
    }
    if (!v.is_array() || v.size() != r.repeat)
      return Status(Errc::malformed, key + " should list " + std::to_string(r.repeat) + " values");
    for (unsigned i = 0; i < r.repeat; ++i) {
      if (Status s = take(v[i], i)) return s;
    }
  }
  std::copy(words.begin(), words.end(), image.words().begin());
  return {};
}

namespace {

// Whether a file that did not load is still ours (then saving may replace
// it) or something else that happens to sit at the path. Ours: the JSON of
// an rtukit state file of this device, or the first bytes of one (a file
// cut short by a failing disk) as state_to_text writes them, its keys in
// order: checksum, device, format, registers, version.
bool is_ours(const Profile& profile, std::string_view text) {
  const json file = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!file.is_discarded())
    return file.is_object() && file.contains("format") && file["format"] == kFormat &&
           file.contains("device") && file["device"] == std::string(profile.name);
  constexpr std::string_view head = "{\n \"checksum\": \"0x";
  // Cut short within those first bytes (empty, "{"): nothing to lose either.
  if (!text.starts_with(head)) return head.starts_with(text);
  const std::string device = "\n \"device\": \"" + std::string(profile.name) + "\"";
  const size_t at = text.find("\n \"device\": \"");
  // Cut before the device's name is complete: ours by its first bytes.
  if (at == std::string_view::npos || text.size() < at + device.size()) return true;
  return text.substr(at, device.size()) == device;
}

}  // namespace

LoadedState load_state(const std::string& path, const Profile& profile, Image& image) {
  LoadedState loaded;
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0 && errno == ENOENT) {
    loaded.warning = "no state file at " + path + "; starting with factory settings";
    return loaded;
  }
  Outcome<std::string> text = io::read_regular_file(path, kMaxFileSize);
  Status s = text.ok() ? state_from_text(profile, *text, image) : text.error();
  if (s.ok()) {
    loaded.from_file = true;
    return loaded;
  }
  if (!text.ok() || !is_ours(profile, *text)) {
    loaded.foreign = true;
    loaded.warning = "state file " + path + " is not a " + std::string(profile.name) + " state file (" +
                     std::string(s.reason()) + ")";
    return loaded;
  }
  loaded.warning =
      "state file " + path + " is damaged (" + std::string(s.reason()) + "); starting with factory settings";
  return loaded;
}

Status save_state(const std::string& path, const Profile& profile, const Image& image) {
  return io::write_file_atomically(path, state_to_text(profile, image));
}

}  // namespace rtukit::profile
