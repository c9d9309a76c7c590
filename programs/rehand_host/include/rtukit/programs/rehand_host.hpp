// The Rehand 6600 host daemon, the program that runs on the RK3588: it owns
// the UART (the host controller, rehand6600/host.hpp), serves the touch HMI
// and the phone remote (web/assets/rehand/) and their JSON API over HTTP and
// WebSocket (docs/rehand6600.md, "The host daemon").
//
// Who may do what:
//  - the display: WebSocket /ws?role=display on the --http listener (loopback
//    by default: the kiosk browser on the same board). Everything but phone
//    driving; it shows the pairing code and can revoke a phone.
//  - a phone: /ws?role=phone&token=T on any listener. Without a valid token
//    it may only pair (a one-time code the display shows); with one it sees
//    the state and may drive under the seed's phone rules (dead-man, one
//    driver at a time, lease 300 ms), horn, light and turn signals.
//
// Every command is answered on its own connection ({"type":"result"}); a
// refused one changes nothing. The poll loop and the leases run on the
// host controller's thread and never wait for a client.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::programs {

/// Paired phones, in a JSON file written atomically (a temporary file
/// created exclusively beside it, fsync, rename), mode 0600. A file that is
/// not ours (not a regular file, too large, another program's JSON) is never
/// overwritten: load() says why.
class PairingStore {
 public:
  explicit PairingStore(std::string path) : path_(std::move(path)) {}
  /// Reads the file; a missing file is an empty store. Errors: io_error /
  /// invalid_argument with the reason (the store is then read-only).
  rtukit::Status load();
  /// A new 128-bit token for `name`, saved before it is returned. Errors:
  /// the save's, with the reason.
  rtukit::Outcome<std::string> add(std::string name);
  bool contains(const std::string& token) const;
  std::string name_of(const std::string& token) const;
  rtukit::Status remove(const std::string& token);
  size_t size() const noexcept { return phones_.size(); }
  const std::string& path() const noexcept { return path_; }

 private:
  rtukit::Status save() const;
  struct Phone {
    std::string token, name, paired_at;
  };
  std::string path_;
  std::vector<Phone> phones_;
  bool writable_ = true;
};

struct HostDaemonOptions {
  std::string http = "127.0.0.1:8080";  ///< the display's listener
  std::vector<std::string> phone;       ///< phone listeners ("0.0.0.0:8443")
  std::string pairing_file;             ///< required
  /// What phones open ("http://192.168.4.1:8443"), for the pairing QR code.
  /// Empty: the first phone listener, with this machine's first non-loopback
  /// IPv4 address for 0.0.0.0.
  std::string phone_url;
  rehand6600::HostOptions host;
  bool mph = false;  ///< show speed in mph
};

class HostDaemon {
 public:
  HostDaemon(std::unique_ptr<io::Link> link, HostDaemonOptions options);
  ~HostDaemon();
  HostDaemon(const HostDaemon&) = delete;
  HostDaemon& operator=(const HostDaemon&) = delete;

  /// Loads the pairing store, binds the listeners, starts the host
  /// controller. Errors: the store's or the listeners', with the reason.
  rtukit::Status start();
  /// Releases every hold, stops the host controller and the server.
  void stop();
  /// Bound ports: the display's first, then the phones'.
  std::vector<uint16_t> ports() const;
  /// "http://127.0.0.1:8080" for each listener.
  std::vector<std::string> urls() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit::programs
