// The pairing store. Tokens are secrets: the file is 0600 and replaced
// atomically, so a power cut leaves the old or the new list of phones.
#include <fcntl.h>
#include <fmt/chrono.h>
#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <nlohmann/json.hpp>

#include "rtukit/io/atomic_file.hpp"
#include "rtukit/programs/rehand_host.hpp"

namespace rtukit::programs {
namespace {

constexpr size_t kMaxFile = 256 * 1024;
constexpr std::string_view kFormat = "rtukit rehand6600 pairing 1";

std::string random_token() {
  std::array<unsigned char, 16> bytes{};
  const int fd = ::open("/dev/urandom", O_RDONLY | O_CLOEXEC);
  size_t got = 0;
  while (fd >= 0 && got < bytes.size()) {
    const ssize_t n = ::read(fd, bytes.data() + got, bytes.size() - got);
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  if (fd >= 0) ::close(fd);
  if (got != bytes.size()) return {};
  std::string out;
  for (unsigned char b : bytes) out += fmt::format("{:02x}", b);
  return out;
}

}  // namespace

rtukit::Status PairingStore::load() {
  phones_.clear();
  writable_ = true;
  if (::access(path_.c_str(), F_OK) != 0) return {};  // no phone paired yet
  Outcome<std::string> text = io::read_regular_file(path_, kMaxFile);
  if (!text) {
    writable_ = false;
    return text.error();
  }
  const nlohmann::json doc = nlohmann::json::parse(*text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || doc.value("format", "") != kFormat ||
      !doc.contains("phones") || !doc["phones"].is_array()) {
    writable_ = false;  // not ours: never overwritten
    return rtukit::Status(
        Errc::invalid_argument,
        fmt::format("{}: not an rtukit pairing file; move it away or choose another path", path_));
  }
  for (const nlohmann::json& p : doc["phones"]) {
    if (!p.is_object() || !p.contains("token") || !p["token"].is_string() ||
        p["token"].get<std::string>().size() != 32)
      continue;  // a damaged entry pairs nothing
    phones_.push_back({p["token"].get<std::string>(), p.value("name", "phone"), p.value("paired_at", "")});
  }
  return {};
}

rtukit::Status PairingStore::save() const {
  if (!writable_)
    return rtukit::Status(Errc::refused,
                          fmt::format("{}: not an rtukit pairing file, not overwritten", path_));
  nlohmann::ordered_json doc;
  doc["format"] = kFormat;
  doc["phones"] = nlohmann::json::array();
  for (const Phone& p : phones_)
    doc["phones"].push_back({{"token", p.token}, {"name", p.name}, {"paired_at", p.paired_at}});
  return io::write_file_atomically(path_, doc.dump(2) + "\n", 0600);
}

rtukit::Outcome<std::string> PairingStore::add(std::string name) {
  std::string token = random_token();
  if (token.empty()) return rtukit::Status(Errc::io_error, "no random numbers (/dev/urandom)");
  if (name.empty() || name.size() > 40) name = fmt::format("phone {}", phones_.size() + 1);
  const auto now = std::chrono::system_clock::now();
  phones_.push_back(
      {token, name,
       fmt::format("{:%Y-%m-%dT%H:%M:%SZ}", fmt::gmtime(std::chrono::system_clock::to_time_t(now)))});
  if (rtukit::Status e = save()) {
    phones_.pop_back();
    return e;
  }
  return token;
}

bool PairingStore::contains(const std::string& token) const {
  return !token.empty() &&
         std::any_of(phones_.begin(), phones_.end(), [&](const Phone& p) { return p.token == token; });
}

std::string PairingStore::name_of(const std::string& token) const {
  for (const Phone& p : phones_)
    if (p.token == token) return p.name;
  return {};
}

rtukit::Status PairingStore::remove(const std::string& token) {
  const auto it =
      std::find_if(phones_.begin(), phones_.end(), [&](const Phone& p) { return p.token == token; });
  if (it == phones_.end()) return {};
  const Phone removed = *it;
  phones_.erase(it);
  if (rtukit::Status e = save()) {
    phones_.push_back(removed);
    return e;
  }
  return {};
}

}  // namespace rtukit::programs
