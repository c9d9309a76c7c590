// rtukit Rehand 6600 host daemon: who is in. The rules that decide which
// Wi-Fi phone connection may drive the chair, apart from the sockets: the
// pairing window, the challenge a connection signs, the wrong-guess limits,
// one connection per phone, the authentication timeout and the expiry of
// unused phones. The daemon (rehand_host.cpp) only carries out what these
// answers say: it closes the connections they name, joins and leaves the
// session, logs and shows. Time comes from the DriverClock it is given, so
// every rule has a unit test on a ManualClock (tests/rehand_phone_access_test.cpp).
//
// The rules (docs/security.md, "Threat model"; docs/rehand6600-remote.md):
//  - a phone connection is out until it signs its connection's challenge
//    with a paired key (authenticate) or pairs with the display's code and
//    a new key (pair); a connection still out after `auth_timeout` is
//    closed;
//  - one answer for an unknown phone and a wrong signature, one for "no
//    code shown", "expired" and "wrong"; the pairing window's own rules are
//    PairingWindow's (pairing_window.hpp);
//  - `wrong_per_source` wrong codes or signatures from one source (an IPv4
//    address, an IPv6 /64) in `wrong_window` refuse that source until the
//    window ends (web::GuessLimit), checked before any key is looked at;
//  - a phone is in on one connection: the newest wins, the older ones are
//    named for the caller to close;
//  - a phone unused for `max_age` is forgotten (checked once a minute).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/programs/pairing_window.hpp"
#include "rtukit/programs/rehand_host.hpp"
#include "rtukit/web/guard.hpp"

namespace rtukit::programs {

class PhoneAccess {
 public:
  struct Limits {
    PairingWindow::Limits window;
    int wrong_per_source = 10;
    Clock::duration wrong_window = std::chrono::minutes(1);
    size_t wrong_sources = 4096;  ///< sources the limiter keeps at most (about 200 KiB)
    Clock::duration auth_timeout = std::chrono::seconds(5);
    std::chrono::seconds max_age{std::chrono::hours(24 * 30)};
  };

  /// `store` (loaded by the caller) and `clock` outlive this object.
  /// `new_code`: the pairing window's codes (6 random digits in the daemon).
  PhoneAccess(PairingStore& store, DriverClock& clock, PairingWindow::NewCode new_code, Limits limits);

  /// What a phone's key signs to be let in on a connection: a fixed prefix
  /// (the signature means nothing anywhere else) and that connection's
  /// challenge (new on every connection: a signature seen once opens no other).
  static std::string signed_text(std::string_view challenge);

  // ---------------------------------------------------------- connections

  /// A phone connection opened with `challenge` (sent in its hello): out
  /// until it authenticates or pairs.
  void connected(uint64_t connection, std::string challenge);
  /// It closed: forgotten. Returns the phone it let in, "" when it was out.
  std::string left(uint64_t connection);
  bool is_in(uint64_t connection) const;
  /// The phone connection `connection` let in; "" when it is out or unknown.
  std::string phone_of(uint64_t connection) const;
  /// Whether `phone` is in on some connection.
  bool is_connected(std::string_view phone) const;

  /// The answer to a phone's authenticate or pair.
  struct Admission {
    rtukit::Status error;            ///< refused: the reason, for the phone (errc refused); else ok
    std::string phone;               ///< let in: its id
    std::vector<uint64_t> replaced;  ///< its older connections, now out: the caller closes them
    /// pair(): what a wrong code did to the window (code_replaced,
    /// window_closed: the caller tells the display); `right` otherwise.
    PairingWindow::Guess guess = PairingWindow::Guess::right;
    bool limited = false;  ///< refused for too many wrong guesses from its source
  };
  /// A paired phone's signature of signed_text(its connection's challenge).
  /// `peer`: the source address, for the guess limit.
  Admission authenticate(uint64_t connection, std::string_view peer, std::string_view phone,
                         std::string_view signature);
  /// A new phone: the display's `code`, its `public_key` (raw P-256 point)
  /// and its signature of the challenge with that key. Let in: the phone is
  /// saved (named `name`), the window closed. Errors: refused (the reasons
  /// above), the store's save error (nothing added, the window still open).
  Admission pair(uint64_t connection, std::string_view peer, std::string_view code, std::string name,
                 std::string_view public_key, std::string_view signature);

  /// Connections still out after auth_timeout, forgotten here: the caller closes them.
  std::vector<uint64_t> timed_out();
  /// Every connection `phone` is in on, now out (it was forgotten): the caller closes them.
  std::vector<uint64_t> drop(std::string_view phone);

  // ---------------------------------------------------------- the pairing window

  /// "Pair a phone": a fresh code for the window's lifetime. False: no
  /// random numbers (it stays closed).
  bool open_window() { return window_.open(clock_.now()); }
  void close_window() noexcept { window_.close(); }
  /// Closes the window when its time is up; true when that happened now.
  bool expire_window() noexcept { return window_.expire(clock_.now()); }
  const std::string& code() const noexcept { return window_.code(); }
  bool window_open() const noexcept { return window_.is_open(); }
  Clock::duration window_left() const noexcept { return window_.left(clock_.now()); }

  // ---------------------------------------------------------- the store's time

  /// The store's time now (PairingStore::time: the calendar, never before
  /// what its file recorded).
  int64_t store_now();
  /// Records a contact of `phone` (either kind) now; see PairingStore::touch.
  rtukit::Status touch(std::string_view phone) { return store_.touch(phone, store_now()); }
  /// The phones of either kind unused for more than max_age, forgotten from
  /// the store (their connections are the caller's to drop, a Bluetooth
  /// phone's bond too). Checks at most once a minute: call it often; the
  /// first call checks.
  std::vector<PairingStore::Forgotten> expire_unused();

 private:
  struct Connection {
    Clock::time_point opened;
    std::string challenge;
    std::string phone;  ///< "" while out
  };
  Admission refused(std::string reason, bool limited = false) const;
  Admission admit(uint64_t connection, std::string phone);

  PairingStore& store_;
  DriverClock& clock_;
  Limits limits_;
  PairingWindow window_;
  web::GuessLimit wrong_;
  std::map<uint64_t, Connection> connections_;
  std::optional<Clock::time_point> last_expiry_check_;
};

}  // namespace rtukit::programs
