#include "rtukit/programs/pairing_window.hpp"

#include <openssl/crypto.h>

namespace rtukit::programs {

bool PairingWindow::open(Clock::time_point now) {
  std::string fresh = new_code_();
  if (fresh.empty()) return false;
  code_ = std::move(fresh);
  until_ = now + limits_.lifetime;
  code_guesses_ = 0;
  window_guesses_ = 0;
  return true;
}

void PairingWindow::close() noexcept {
  code_.clear();
  until_ = {};
  code_guesses_ = 0;
  window_guesses_ = 0;
}

bool PairingWindow::expire(Clock::time_point now) noexcept {
  if (!is_open() || now <= until_) return false;
  close();
  return true;
}

Clock::duration PairingWindow::left(Clock::time_point now) const noexcept {
  if (!is_open() || now >= until_) return Clock::duration::zero();
  return until_ - now;
}

PairingWindow::Guess PairingWindow::guess(std::string_view typed, Clock::time_point now) {
  if (!is_open()) return Guess::wrong;  // nothing to guess at, nothing counted
  // A time-constant comparison: how far a wrong code matched does not show.
  const bool right = now <= until_ && typed.size() == code_.size() &&
                     CRYPTO_memcmp(typed.data(), code_.data(), code_.size()) == 0;
  if (right) return Guess::right;
  if (++window_guesses_ >= limits_.window_guesses) {
    close();
    return Guess::window_closed;
  }
  if (++code_guesses_ >= limits_.code_guesses) {
    // Guessed at: a new code, so the owner can still pair, in the same
    // window (its end does not move). No code to be had: the window closes.
    std::string fresh = new_code_();
    if (fresh.empty()) {
      close();
      return Guess::window_closed;
    }
    code_ = std::move(fresh);
    code_guesses_ = 0;
    return Guess::code_replaced;
  }
  return Guess::wrong;
}

}  // namespace rtukit::programs
