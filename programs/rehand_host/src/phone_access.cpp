#include "rtukit/programs/phone_access.hpp"

#include "rtukit/web/webcrypto.hpp"

namespace rtukit::programs {

PhoneAccess::PhoneAccess(PairingStore& store, DriverClock& clock, PairingWindow::NewCode new_code,
                         Limits limits)
    : store_(store),
      clock_(clock),
      limits_(limits),
      window_(std::move(new_code), limits.window),
      wrong_(limits.wrong_per_source, limits.wrong_window, limits.wrong_sources) {}

std::string PhoneAccess::signed_text(std::string_view challenge) {
  return "rtukit-rehand6600-phone:" + std::string(challenge);
}

void PhoneAccess::connected(uint64_t connection, std::string challenge) {
  connections_[connection] = {.opened = clock_.now(), .challenge = std::move(challenge), .phone = {}};
}

std::string PhoneAccess::left(uint64_t connection) {
  const auto it = connections_.find(connection);
  if (it == connections_.end()) return {};
  std::string phone = std::move(it->second.phone);
  connections_.erase(it);
  return phone;
}

bool PhoneAccess::is_in(uint64_t connection) const {
  return !phone_of(connection).empty();
}

std::string PhoneAccess::phone_of(uint64_t connection) const {
  const auto it = connections_.find(connection);
  return it == connections_.end() ? std::string() : it->second.phone;
}

bool PhoneAccess::is_connected(std::string_view phone) const {
  for (const auto& [id, c] : connections_)
    if (!c.phone.empty() && c.phone == phone) return true;
  return false;
}

PhoneAccess::Admission PhoneAccess::refused(std::string reason, bool limited) const {
  Admission a;
  a.error = rtukit::Status(Errc::refused, std::move(reason));
  a.guess = PairingWindow::Guess::wrong;
  a.limited = limited;
  return a;
}

// In: the newest connection of a phone wins, the older ones go out at once
// (their presses end when the caller leaves the session for them).
PhoneAccess::Admission PhoneAccess::admit(uint64_t connection, std::string phone) {
  Admission a;
  for (auto& [id, c] : connections_) {
    if (id == connection || c.phone != phone) continue;
    c.phone.clear();
    a.replaced.push_back(id);
  }
  connections_[connection].phone = phone;
  a.phone = std::move(phone);
  (void)store_.touch(a.phone, store_now());
  return a;
}

namespace {
constexpr const char* kTooMany =
    "too many wrong signatures or codes from this address (or too many addresses guessing): wait a minute";
}

PhoneAccess::Admission PhoneAccess::authenticate(uint64_t connection, std::string_view peer,
                                                 std::string_view phone, std::string_view signature) {
  const auto it = connections_.find(connection);
  if (it == connections_.end()) return refused("no such connection");
  // The limit first: a refused source learns nothing, not even whether its signature was right.
  if (wrong_.refused(peer, clock_.now())) return refused(kTooMany, true);
  // One answer for an unknown phone and a wrong signature.
  if (!store_.verify(phone, signed_text(it->second.challenge), signature)) {
    (void)wrong_.count(peer, clock_.now());
    return refused("not paired: this phone is unknown or was forgotten; pair again with the display's code");
  }
  return admit(connection, std::string(phone));
}

PhoneAccess::Admission PhoneAccess::pair(uint64_t connection, std::string_view peer, std::string_view code,
                                         std::string name, std::string_view public_key,
                                         std::string_view signature) {
  const auto it = connections_.find(connection);
  if (it == connections_.end()) return refused("no such connection");
  if (wrong_.refused(peer, clock_.now())) return refused(kTooMany, true);
  // One answer for "no code shown", "expired" and "wrong": nothing a
  // stranger can probe tells whether a code is showing. The window's rules
  // (pairing_window.hpp): a code guessed at is replaced, a window guessed at
  // from everywhere closes.
  if (const PairingWindow::Guess g = window_.guess(code, clock_.now()); g != PairingWindow::Guess::right) {
    (void)wrong_.count(peer, clock_.now());
    Admission a = refused("wrong or expired code: enter the code the display shows now");
    a.guess = g;
    return a;
  }
  // The right code: the phone also shows it holds the key it brings (a key
  // the page cannot use would pair a phone that never connects). Not a
  // guess: the code was right, so nothing is counted.
  if (!web::verify_p256(public_key, signed_text(it->second.challenge), signature))
    return refused("the phone's signature does not match its key: reload the page and pair again");
  rtukit::Outcome<std::string> added =
      store_.add(std::move(name), window_.code(), web::base64url(public_key), store_now());
  if (!added) {
    Admission a;
    a.error = added.error();
    return a;
  }
  // One "Pair a phone", one phone.
  window_.close();
  return admit(connection, *added);
}

std::vector<uint64_t> PhoneAccess::timed_out() {
  std::vector<uint64_t> out;
  const auto now = clock_.now();
  for (auto it = connections_.begin(); it != connections_.end();) {
    if (it->second.phone.empty() && now - it->second.opened > limits_.auth_timeout) {
      out.push_back(it->first);
      it = connections_.erase(it);
    } else {
      ++it;
    }
  }
  return out;
}

std::vector<uint64_t> PhoneAccess::drop(std::string_view phone) {
  std::vector<uint64_t> out;
  for (auto& [id, c] : connections_) {
    if (c.phone.empty() || c.phone != phone) continue;
    c.phone.clear();
    out.push_back(id);
  }
  return out;
}

int64_t PhoneAccess::store_now() {
  return store_.time(
      clock_.unix_seconds(),
      std::chrono::duration_cast<std::chrono::seconds>(clock_.now().time_since_epoch()).count());
}

std::vector<PairingStore::Forgotten> PhoneAccess::expire_unused() {
  const auto now = clock_.now();
  if (last_expiry_check_ && now - *last_expiry_check_ < std::chrono::minutes(1)) return {};
  last_expiry_check_ = now;
  return store_.expire(store_now(), limits_.max_age.count());
}

}  // namespace rtukit::programs
