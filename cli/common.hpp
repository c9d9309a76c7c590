// rtukit CLI: what every subcommand shares: the link options, number parsing
// (decimal or 0x hex), and turning an Error into one line and an exit code.
#pragma once

#include <CLI/CLI.hpp>
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
#include "rtukit/base/clock.hpp"
#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/profile/verb.hpp"
#include "rtukit/driver/bus_line.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/io/port.hpp"
#include "rtukit/term/terminal.hpp"

namespace rtukit::cli {

// The terminal and the signals (rtukit/term/terminal.hpp: io is the only
// layer that touches the OS), under the names the commands use.
using term::catch_broken_output;
using term::clock_hms;
using term::Interruptible;
using term::LivePanel;
using term::output_broken;
using term::Progress;
using term::stop_on_signals;
using term::warn_if_exposed;

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

/// What each exit code means, for the help and the manual page (one table).
struct ExitCodeText {
  int code;
  std::string_view meaning;
};
inline constexpr ExitCodeText kExitCodes[] = {
    {kOk, "done"},
    {kModbusException, "the device answered a Modbus exception (the line says which and why)"},
    {kUsage, "bad input: an unknown command or option, a value out of range; nothing was sent"},
    {kNoResponse, "no response: a timeout, a bad CRC, an answer that does not fit the request"},
    {kIoError, "I/O error: no such port, not a serial port, permission, connection refused, a file"},
    {kRefused, "refused: another device answers (the handshake), or the device's rules refuse the command"},
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
  unsigned max_per_source = 16;
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

/// One refresh of a device's live view (`rtukit <device> watch`): the device layer's.
using ViewFrame = profile::LiveFrame;

/// Every device's watch: refresh(n) each interval (watch_loop), printed as a
/// JSON document (--json), the live panel on a terminal, else a line. A
/// frame that is not ok keeps the last panel, marked stale since the first
/// failure ("14:02:07 stale since 14:02:05: no response" on a pipe, and
/// "ok": false with "error": {"kind": "no_response", "message", "since"}).
/// `title`: the panel's head ("Inverjet unit 21 on /dev/ttyUSB0").
void watch_view(const WatchOptions& options, bool json, std::string_view device, UnitId unit,
                const std::string& title, const std::function<ViewFrame(unsigned n)>& refresh);

/// A program run from the CLI (the host daemon, the bridge, the panel):
/// `start` it (a refusal is one line: exit 2 for its options, 4 for the
/// rest), `announce` where it is, serve until SIGINT, SIGTERM or SIGHUP,
/// `stop` it.
int serve_until_stopped(std::string_view name, const std::function<rtukit::Status()>& start,
                        const std::function<void()>& announce, const std::function<void()>& stop);
/// The same for a program with start() -> rtukit::Status and stop().
template <class Program>
int serve(Program& program, std::string_view name, const std::function<void()>& announce) {
  return serve_until_stopped(
      name, [&program] { return program.start(); }, announce, [&program] { program.stop(); });
}

/// Bytes as "15 03 00 21" (request logs).
using profile::hex;

/// Where `rtukit bus --name NAME` offers its tap to `rtukit sniff --bus NAME`:
/// term::bus_tap_socket, whose error becomes Failure{kUsage} with its reason.
std::string bus_tap_socket(const std::string& name);

/// A server's -v: each request and its answer on stdout, "rx 15 03 ... -> tx 15 03 ..." or "(silence)".
RequestLog print_requests();

/// Prints the master's counters to stderr (for --stats).
void print_stats(const Master& master);

}  // namespace rtukit::cli
