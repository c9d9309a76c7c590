// rtukit CLI: what every subcommand shares: the link options, number parsing
// (decimal or 0x hex), and turning an Error into one line and an exit code.
#pragma once

#include <CLI/CLI.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "commands.hpp"
#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/driver/bus_line.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/io/clock.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit::cli {

/// The CLI's clock: the real one (the commands are the outermost layer; what
/// they call below takes a clock of its own).
inline DriverClock& time_source() {
  return SteadyClock::instance();
}

/// Exit codes (documented in README.md).
enum Exit : int {
  kOk = 0,
  kModbusException = 1,
  kUsage = 2,
  kNoResponse = 3,
  kIoError = 4,
  kRefused = 5,  ///< the device is not the expected one (handshake) or its rules refuse the command
};

/// Thrown inside a subcommand to leave with a message and an exit code;
/// caught once in main(). (Exceptions are fine here; the core has none.)
struct Failure {
  int code;
  std::string message;
};

/// --port and the serial settings, shared by every command that talks to a device.
struct LinkOptions {
  std::string port;
  uint32_t baud = 9600;
  std::string parity = "N";
  unsigned data_bits = 8;
  unsigned stop_bits = 1;
  bool rs485 = false;
  unsigned rs485_before_us = 0;
  unsigned rs485_after_us = 0;
  unsigned timeout_ms = 1000;
  unsigned retries = 0;
  unsigned delay_ms = 0;
  bool echo = false;
  bool stats = false;
  std::vector<std::string> quirks;  ///< fc10-no-count, fc03-two-byte-count
  bool trace = false;               ///< each frame to stderr with a timestamp
  std::string log_file;             ///< each frame appended to this file

  /// Adds the options to `cmd`. `listening`: the port is where we listen.
  void add_to(CLI::App& cmd, bool listening, uint32_t default_baud = 9600);
  /// The parsed port spec; throws Failure{kUsage} with the reason.
  io::PortSpec spec(bool listening) const;
  MasterOptions master_options() const;
  /// The --quirk options as FrameQuirks (RTU links only).
  FrameQuirks frame_quirks() const;
  /// The --trace / --log callback (empty when neither is given). Throws
  /// Failure{kIoError} when the log file cannot be opened.
  std::function<void(const TraceEvent&)> tracer() const;
  /// A master on the port (not opened yet).
  std::unique_ptr<Master> make_master() const;
};

/// The protections of a listening command (slave, sim): connection limit,
/// idle timeout, the answer's turnaround on serial lines.
struct ServerArgs {
  unsigned max_connections = 64;
  unsigned idle_timeout_s = 60;
  double turnaround_ms = -1;  ///< < 0: the default (t3.5 on serial ports, none on ptys)
  /// `serial`: the command may listen on a serial line (--turnaround-ms means something).
  void add_to(CLI::App& cmd, bool serial = true);
  ServerOptions options() const;
};

/// "none", "even", "odd" or N/E/O in any case -> 'N', 'E', 'O'. Throws Failure{kUsage}.
char parity_letter(std::string_view text);

/// Parses "33" or "0x21" (also negative decimals when `allow_negative`).
/// Throws Failure{kUsage} naming `what` when it is not a number in range.
int64_t parse_number(std::string_view text, std::string_view what, int64_t min, int64_t max);

/// Unit option value -> UnitId. RTU links take the standard 0..247 (0 =
/// broadcast, modbus-rtu.md); Modbus TCP takes 0..255 (0xFF addresses a TCP
/// device directly). Throws Failure{kUsage} outside the range.
UnitId parse_unit(const std::string& text, bool tcp = false);

/// A device's unit address from --unit: empty -> its factory address; else
/// one of the addresses its link-address row (or Profile::link) allows.
/// Throws Failure{kUsage}: "unit 250 is out of range 1..247 (rehand6600)".
UnitId device_unit(const std::string& text, const profile::Profile& p);
/// "Inverjet counter-current swimming machine (unit 21, 9600 8N1 by default)".
std::string device_title(const profile::Profile& p);
/// The help of a device's --unit: "the device's address, 1..254 (default 21)".
std::string device_unit_help(const profile::Profile& p);

/// "1-247", "21", "1,5,21-30" -> the units in order, each once (1..max).
/// Throws Failure{kUsage} naming the bad item.
std::vector<unsigned> parse_units(const std::string& text, unsigned max);

/// Maps an Error to its exit code.
int exit_code(Error e);
/// Throws Failure with one clear line: what failed, on which port/unit.
[[noreturn]] void fail(Error e, std::string_view context);

/// One warning line on stderr when a Modbus TCP listener is reachable from
/// beyond this machine (0.0.0.0, [::] or another address that is not
/// loopback): Modbus has no authentication, so whoever reaches it reads and
/// writes the device. Nothing for a serial port, a pty or loopback.
void warn_if_exposed(const io::PortSpec& listen, std::string_view who);

/// The signals that end a command cleanly, as Ctrl-C does: SIGINT, SIGTERM,
/// SIGHUP (its terminal or session closed) and SIGPIPE when it comes from the
/// command's own standard output or error (`rtukit slave -v | head` after
/// head has ended). A SIGPIPE from anything else (a socket whose peer left,
/// in a library that writes without MSG_NOSIGNAL) ends nothing: the write
/// fails with EPIPE and its code handles that. Servers then return from their
/// loop and clean up (a pty's link removed, state saved).

/// For servers on an Asio loop: `signals` is armed and stops `ctx` on one of
/// those signals.
void stop_on_signals(asio::signal_set& signals, asio::io_context& ctx);

/// True once a standard output or error was found broken by a SIGPIPE: both
/// then write to /dev/null, so the command's last words (statistics) cannot
/// fail, and it exits 0 like any filter whose reader has had enough.
bool output_broken();

/// Called first in main: a SIGPIPE from our own output, at any time, marks
/// it broken (above) and interrupts instead of killing the process.
void catch_broken_output();

/// The same signals for commands that run until interrupted (watch, hold,
/// the daemons with their own threads): while one exists, they set
/// interrupted() instead of killing us.
class Interruptible {
 public:
  Interruptible();
  ~Interruptible();
  Interruptible(const Interruptible&) = delete;
  Interruptible& operator=(const Interruptible&) = delete;
  bool interrupted() const;
  /// The signal that interrupted (SIGINT for Ctrl-C), 0 when none did.
  int signal() const;
  /// Sleeps `d` in small steps; false when interrupted meanwhile.
  bool sleep(std::chrono::milliseconds d) const;
};

/// One line of progress on stderr, redrawn in place, for the waits that
/// would otherwise be silent (scan, doctor, hold). Only when stderr is a
/// terminal: a pipe or a file gets none of it. Cleared when it goes.
class Progress {
 public:
  Progress();
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  /// Whether anything is shown (stderr is a terminal).
  bool active() const { return active_; }
  /// Replaces the line with `text` (cut to 79 columns).
  void show(std::string_view text);
  /// Removes the line (before printing something else on the terminal).
  void clear();

 private:
  bool active_;
  bool shown_ = false;
};

/// --interval and --count of a `watch` command.
struct WatchOptions {
  unsigned interval_ms;
  unsigned count = 0;
  void add_to(CLI::App& cmd);
};

/// Calls refresh(n) for n = 0, 1, ... `interval_ms` apart, until Ctrl-C or
/// `count` refreshes (0 = no limit).
void watch_loop(const WatchOptions& options, const std::function<void(unsigned n)>& refresh);

/// Registers the subcommand `name` of `parent`: `setup(cmd, args)` declares
/// its options into a fresh `Args`; when the user picks it, `run(args)`
/// becomes the action (returning the exit code). Every command is made this
/// way, so options live in one struct per command and nothing else repeats.
template <class Args, class Setup, class Run>
CLI::App* add_command(CLI::App& parent, Action& action, const std::string& name,
                      const std::string& description, Setup setup, Run run) {
  auto args = std::make_shared<Args>();
  CLI::App* cmd = parent.add_subcommand(name, description);
  setup(*cmd, *args);
  // `run(args, cmd)` when it wants to ask what was given on the command line.
  if constexpr (std::is_invocable_v<Run, Args&, const CLI::App&>)
    cmd->callback([&action, args, run, cmd] { action = [args, run, cmd] { return run(*args, *cmd); }; });
  else
    cmd->callback([&action, args, run] { action = [args, run] { return run(*args); }; });
  return cmd;
}

/// Sets the "Examples:" footer of a command's --help (one command a line).
void examples(CLI::App& cmd, std::initializer_list<std::string_view> lines);
void examples(CLI::App& cmd, std::span<const std::string_view> lines);

/// rtukit's JSON documents (docs/json.md): objects keep their key order.
using Json = nlohmann::ordered_json;

/// The head every JSON document starts with: {"time": UTC ISO 8601 with ms,
/// "ok": true, "device": name (absent when empty), "unit": n (absent when < 0)}.
Json json_document(std::string_view device = {}, int unit = -1);
/// A derived value with a unit, shaped like a register entry: {"value", "unit", "text"}.
using profile::quantity_json;
/// Prints one document on one line.
void print_json(const Json& document);
/// True when the command line asked for --json (set by main()): a failure is
/// then also printed on stdout as {"time", "ok": false, "error": {...}}.
bool& json_requested();
/// {"time", "ok": false, "error": {"exit": 3, "kind": "no_response", "message": "..."}}.
Json json_failure(const Failure& f);

/// The live panel of a `watch` command, the same for every device: on a
/// terminal it redraws in place (no scrolling), at most 80 columns. When a
/// refresh fails the last good panel stays on screen, marked stale with the
/// error and since when; faults are highlighted. Colour only on a terminal
/// and never when NO_COLOR is set (https://no-color.org).
class LivePanel {
 public:
  /// `title`: the device and link ("Inverjet 21 on /dev/ttyUSB0").
  LivePanel(std::string title, unsigned interval_ms);
  /// Draws a fresh panel (lines of at most 80 columns).
  void show(const std::string& body);
  /// Keeps the last panel, marked stale: "STALE since 14:02:07: no response".
  void stale(std::string_view error);
  /// Whether to colour: stdout is a terminal and NO_COLOR is unset.
  static bool colour();
  /// `text` in bold red when colouring, else as it is.
  static std::string alert(std::string_view text);

 private:
  void draw(std::string_view banner);
  std::string title_;
  unsigned interval_ms_;
  std::string last_body_;
  std::string stale_since_;
};

/// The wall clock as "14:02:07" (local time).
std::string clock_hms();

/// Bytes as "15 03 00 21" (request logs).
using profile::hex;

/// The bus tap format (docs/bus-tools.md), one character a line:
/// "start_us end_us sender sent heard [flags]", sender -1 for a stray byte,
/// flags c (collision) and d (dropped). Lines starting with '#' are comments;
/// the first is the header (io::tap_header, rtukit/io/tap_client.hpp).
std::string tap_line(const BusCharacter& c);
/// One tap line read back; nullopt for a comment or a line that is not one.
std::optional<BusCharacter> parse_tap_line(const std::string& line);

/// Where `rtukit bus --name NAME` offers its tap to `rtukit sniff --bus NAME`:
/// $XDG_RUNTIME_DIR/rtukit/bus-NAME.sock, else /tmp/rtukit-UID/bus-NAME.sock.
/// Throws Failure{kUsage} unless the name is 1..64 letters, digits, '-', '_'.
std::string bus_tap_socket(const std::string& name);

/// Prints the master's counters to stderr (for --stats).
void print_stats(const Master& master);

}  // namespace rtukit::cli
