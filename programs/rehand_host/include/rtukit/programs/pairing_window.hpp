// rtukit Rehand 6600 host daemon: the pairing window the display opens
// ("Pair a phone"), its code and its limits, apart from the sockets. Pure:
// the time is passed in, new codes come from the function it is given (the
// daemon's draws 6 random digits; tests give their own), so every rule has a
// unit test on virtual time (tests/rehand_pairing_window_test.cpp).
//
// The rules (docs/security.md, "Threat model"):
//  - one window at a time, `lifetime` (2 minutes) from the display's "Pair a
//    phone", never extended, not even when its code is replaced;
//  - a code guessed at wrongly `code_guesses` (3) times is replaced by a new
//    one in the same window, so the owner can still pair;
//  - `window_guesses` (10) wrong codes in all, every code and address
//    together, close the window: only the display opens it again;
//  - one answer for "no window", "expired" and "wrong": a stranger learns
//    nothing about whether a code is showing;
//  - the code is compared in constant time.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <string_view>

#include "rtukit/base/clock.hpp"

namespace rtukit::programs {

class PairingWindow {
 public:
  /// A fresh code, or "" when none can be made (no random numbers).
  using NewCode = std::function<std::string()>;
  struct Limits {
    Clock::duration lifetime = std::chrono::minutes(2);
    int code_guesses = 3;
    int window_guesses = 10;
  };

  explicit PairingWindow(NewCode new_code) : PairingWindow(std::move(new_code), Limits{}) {}
  PairingWindow(NewCode new_code, Limits limits) : new_code_(std::move(new_code)), limits_(limits) {}

  /// Opens the window with a fresh code, `lifetime` from `now` (a window
  /// open already starts again). False: no code could be made; it stays closed.
  bool open(Clock::time_point now);
  /// Closes it (a phone paired, the display cancelled, it expired).
  void close() noexcept;
  /// Closes it when its time is up at `now`; true when that happened now.
  bool expire(Clock::time_point now) noexcept;

  bool is_open() const noexcept { return !code_.empty(); }
  /// The code the display shows; "" when closed.
  const std::string& code() const noexcept { return code_; }
  /// What is left of the window at `now` (zero when closed or past its end).
  Clock::duration left(Clock::time_point now) const noexcept;

  enum class Guess {
    right,          ///< the code shown, in time: the caller pairs the phone, then close()s
    wrong,          ///< no window, expired, or another code
    code_replaced,  ///< wrong, and the code's last guess: a new code shows, the window's end kept
    window_closed,  ///< wrong, and the window's last guess: closed until the display opens it again
  };
  /// A phone's code, typed at `now`.
  Guess guess(std::string_view typed, Clock::time_point now);

 private:
  NewCode new_code_;
  Limits limits_;
  std::string code_;
  Clock::time_point until_{};
  int code_guesses_ = 0;    ///< wrong guesses at this code
  int window_guesses_ = 0;  ///< wrong guesses in this window, every code together
};

}  // namespace rtukit::programs
