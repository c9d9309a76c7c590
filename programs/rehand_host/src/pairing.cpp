// The pairing store. A Wi-Fi phone is its public key: the private key was
// made non-extractable in the phone's browser at pairing, so neither the
// file, nor a look over a shoulder at it, nor a page that reads the phone's
// storage, holds anything that drives. The file is 0600 and replaced
// atomically, so a power cut leaves the old or the new list of phones.
#include <fmt/chrono.h>
#include <fmt/core.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <nlohmann/json.hpp>

#include "rtukit/io/atomic_file.hpp"
#include "rtukit/programs/rehand_host.hpp"
#include "rtukit/web/tls.hpp"
#include "rtukit/web/webcrypto.hpp"

namespace rtukit::programs {

namespace {

constexpr size_t kMaxFile = 256 * 1024;
constexpr size_t kMaxBluetooth = 256;
constexpr int64_t kBluetoothContactStep = 60;  // s: a Bluetooth contact is recorded at most once a minute
constexpr std::string_view kFormat = "rtukit rehand6600 pairing 3";
// Earlier formats: Wi-Fi phones held a token (1: in the clear, 2: hashed).
constexpr std::string_view kFormatV1 = "rtukit rehand6600 pairing 1";
constexpr std::string_view kFormatV2 = "rtukit rehand6600 pairing 2";

std::string random_hex(size_t bytes) {
  std::array<unsigned char, 64> b{};
  if (bytes > b.size() || !web::random_bytes(b.data(), bytes)) return {};
  std::string out;
  for (size_t i = 0; i < bytes; ++i) out += fmt::format("{:02x}", b[i]);
  return out;
}

bool is_bluetooth_id(std::string_view id) {
  return id.starts_with("ble:") && id.size() <= 64;
}

}  // namespace

std::string default_pairing_file(const char* state_directory, const char* home) {
  // A service under systemd gets its own directory, kept across upgrades;
  // a user's run keeps the phones in the XDG state directory.
  constexpr std::string_view kName = "rehand6600-pairing.json";
  if (state_directory) return fmt::format("{}/{}", state_directory, kName);
  if (home) return fmt::format("{}/.local/state/rtukit/{}", home, kName);
  return std::string(kName);
}

rtukit::Status PairingStore::load(int64_t now) {
  phones_.clear();
  bluetooth_.clear();
  legacy_dropped_.clear();
  writable_ = true;
  if (::access(path_.c_str(), F_OK) != 0) return {};  // no phone paired yet
  Outcome<std::string> text = io::read_regular_file(path_, kMaxFile);
  if (!text) {
    writable_ = false;
    return text.error();
  }
  const nlohmann::json doc = nlohmann::json::parse(*text, nullptr, false);
  const std::string format = doc.is_object() ? doc.value("format", "") : "";
  const bool legacy = format == kFormatV1 || format == kFormatV2;
  if (doc.is_discarded() || !doc.is_object() || (format != kFormat && !legacy) || !doc.contains("phones") ||
      !doc["phones"].is_array()) {
    writable_ = false;  // not ours: never overwritten
    return rtukit::Status(
        Errc::invalid_argument,
        fmt::format("{}: not an rtukit pairing file; move it away or choose another path", path_));
  }
  const auto time_of = [&](const nlohmann::json& j) {
    return j.contains("last_contact") && j["last_contact"].is_number_integer()
               ? j["last_contact"].get<int64_t>()
               : now;
  };
  for (const nlohmann::json& p : doc["phones"]) {
    if (!p.is_object()) continue;
    const auto text_of = [&](const char* key) {
      return p.contains(key) && p[key].is_string() ? p[key].get<std::string>() : std::string();
    };
    if (legacy) {
      // A token is what a phishing page could take: those phones pair again.
      legacy_dropped_.push_back(text_of("name").empty() ? "phone" : text_of("name"));
      continue;
    }
    PairedPhone phone;
    phone.id = text_of("id");
    phone.public_key = text_of("public_key");
    const std::optional<std::string> key = web::from_base64url(phone.public_key);
    if (phone.id.empty() || phone.id.size() > 64 || !key || !web::valid_p256_key(*key))
      continue;  // a damaged entry pairs nothing
    phone.last_contact = time_of(p);
    phone.name = text_of("name");
    if (phone.name.empty()) phone.name = "phone";
    phone.paired_at = text_of("paired_at");
    phone.code = text_of("code");
    // a key that is not true is doubt: not allowed.
    phone.confirmed = p.contains("confirmed") && p["confirmed"].is_boolean() && p["confirmed"].get<bool>();
    floor_ = std::max(floor_, phone.last_contact);
    phones_.push_back(std::move(phone));
  }
  // Format 2 kept only the Bluetooth phones allowed to drive, by id.
  if (doc.contains("bluetooth_confirmed") && doc["bluetooth_confirmed"].is_array())
    for (const nlohmann::json& id : doc["bluetooth_confirmed"])
      if (id.is_string() && is_bluetooth_id(id.get<std::string>()) && bluetooth_.size() < kMaxBluetooth)
        bluetooth_.push_back({id.get<std::string>(), true, now});
  if (doc.contains("bluetooth") && doc["bluetooth"].is_array())
    for (const nlohmann::json& b : doc["bluetooth"]) {
      if (!b.is_object() || !b.contains("id") || !b["id"].is_string() || bluetooth_.size() >= kMaxBluetooth)
        continue;
      const std::string id = b["id"].get<std::string>();
      if (!is_bluetooth_id(id) || bluetooth_phone(id)) continue;
      const bool confirmed =
          b.contains("confirmed") && b["confirmed"].is_boolean() && b["confirmed"].get<bool>();
      bluetooth_.push_back({id, confirmed, time_of(b)});
      floor_ = std::max(floor_, bluetooth_.back().last_contact);
    }
  // The file's own last write counts too (the kernel stamped it with the
  // calendar of that moment: right, when the board had the time then).
  struct stat st {};
  if (::stat(path_.c_str(), &st) == 0) floor_ = std::max<int64_t>(floor_, st.st_mtime);
  if (legacy) return save();  // the tokens leave the disk now
  return {};
}

rtukit::Status PairingStore::save() const {
  if (!writable_)
    return rtukit::Status(Errc::refused,
                          fmt::format("{}: not an rtukit pairing file, not overwritten", path_));
  nlohmann::ordered_json doc;
  doc["format"] = kFormat;
  doc["phones"] = nlohmann::json::array();
  for (const PairedPhone& p : phones_)
    doc["phones"].push_back({{"id", p.id},
                             {"public_key", p.public_key},
                             {"name", p.name},
                             {"code", p.code},
                             {"paired_at", p.paired_at},
                             {"last_contact", p.last_contact},
                             {"confirmed", p.confirmed}});
  doc["bluetooth"] = nlohmann::json::array();
  for (const BluetoothPhone& b : bluetooth_)
    doc["bluetooth"].push_back({{"id", b.id}, {"confirmed", b.confirmed}, {"last_contact", b.last_contact}});
  return io::write_file_atomically(path_, doc.dump(2) + "\n", 0600);
}

rtukit::Outcome<std::string> PairingStore::add(std::string name, std::string code, std::string public_key,
                                               int64_t now) {
  std::string id = random_hex(6);
  if (id.empty()) return rtukit::Status(Errc::io_error, "no random numbers (getrandom)");
  // Printable and short: the display shows it.
  name.erase(
      std::remove_if(name.begin(), name.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; }),
      name.end());
  if (name.empty() || name.size() > 40) name = fmt::format("phone {}", phones_.size() + 1);
  const auto t = std::chrono::system_clock::time_point(std::chrono::seconds(now));
  phones_.push_back(
      {id, std::move(public_key), name, std::move(code),
       fmt::format("{:%Y-%m-%dT%H:%M:%SZ}", fmt::gmtime(std::chrono::system_clock::to_time_t(t))), now,
       false});  // it drives once the display's user allowed it
  if (rtukit::Status e = save()) {
    phones_.pop_back();
    return e;
  }
  return id;
}

bool PairingStore::verify(std::string_view id, std::string_view message, std::string_view signature) const {
  const PairedPhone* p = phone(id);
  if (!p) return false;
  const std::optional<std::string> key = web::from_base64url(p->public_key);
  return key && web::verify_p256(*key, message, signature);
}

const PairedPhone* PairingStore::phone(std::string_view id) const {
  for (const PairedPhone& p : phones_)
    if (p.id == id) return &p;
  return nullptr;
}

const BluetoothPhone* PairingStore::bluetooth_phone(std::string_view id) const {
  for (const BluetoothPhone& b : bluetooth_)
    if (b.id == id) return &b;
  return nullptr;
}

rtukit::Status PairingStore::touch(std::string_view id, int64_t now) {
  for (BluetoothPhone& b : bluetooth_) {
    if (b.id != id || now - b.last_contact < kBluetoothContactStep) continue;
    b.last_contact = now;
    return save();
  }
  for (PairedPhone& p : phones_) {
    if (p.id != id) continue;
    p.last_contact = now;
    return save();
  }
  return {};
}

rtukit::Status PairingStore::remove(std::string_view id) {
  if (id.starts_with("ble:")) {
    const auto at =
        std::find_if(bluetooth_.begin(), bluetooth_.end(), [&](const auto& b) { return b.id == id; });
    if (at == bluetooth_.end()) return {};
    const BluetoothPhone removed = *at;
    bluetooth_.erase(at);
    if (rtukit::Status e = save()) {
      bluetooth_.push_back(removed);
      return e;
    }
    return {};
  }
  const auto it =
      std::find_if(phones_.begin(), phones_.end(), [&](const PairedPhone& p) { return p.id == id; });
  if (it == phones_.end()) return rtukit::Status(Errc::invalid_argument, "no such phone");
  const PairedPhone removed = *it;
  phones_.erase(it);
  if (rtukit::Status e = save()) {
    phones_.push_back(removed);
    return e;
  }
  return {};
}

rtukit::Status PairingStore::remove_all() {
  std::vector<PairedPhone> before = std::move(phones_);
  std::vector<BluetoothPhone> ble_before = std::move(bluetooth_);
  phones_.clear();
  bluetooth_.clear();
  if (rtukit::Status e = save()) {
    phones_ = std::move(before);
    bluetooth_ = std::move(ble_before);
    return e;
  }
  return {};
}

rtukit::Status PairingStore::bonded(std::string_view id, int64_t now) {
  if (bluetooth_phone(id)) return {};
  if (!is_bluetooth_id(id) || bluetooth_.size() >= kMaxBluetooth)
    return rtukit::Status(Errc::invalid_argument, "not a Bluetooth phone id, or too many");
  bluetooth_.push_back({std::string(id), false, now});
  if (rtukit::Status e = save()) {
    bluetooth_.pop_back();
    return e;
  }
  return {};
}

rtukit::Status PairingStore::confirm(std::string_view id) {
  if (id.starts_with("ble:")) {
    if (confirmed(id)) return {};
    if (!bluetooth_phone(id)) {
      if (!is_bluetooth_id(id) || bluetooth_.size() >= kMaxBluetooth)
        return rtukit::Status(Errc::invalid_argument, "not a Bluetooth phone id");
      bluetooth_.push_back({std::string(id), false, floor_});
    }
    for (BluetoothPhone& b : bluetooth_)
      if (b.id == id) b.confirmed = true;
    if (rtukit::Status e = save()) {
      for (BluetoothPhone& b : bluetooth_)
        if (b.id == id) b.confirmed = false;
      return e;
    }
    return {};
  }
  const auto it =
      std::find_if(phones_.begin(), phones_.end(), [&](const PairedPhone& p) { return p.id == id; });
  if (it == phones_.end()) return rtukit::Status(Errc::invalid_argument, "no such phone");
  if (it->confirmed) return {};
  it->confirmed = true;
  if (rtukit::Status e = save()) {
    it->confirmed = false;
    return e;
  }
  return {};
}

bool PairingStore::confirmed(std::string_view id) const {
  if (id.starts_with("ble:")) {
    const BluetoothPhone* b = bluetooth_phone(id);
    return b && b->confirmed;
  }
  const PairedPhone* p = phone(id);
  return p && p->confirmed;
}

int64_t PairingStore::time(int64_t calendar_s, int64_t monotonic_s) {
  if (!monotonic_origin_) monotonic_origin_ = monotonic_s;
  return std::max(calendar_s, floor_ + (monotonic_s - *monotonic_origin_));
}

std::vector<PairingStore::Forgotten> PairingStore::expire(int64_t now, int64_t max_age_s) {
  const auto old = [&](int64_t& last_contact) {
    last_contact = std::min(last_contact, now);  // the calendar was ahead when it was stored
    return now - last_contact > max_age_s;
  };
  std::vector<PairedPhone> phones_before = phones_;
  std::vector<BluetoothPhone> bluetooth_before = bluetooth_;
  std::vector<Forgotten> gone;
  std::erase_if(phones_, [&](PairedPhone& p) {
    if (!old(p.last_contact)) return false;
    gone.push_back({p.id, p.name});
    return true;
  });
  std::erase_if(bluetooth_, [&](BluetoothPhone& b) {
    if (!old(b.last_contact)) return false;
    gone.push_back({b.id, ""});
    return true;
  });
  if (!gone.empty() && save()) {
    // Not saved: keep them, the file still has them.
    phones_ = std::move(phones_before);
    bluetooth_ = std::move(bluetooth_before);
    gone.clear();
  }
  return gone;
}

}  // namespace rtukit::programs
