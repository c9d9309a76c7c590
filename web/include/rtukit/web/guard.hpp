// What keeps a listener's clients honest, in one place for every program
// (the web server's sockets, the Rehand host daemon's pairing and Bluetooth
// link, the pool panel's login). Pure: the time is passed in, so each rule
// has unit tests on virtual time (tests/web_guard_test.cpp).
//
//  - TokenBucket: a rate with bursts (messages, commands);
//  - GuessLimit: wrong guesses (codes, signatures, passwords) per source, an
//    IPv6 network counted as one (guess_source), in bounded memory;
//  - hex and SHA-256 for what is stored of a secret (a session token).
#pragma once

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "rtukit/base/clock.hpp"

namespace rtukit::web {

/// `rate` a second on average, bursts up to `burst_seconds` of it. Starts
/// full. Time is passed in.
class TokenBucket {
 public:
  explicit TokenBucket(double rate, double burst_seconds = 2.0) noexcept
      : rate_(rate), capacity_(rate * burst_seconds), tokens_(capacity_) {}
  /// Takes one token at `now`: false when there is none (the caller refuses
  /// the message or command). The first call starts the clock.
  bool take(TimePoint now) noexcept;

 private:
  double rate_;
  double capacity_;
  double tokens_;
  std::optional<TimePoint> refilled_;
};

/// The source a guess is counted against, from a connection's peer address
/// as web::Socket::peer_address() gives it ("192.0.2.7", "2001:db8::1"): an
/// IPv4 address itself, an IPv6 address's /64 ("2001:db8:1:2::/64": one
/// subscriber's network has 2^64 addresses, so a limit per address would be
/// no limit there). Anything else is its own key.
std::string guess_source(std::string_view peer);

/// Wrong guesses (pairing codes, signatures, passwords), counted per source
/// (guess_source) over a window: a source with `per_source` wrong ones is
/// refused until its window ends. Sources whose window is over are
/// forgotten; a table full of live sources (many addresses guessing at
/// once) refuses a new one until some window ends: fail closed, with
/// bounded memory. Time is passed in.
class GuessLimit {
 public:
  GuessLimit(int per_source, Clock::duration window, size_t max_sources)
      : per_source_(per_source), window_(window), max_sources_(max_sources) {}
  /// True when `peer` may not try now.
  bool refused(std::string_view peer, Clock::time_point now);
  /// How long `peer` must wait before it may try (zero: it may now). For
  /// the answer's "try again in N s".
  Clock::duration wait(std::string_view peer, Clock::time_point now);
  /// One more wrong guess from `peer` (call after refused() said no).
  /// Returns the source's count in its window (0 when the table is full).
  int count(std::string_view peer, Clock::time_point now);
  /// Sources remembered now (pruned by refused() and wait()).
  size_t sources() const noexcept { return table_.size(); }

 private:
  struct Entry {
    Clock::time_point since;
    int count = 0;
  };
  void forget_ended(Clock::time_point now);
  int per_source_;
  Clock::duration window_;
  size_t max_sources_;
  std::map<std::string, Entry, std::less<>> table_;
};

/// Lowercase hex of `bytes`.
std::string hex(std::string_view bytes);
/// The bytes of lowercase hex `text`; nullopt for an odd length or another character.
std::optional<std::string> from_hex(std::string_view text);
/// The SHA-256 of `text` in lowercase hex (what is kept of a session token).
/// Empty only if OpenSSL fails.
std::string sha256_hex(std::string_view text);

}  // namespace rtukit::web
