// The Inverjet pool panel (`rtukit inverjet panel`): a web page for the
// swimmer's phone or tablet (web/assets/inverjet/), served with its JSON API
// over HTTP and WebSocket by the shared web layer (web/server.hpp).
//
// One bus thread owns the machine: it polls (2 Hz), runs the pages' commands
// in arrival order through the same command runner as the MQTT bridge
// (inverjet::run_command: the verbs every front-end runs), keeps the run's history for
// the charts, and posts the results to the web thread. A page never waits
// for the bus and never slows the polling.
//
// WebSocket /ws. Server -> page: {"type":"state", ...inverjet::state_document...,
// "online"}, {"type":"sample","t","speed","current_a","mosfet_c","motor_c"},
// {"type":"history","samples":[...]}, {"type":"plans","plans":[[{speed,end}]x4]},
// {"type":"result","id","op","ok","error"}. Page -> server: {"op": start |
// pause | resume | stop | speed | plan | plans, "id", ...} (docs/inverjet.md).
//
// Who may use it: the shared web layer's Origin and Host checks and budgets
// on every request. On an address that is not loopback the panel starts only
// with a password file and TLS; with a password file (on any address) every
// page, file and the WebSocket need the session cookie that POST /login
// gives (docs/inverjet.md, "Pool panel").
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/io/clock.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::programs {

struct PanelOptions {
  uint8_t unit = inverjet::kDefaultAddress;
  std::string http = "127.0.0.1:8081";
  double poll_hz = 2;
  unsigned response_timeout_ms = 300;
  std::vector<std::string> host_names;  ///< DNS names allowed in Host ("pool.local"), besides IP literals
  std::string password_file;            ///< a password record (make_password_record); required off loopback
  std::string tls_cert, tls_key;        ///< PEM files, both or neither; required off loopback
  /// One line per login, wrong password, lockout, logout (with the time). Default: stderr.
  std::function<void(const std::string&)> log;
  /// The clock of the poll schedule, the sessions, the login limits and the
  /// time stamps; nullptr: the real one. Must outlive the panel.
  DriverClock* clock = nullptr;
};

/// The panel's password file: one line
///   `rtukit-panel-password pbkdf2-sha256 ITERATIONS SALT_HEX KEY_HEX`
/// PBKDF2-HMAC-SHA256 over the password with a random 16-byte salt
/// (getrandom), ITERATIONS (200000) rounds, a 32-byte key. Errors: io_error
/// (no random bytes; OpenSSL).
rtukit::Outcome<std::string> make_password_record(std::string_view password, unsigned iterations = 200000);
/// Whether `password` matches `record` (the derived keys compared in
/// constant time). Errors: malformed (not a record).
rtukit::Outcome<bool> check_password(std::string_view record, std::string_view password);
/// Loads a password file and checks its format. Errors: the file's, malformed.
rtukit::Outcome<std::string> load_password_record(const std::string& path);

class Panel {
 public:
  Panel(std::unique_ptr<io::Link> link, PanelOptions options);
  ~Panel();
  Panel(const Panel&) = delete;
  Panel& operator=(const Panel&) = delete;

  /// Binds the listener, starts the bus thread. Errors: invalid_argument
  /// (an address that is not loopback without a password file or without
  /// TLS; only one of the TLS files), the password file's, the listener's.
  rtukit::Status start();
  void stop();
  std::string url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit::programs
