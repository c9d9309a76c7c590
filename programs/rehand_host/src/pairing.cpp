// The pairing store. A token is a secret the phone keeps; the file keeps
// only its SHA-256 (a copy of the file, or a look over a shoulder at it,
// drives nothing), and a presented token is compared with every stored hash
// in constant time. The file is 0600 and replaced atomically, so a power cut
// leaves the old or the new list of phones.
#include <fmt/chrono.h>
#include <fmt/core.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <nlohmann/json.hpp>

#include "rtukit/io/atomic_file.hpp"
#include "rtukit/programs/rehand_host.hpp"
#include "rtukit/web/tls.hpp"

namespace rtukit::programs {
namespace {

constexpr size_t kMaxFile = 256 * 1024;
constexpr std::string_view kFormat = "rtukit rehand6600 pairing 2";
constexpr std::string_view kFormatV1 = "rtukit rehand6600 pairing 1";  // tokens in the clear: hashed on load

std::string hex(const unsigned char* data, size_t n) {
  std::string out;
  out.reserve(n * 2);
  for (size_t i = 0; i < n; ++i) out += fmt::format("{:02x}", data[i]);
  return out;
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

std::string sha256_hex(std::string_view text) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int n = 0;
  if (EVP_Digest(text.data(), text.size(), digest.data(), &n, EVP_sha256(), nullptr) != 1) return {};
  return hex(digest.data(), n);
}

std::string random_hex(size_t bytes) {
  std::array<unsigned char, 64> b{};
  if (bytes > b.size() || !web::random_bytes(b.data(), bytes)) return {};
  return hex(b.data(), bytes);
}

rtukit::Status PairingStore::load(int64_t now) {
  phones_.clear();
  ble_confirmed_.clear();
  writable_ = true;
  if (::access(path_.c_str(), F_OK) != 0) return {};  // no phone paired yet
  Outcome<std::string> text = io::read_regular_file(path_, kMaxFile);
  if (!text) {
    writable_ = false;
    return text.error();
  }
  const nlohmann::json doc = nlohmann::json::parse(*text, nullptr, false);
  const std::string format = doc.is_object() ? doc.value("format", "") : "";
  if (doc.is_discarded() || !doc.is_object() || (format != kFormat && format != kFormatV1) ||
      !doc.contains("phones") || !doc["phones"].is_array()) {
    writable_ = false;  // not ours: never overwritten
    return rtukit::Status(
        Errc::invalid_argument,
        fmt::format("{}: not an rtukit pairing file; move it away or choose another path", path_));
  }
  const bool v1 = format == kFormatV1;
  for (const nlohmann::json& p : doc["phones"]) {
    if (!p.is_object()) continue;
    PairedPhone phone;
    const auto text_of = [&](const char* key) {
      return p.contains(key) && p[key].is_string() ? p[key].get<std::string>() : std::string();
    };
    if (v1) {
      const std::string token = text_of("token");
      if (token.size() != 32) continue;  // a damaged entry pairs nothing
      phone.token_hash = sha256_hex(token);
      phone.id = random_hex(6);
      phone.last_contact = now;  // the 30-day clock starts with this version
    } else {
      phone.token_hash = text_of("token_sha256");
      phone.id = text_of("id");
      if (phone.token_hash.size() != 64 || phone.id.empty()) continue;
      phone.last_contact = p.contains("last_contact") && p["last_contact"].is_number_integer()
                               ? p["last_contact"].get<int64_t>()
                               : now;
    }
    phone.name = text_of("name");
    if (phone.name.empty()) phone.name = "phone";
    phone.paired_at = text_of("paired_at");
    phone.code = text_of("code");
    // Paired before R-18 (no such key): it drove then and keeps driving. A
    // key that is there but not true is doubt: not allowed.
    phone.confirmed = !p.contains("confirmed") || (p["confirmed"].is_boolean() && p["confirmed"].get<bool>());
    floor_ = std::max(floor_, phone.last_contact);
    phones_.push_back(std::move(phone));
  }
  if (doc.contains("bluetooth_confirmed") && doc["bluetooth_confirmed"].is_array())
    for (const nlohmann::json& id : doc["bluetooth_confirmed"])
      if (id.is_string() && id.get<std::string>().starts_with("ble:") && id.get<std::string>().size() <= 64 &&
          ble_confirmed_.size() < 256)
        ble_confirmed_.push_back(id.get<std::string>());
  // The file's own last write counts too (the kernel stamped it with the
  // calendar of that moment: right, when the board had the time then).
  struct stat st {};
  if (::stat(path_.c_str(), &st) == 0) floor_ = std::max<int64_t>(floor_, st.st_mtime);
  if (v1) return save();  // the clear tokens leave the disk now
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
                             {"token_sha256", p.token_hash},
                             {"name", p.name},
                             {"code", p.code},
                             {"paired_at", p.paired_at},
                             {"last_contact", p.last_contact},
                             {"confirmed", p.confirmed}});
  doc["bluetooth_confirmed"] = ble_confirmed_;
  return io::write_file_atomically(path_, doc.dump(2) + "\n", 0600);
}

rtukit::Outcome<PairingStore::Added> PairingStore::add(std::string name, std::string code, int64_t now) {
  Added added{random_hex(6), random_hex(32)};  // a 256-bit token
  if (added.id.empty() || added.token.empty())
    return rtukit::Status(Errc::io_error, "no random numbers (getrandom)");
  // Printable and short: the display shows it.
  name.erase(
      std::remove_if(name.begin(), name.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; }),
      name.end());
  if (name.empty() || name.size() > 40) name = fmt::format("phone {}", phones_.size() + 1);
  const auto t = std::chrono::system_clock::time_point(std::chrono::seconds(now));
  phones_.push_back(
      {added.id, sha256_hex(added.token), name, std::move(code),
       fmt::format("{:%Y-%m-%dT%H:%M:%SZ}", fmt::gmtime(std::chrono::system_clock::to_time_t(t))), now,
       false});  // it drives once the display's user allowed it
  if (rtukit::Status e = save()) {
    phones_.pop_back();
    return e;
  }
  return added;
}

std::optional<std::string> PairingStore::find(std::string_view token) const {
  if (token.empty()) return std::nullopt;
  const std::string hash = sha256_hex(token);
  if (hash.size() != 64) return std::nullopt;
  std::optional<std::string> found;
  // Every entry is compared, each in constant time: how long this takes
  // says nothing about which hash, or how much of it, matched.
  for (const PairedPhone& p : phones_) {
    if (p.token_hash.size() == hash.size() &&
        CRYPTO_memcmp(p.token_hash.data(), hash.data(), hash.size()) == 0)
      found = p.id;
  }
  return found;
}

const PairedPhone* PairingStore::phone(std::string_view id) const {
  for (const PairedPhone& p : phones_)
    if (p.id == id) return &p;
  return nullptr;
}

rtukit::Status PairingStore::touch(std::string_view id, int64_t now) {
  for (PairedPhone& p : phones_) {
    if (p.id != id) continue;
    p.last_contact = now;
    return save();
  }
  return {};
}

rtukit::Status PairingStore::remove(std::string_view id) {
  if (id.starts_with("ble:")) {
    const auto at = std::find(ble_confirmed_.begin(), ble_confirmed_.end(), id);
    if (at == ble_confirmed_.end()) return {};
    const std::string removed = *at;
    ble_confirmed_.erase(at);
    if (rtukit::Status e = save()) {
      ble_confirmed_.push_back(removed);
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
  std::vector<std::string> ble_before = std::move(ble_confirmed_);
  phones_.clear();
  ble_confirmed_.clear();
  if (rtukit::Status e = save()) {
    phones_ = std::move(before);
    ble_confirmed_ = std::move(ble_before);
    return e;
  }
  return {};
}

rtukit::Status PairingStore::confirm(std::string_view id) {
  if (id.starts_with("ble:")) {
    if (confirmed(id)) return {};
    if (id.size() > 64 || ble_confirmed_.size() >= 256)
      return rtukit::Status(Errc::invalid_argument, "not a Bluetooth phone id");
    ble_confirmed_.emplace_back(id);
    if (rtukit::Status e = save()) {
      ble_confirmed_.pop_back();
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
  if (id.starts_with("ble:"))
    return std::find(ble_confirmed_.begin(), ble_confirmed_.end(), id) != ble_confirmed_.end();
  const PairedPhone* p = phone(id);
  return p && p->confirmed;
}

int64_t PairingStore::time(int64_t calendar_s, int64_t monotonic_s) {
  if (!monotonic_origin_) monotonic_origin_ = monotonic_s;
  return std::max(calendar_s, floor_ + (monotonic_s - *monotonic_origin_));
}

std::vector<PairedPhone> PairingStore::expire(int64_t now, int64_t max_age_s) {
  std::vector<PairedPhone> gone;
  std::vector<PairedPhone> kept;
  for (PairedPhone& p : phones_) {
    p.last_contact = std::min(p.last_contact, now);  // the calendar was ahead when it was stored
    (now - p.last_contact > max_age_s ? gone : kept).push_back(std::move(p));
  }
  phones_ = std::move(kept);
  if (!gone.empty() && save()) {
    // Not saved: keep them, the file still has them.
    for (PairedPhone& p : gone) phones_.push_back(std::move(p));
    gone.clear();
  }
  return gone;
}

}  // namespace rtukit::programs
