// The Rehand 6600 host daemon, the program that runs on the RK3588: it owns
// the UART (the host controller, rehand6600/host.hpp), serves the touch HMI
// and the phone remote (web/assets/rehand/) and their JSON API over HTTP and
// WebSocket (docs/rehand6600.md, "The host daemon").
//
// Who may do what (docs/rehand6600-remote.md; threats: docs/security.md):
//  - the display: WebSocket /ws on the --http listener, loopback only (the
//    kiosk browser on the same board). Postures, settings, the Stop button;
//    it shows the pairing code and the certificate's fingerprint, lists
//    every paired phone and forgets them.
//  - a phone: WebSocket /ws on a phone listener, TLS only. Its first message
//    authenticates it (a token, never in a URL) or pairs it (the one-time
//    code the display shows); then it drives under the session's rules.
//  - a phone over Bluetooth LE (--ble): bonded with the passkey the display
//    shows; the same session and rules (docs/rehand6600-ble.md).
//
// Every rule about who may command what, and for how long, is the host
// controller's Session (rehand6600/session.hpp); this daemon only carries
// messages to it. Every command is answered on its own connection
// ({"type":"result"}); a refused one changes nothing. The web thread never
// waits for the bus: the host controller's worker writes.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/io/link.hpp"

namespace rtukit::programs {

/// One phone paired over Wi-Fi, as the store keeps it: its public key,
/// never a secret (the private key never leaves the phone's browser).
struct PairedPhone {
  std::string id;            ///< 12 hex digits, random: how the page and the display name it
  std::string public_key;    ///< ECDSA P-256, raw point, base64url (web/webcrypto.hpp)
  std::string name;          ///< as the phone asked, shown on the display
  std::string code;          ///< the pairing code it paired with (the display user saw it)
  std::string paired_at;     ///< UTC, ISO 8601
  int64_t last_contact = 0;  ///< Unix seconds of its last connection
  /// The display's user allowed it to drive, seeing its name. A phone
  /// paired from now on starts without.
  bool confirmed = false;
};

/// One phone bonded over Bluetooth LE: its bond is BlueZ's; the store keeps
/// what the daemon decides about it.
struct BluetoothPhone {
  std::string id;            ///< "ble:ADDRESS"
  bool confirmed = false;    ///< allowed to drive (R-18)
  int64_t last_contact = 0;  ///< Unix seconds: its bonding, then its last command (30 days unused: forgotten)
};

/// Paired phones, in a JSON file written atomically (a temporary file
/// created exclusively beside it, fsync, rename), mode 0600. A file that is
/// not ours (not a regular file, too large, another program's JSON) is never
/// overwritten: load() says why. A Wi-Fi phone is its public key: it proves
/// it is paired by signing a challenge (verify()); no secret is on the disk.
/// Files of the earlier formats kept phones by a token (in the clear, then
/// hashed): their Wi-Fi phones are dropped at load (they pair again once,
/// legacy_dropped() names them); their Bluetooth leaves are kept.
class PairingStore {
 public:
  explicit PairingStore(std::string path) : path_(std::move(path)) {}
  /// Reads the file; a missing file is an empty store. Errors: io_error /
  /// invalid_argument with the reason (the store is then read-only).
  /// `now`: Unix seconds, the last contact given to a record that has none.
  rtukit::Status load(int64_t now);
  /// A new phone named `name` (control characters removed; empty or over
  /// 40 bytes: "phone N") with `public_key` (raw, base64url; the caller
  /// checked it with web::valid_p256_key), paired with `code` at `now`
  /// (Unix s), saved before its id is returned. Errors: the save's, with the
  /// reason; io_error when the OS gives no random numbers.
  rtukit::Outcome<std::string> add(std::string name, std::string code, std::string public_key, int64_t now);
  /// Whether Wi-Fi phone `id` signed `message` with its key (`signature`:
  /// P1363 bytes). False for an unknown id or anything malformed.
  bool verify(std::string_view id, std::string_view message, std::string_view signature) const;
  const PairedPhone* phone(std::string_view id) const;
  /// Records a contact, saved. A Wi-Fi phone's at once (it connects
  /// rarely); a Bluetooth phone's (it writes ten times a second) only when
  /// the recorded one is a minute old or more. Unknown ids are ignored.
  rtukit::Status touch(std::string_view id, int64_t now);
  /// Forgets a phone of either kind and its leave to drive. Errors:
  /// invalid_argument (no such Wi-Fi phone; an unknown Bluetooth id is no
  /// error: its bond is BlueZ's), the save's (then nothing changed).
  rtukit::Status remove(std::string_view id);
  rtukit::Status remove_all();
  /// A Bluetooth phone BlueZ lists as bonded: a record is made for it at
  /// `now` if it has none (a new bond, or one made before the store kept
  /// Bluetooth phones), not allowed to drive. Errors: the save's.
  rtukit::Status bonded(std::string_view id, int64_t now);
  /// the display's user allows phone `id` to drive (a paired phone's
  /// id, or "ble:ADDRESS" of a bonded Bluetooth phone; the caller checks
  /// that one is bonded). Saved. Errors: invalid_argument (no such paired
  /// phone), the save's (then nothing changed).
  rtukit::Status confirm(std::string_view id);
  /// Whether phone `id` (either kind) may drive.
  bool confirmed(std::string_view id) const;
  /// Forgets the phones of either kind not seen for more than `max_age_s`
  /// and returns them, id and name (a Bluetooth phone's name is BlueZ's:
  /// empty here; its bond is the caller's to remove). A last contact after `now` (stored while the calendar
  /// was ahead) counts as `now`. Not saved: none is forgotten (the file still has them).
  struct Forgotten {
    std::string id, name;
  };
  std::vector<Forgotten> expire(int64_t now, int64_t max_age_s);
  /// The store's time, for add(), touch() and expire(): the calendar
  /// (`calendar_s`, Unix seconds), but never before the newest time the file
  /// recorded at load (a last contact, the file's own last write) plus the
  /// monotonic time since the first call (`monotonic_s`, any origin). A board
  /// without a real-time clock boots in 1970, or at an old saved time: a
  /// contact then is recorded at the file's time and after, never in 1970
  /// (which would forget the phone the moment the clock is set). While the
  /// calendar is wrong, time the board spent switched off is not counted: a
  /// phone is kept longer, never forgotten sooner.
  int64_t time(int64_t calendar_s, int64_t monotonic_s);
  const std::vector<PairedPhone>& phones() const noexcept { return phones_; }
  const std::vector<BluetoothPhone>& bluetooth() const noexcept { return bluetooth_; }
  const BluetoothPhone* bluetooth_phone(std::string_view id) const;
  /// The names of the Wi-Fi phones of an earlier format dropped at load.
  const std::vector<std::string>& legacy_dropped() const noexcept { return legacy_dropped_; }
  size_t size() const noexcept { return phones_.size(); }
  const std::string& path() const noexcept { return path_; }

 private:
  rtukit::Status save() const;
  std::string path_;
  std::vector<PairedPhone> phones_;
  std::vector<BluetoothPhone> bluetooth_;
  std::vector<std::string> legacy_dropped_;
  bool writable_ = true;
  int64_t floor_ = 0;                        ///< the newest time the file recorded, at load (Unix s)
  std::optional<int64_t> monotonic_origin_;  ///< time()'s first monotonic reading
};

/// Where the pairing store is kept when `rtukit rehand6600 host` is given no
/// --pairing-file, from two environment values (nullptr: unset):
/// `state_directory` ($STATE_DIRECTORY, systemd's StateDirectory=) set:
/// "<it>/rehand6600-pairing.json"; else `home` ($HOME) set:
/// "<it>/.local/state/rtukit/rehand6600-pairing.json"; else
/// "rehand6600-pairing.json" in the current directory. A set value is used
/// as it is, even empty. Pure: reads no environment, touches no file.
std::string default_pairing_file(const char* state_directory, const char* home);

struct HostDaemonOptions {
  /// The display's listener: loopback only (the kiosk browser on the board);
  /// start() refuses any other address.
  std::string http = "127.0.0.1:8080";
  /// Phone listeners ("0.0.0.0:8443"): TLS only.
  std::vector<std::string> phone;
  std::string pairing_file;  ///< required
  /// The phone listener's certificate and key (PEM). Both empty: created at
  /// first start beside the pairing file (rehand6600-phone.crt/.key, 0600).
  std::string tls_cert, tls_key;
  /// Names phones may use for the chair besides its IP addresses ("chair.local").
  std::vector<std::string> host_names;
  /// What phones open ("https://192.168.4.1:8443"), for the pairing QR code.
  /// Empty: the first phone listener, with this machine's first non-loopback
  /// IPv4 address for 0.0.0.0.
  std::string phone_url;
  std::chrono::seconds pairing_max_age{std::chrono::hours(24 * 30)};  ///< unused this long: forgotten
  std::chrono::seconds auth_timeout{5};  ///< a phone socket that has not authenticated by then is closed
  /// Non-empty: phones are also served over Bluetooth LE on this BlueZ
  /// adapter ("hci0"; docs/rehand6600-ble.md): a GATT service, passkey
  /// pairing shown on the display while "Pair a phone" is open, bonded
  /// phones in the display's phone list.
  std::string ble_adapter;
  rehand6600::HostOptions host;
  bool mph = false;  ///< show speed in mph
  /// One line per security-relevant event (pairing, forgetting, link loss and
  /// recovery, emergency stops, shutdown), without the timestamp. Default: stderr with one.
  std::function<void(const std::string&)> log;
  /// The clock of the pairing code, the limits, the expiry, the controller's
  /// poll and leases (unless `host.clock` is set) and the log's time stamps;
  /// nullptr: the real one. Must outlive the daemon.
  DriverClock* clock = nullptr;
};

class HostDaemon {
 public:
  HostDaemon(std::unique_ptr<io::Link> link, HostDaemonOptions options);
  ~HostDaemon();
  HostDaemon(const HostDaemon&) = delete;
  HostDaemon& operator=(const HostDaemon&) = delete;

  /// Loads the pairing store, makes (or checks) the phone certificate, binds
  /// the listeners, starts the host controller. Errors: invalid_argument (a
  /// display listener that is not loopback, half a certificate pair, an
  /// address that does not parse), the store's, the certificate's or the
  /// listeners', with the reason.
  rtukit::Status start();
  /// Releases every hold, stops the host controller and the server.
  void stop();
  /// Bound ports: the display's first, then the phones'.
  std::vector<uint16_t> ports() const;
  /// "http://127.0.0.1:8080", then "https://..." for each phone listener.
  std::vector<std::string> urls() const;
  /// The phone certificate's SHA-256 fingerprint ("AB:CD:..."), after start().
  std::string fingerprint() const;
  /// The certificate's path, after start() (tests pin it in the browser).
  std::string certificate() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit::programs
