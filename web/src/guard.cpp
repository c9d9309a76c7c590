#include "rtukit/web/guard.hpp"

#include <arpa/inet.h>
#include <openssl/evp.h>

#include <algorithm>
#include <array>

namespace rtukit::web {

bool TokenBucket::take(TimePoint now) noexcept {
  if (refilled_)
    tokens_ = std::min(capacity_, tokens_ + std::chrono::duration<double>(now - *refilled_).count() * rate_);
  refilled_ = now;
  if (tokens_ < 1) return false;
  tokens_ -= 1;
  return true;
}

std::string guess_source(std::string_view peer) {
  const std::string text(peer);
  in6_addr a{};
  if (inet_pton(AF_INET6, text.c_str(), &a) != 1) return text;
  for (size_t i = 8; i < 16; ++i) a.s6_addr[i] = 0;  // the interface half: the subscriber chooses it
  char out[INET6_ADDRSTRLEN] = {};
  if (!inet_ntop(AF_INET6, &a, out, sizeof out)) return text;
  return std::string(out) + "/64";
}

void GuessLimit::forget_ended(Clock::time_point now) {
  std::erase_if(table_, [&](const auto& kv) { return now - kv.second.since >= window_; });
}

bool GuessLimit::refused(std::string_view peer, Clock::time_point now) {
  forget_ended(now);
  const auto it = table_.find(guess_source(peer));
  if (it == table_.end()) return table_.size() >= max_sources_;
  return it->second.count >= per_source_;
}

Clock::duration GuessLimit::wait(std::string_view peer, Clock::time_point now) {
  if (!refused(peer, now)) return Clock::duration::zero();
  const auto it = table_.find(guess_source(peer));
  if (it != table_.end()) return it->second.since + window_ - now;
  // A full table: the first live source's window to end frees a place.
  Clock::time_point first = Clock::time_point::max();
  for (const auto& [source, entry] : table_) first = std::min(first, entry.since + window_);
  return first - now;
}

int GuessLimit::count(std::string_view peer, Clock::time_point now) {
  const std::string source = guess_source(peer);
  auto it = table_.find(source);
  if (it == table_.end()) {
    if (table_.size() >= max_sources_) return 0;  // refused() refuses it anyway
    it = table_.emplace(source, Entry{now, 0}).first;
  }
  return ++it->second.count;
}

std::string hex(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(bytes.size() * 2);
  for (const char c : bytes) {
    const auto b = static_cast<unsigned char>(c);
    out += kDigits[b >> 4];
    out += kDigits[b & 0xF];
  }
  return out;
}

std::optional<std::string> from_hex(std::string_view text) {
  if (text.size() % 2) return std::nullopt;
  const auto digit = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
  };
  std::string out;
  out.reserve(text.size() / 2);
  for (size_t i = 0; i < text.size(); i += 2) {
    const int high = digit(text[i]), low = digit(text[i + 1]);
    if (high < 0 || low < 0) return std::nullopt;
    out += static_cast<char>(high << 4 | low);
  }
  return out;
}

std::string sha256_hex(std::string_view text) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int n = 0;
  if (EVP_Digest(text.data(), text.size(), digest.data(), &n, EVP_sha256(), nullptr) != 1) return {};
  return hex({reinterpret_cast<const char*>(digest.data()), n});
}

}  // namespace rtukit::web
