// The Inverjet pool panel (`rtukit inverjet panel`): a web page for the
// swimmer's phone or tablet (web/assets/inverjet/), served with its JSON API
// over HTTP and WebSocket by the shared web layer (web/server.hpp).
//
// One bus thread owns the machine: it runs PanelLogic (below), which polls
// (2 Hz), runs the pages' commands in arrival order through the same command
// runner as the MQTT bridge (inverjet::run_command: the verbs every front-end
// runs), keeps the run's history for the charts, and hands its messages to
// the web thread. A page never waits for the bus and never slows the polling.
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

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/link.hpp"

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

/// The shortest panel password, in characters (Unicode code points).
inline constexpr size_t kMinPasswordCharacters = 8;
/// Characters in `password`, taken as UTF-8: code points, not bytes ("école"
/// is 5). Bytes that are not UTF-8 count one each, continuation bytes none.
size_t password_characters(std::string_view password) noexcept;
/// Whether `password` may become the panel's: at least kMinPasswordCharacters
/// characters. Errors: invalid_argument "the password has 5 characters: at
/// least 8, please".
rtukit::Status check_new_password(std::string_view password);
/// Whether a new password file may go to `path`: with `force` always; else
/// only where nothing exists (no file, no directory, not even a symlink,
/// dangling or not). Errors: refused "PATH exists: not replaced (--force
/// replaces it)".
rtukit::Status check_password_file_path(const std::string& path, bool force);
/// Writes the panel's password file for `password` (make_password_record)
/// to `path`, mode 0600 (less what the umask takes). Checks first, writing
/// nothing when refused: check_new_password, check_password_file_path.
/// Without `force` the file is created exclusively (O_EXCL, never through a
/// symlink), so a file that appears meanwhile is refused too; it is flushed
/// (fsync), and a failed write removes it: no half file is left. With
/// `force` an existing file is replaced atomically (io::write_file_atomically):
/// a failure leaves the old file whole. Errors: invalid_argument and refused
/// as above; io_error "PATH: No such file or directory", "PATH: cannot
/// write", make_password_record's (no path).
rtukit::Status write_password_file(const std::string& path, std::string_view password, bool force);

/// Commands from the pages waiting for the bus; more are refused ("busy").
inline constexpr size_t kPanelCommandLimit = 16;
/// Samples kept for the charts: two hours at 2 Hz (the oldest goes first).
inline constexpr size_t kPanelHistory = 2 * 60 * 60 * 2;

/// One message for the pages (its JSON text), numbered in the order the
/// logic made it.
struct PanelMessage {
  uint64_t to = 0;  ///< the page's socket id (a command's result); 0: every page
  std::string text;
  uint64_t seq = 0;  ///< 1, 2, ...: what welcome() covers is up to its seq
};
/// Where the logic's messages go: the web thread, or a test's list.
using PanelSend = std::function<void(const PanelMessage&)>;

/// The panel's logic, without the web server and without a thread: the
/// polls on the shared schedule (driver/poll_schedule.hpp: `poll_hz`, the
/// back-off, offline after two failed polls), the pages' commands (at most
/// kPanelCommandLimit waiting), the run's history and the machine's plans.
/// The Panel runs it on a BusWorker and carries its messages to the pages;
/// tests run it on a ManualClock and a MemoryLink, step by step.
///
/// What it sends (the JSON in the Panel's comment above):
///  - "state" when the state document changes (each answer has a new
///    "last_contact_ms": in practice every poll), with "online": true;
///    once the machine counts as offline, the last state with "online":
///    false (also when it never answered), once per outage.
///  - "sample" each poll while a run is on (starting, running, paused; the
///    "speed" is 0 unless running), kept in the history (kPanelHistory at
///    most; kept after the run ends); a new run empties the history and
///    sends the empty "history" first.
///  - "plans" (the four plans as the machine stores them) after its first
///    answer ever, after the "plans" command and after a "plan" it took.
///  - "result" for each command, to its page only, with the page's "id";
///    when it failed, "error", "code" and "advice" (inverjet::describe_failure).
///    A command's effect is polled at once.
/// Commands run at the next step, before its poll, in the order queued,
/// through inverjet::run_command (which refuses a bad one before it writes).
/// A command that finds kPanelCommandLimit waiting is refused at once
/// ("busy") and never runs.
/// step() runs on one thread; queue_command() and welcome() on any. `send`
/// is called on step()'s thread, and on queue_command()'s for "busy".
class PanelLogic {
 public:
  /// `master`, `options` and `clock` must outlive the logic.
  PanelLogic(Master& master, const PanelOptions& options, DriverClock& clock, PanelSend send);
  ~PanelLogic();
  PanelLogic(const PanelLogic&) = delete;
  PanelLogic& operator=(const PanelLogic&) = delete;

  /// A page's command (a JSON object with a string "op"; "id" optional),
  /// run at the next step. Returns false when refused, with the answer sent
  /// to `socket` at once: "busy", or an "error" for a message with no "op".
  bool queue_command(uint64_t socket, nlohmann::json command);
  /// What a page that connects now is sent first: the last state (if any),
  /// the history, the plans (once read), then the machine's "limits"
  /// (inverjet::limits_document). `seq` is set to the last message
  /// these include: the later ones (seq > it) are the page's to receive.
  std::vector<std::string> welcome(uint64_t& seq) const;
  /// Runs the commands queued, then the poll if it is due at `now` (or a
  /// command asked for it). Returns when the next poll is due.
  Clock::time_point step(Clock::time_point now);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

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
