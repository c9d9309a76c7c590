// rtukit io: the terminal and the signals of a command-line program: the
// signals that end a command cleanly, a standard output whose reader has
// gone, a progress line and a live panel on a terminal, a password prompt
// without echo, and the wall clock as people read it.
//
// The CLI (cli/) uses these and holds no OS code of its own. They act on the
// process's standard streams and signal dispositions, which are one per
// process: use them from the main thread of a program (the flags set by the
// signal handlers may be read from any thread).
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <chrono>
#include <ctime>
#include <string>
#include <string_view>

#include "rtukit/base/clock.hpp"
#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit::term {

/// The signals that end a command cleanly, as Ctrl-C does: SIGINT, SIGTERM,
/// SIGHUP (its terminal or session closed) and SIGPIPE when it comes from the
/// command's own standard output or error (`rtukit slave -v | head` after
/// head has ended). A SIGPIPE from anything else (a socket whose peer left,
/// in a library that writes without MSG_NOSIGNAL) ends nothing: the write
/// fails with EPIPE and its code handles that. Servers then return from their
/// loop and clean up (a pty's link removed, state saved).

/// For servers on an Asio loop: `signals` (on `ctx`) gets those signals and
/// stops `ctx` when one arrives. Both must outlive the loop's run. When the
/// output is already broken, `ctx` is stopped at once.
void stop_on_signals(asio::signal_set& signals, asio::io_context& ctx);

/// True once a standard output or error was found broken by a SIGPIPE (or
/// is found broken now): both then write to /dev/null, so the command's last
/// words (statistics) cannot fail, and it exits 0 like any filter whose
/// reader has had enough.
bool output_broken();

/// Called first in main: a SIGPIPE from our own output, at any time, marks
/// it broken (above) and interrupts instead of killing the process. A SIGPIPE
/// from anything else is then ignored.
void catch_broken_output();

/// The same signals for commands that run until interrupted (watch, hold,
/// the daemons with their own threads): while one exists, they set
/// interrupted() instead of killing us; its destructor gives SIGINT, SIGTERM
/// and SIGHUP back their default action. One at a time.
class Interruptible {
 public:
  /// Starts uninterrupted, unless the output is already broken (then
  /// interrupted, by SIGPIPE). `clock` paces sleep() and must outlive this.
  explicit Interruptible(DriverClock& clock = SteadyClock::instance());
  ~Interruptible();
  Interruptible(const Interruptible&) = delete;
  Interruptible& operator=(const Interruptible&) = delete;
  bool interrupted() const;
  /// The signal that interrupted (SIGINT for Ctrl-C), 0 when none did.
  int signal() const;
  /// Sleeps `d` on the clock in steps of at most 20 ms; false when
  /// interrupted (before or meanwhile), true when `d` has passed.
  bool sleep(std::chrono::milliseconds d) const;

 private:
  DriverClock& clock_;
};

/// While it exists, a terminal on stdin hands every key over at once and
/// does not echo it (the keys of a remote control); Ctrl-C still signals.
/// Restored when it goes. Nothing happens when stdin is not a terminal.
class KeysAtOnce {
 public:
  KeysAtOnce();
  ~KeysAtOnce();
  KeysAtOnce(const KeysAtOnce&) = delete;
  KeysAtOnce& operator=(const KeysAtOnce&) = delete;

 private:
  bool changed_ = false;
  unsigned char saved_[64];  ///< the terminal's settings (a termios) before
};

/// Whether standard output / standard input is a terminal.
bool stdout_is_terminal();
bool stdin_is_terminal();

/// One line of progress on stderr, redrawn in place, for the waits that
/// would otherwise be silent (scan, doctor, hold). Only when stderr is a
/// terminal (looked at when made): a pipe or a file gets none of it.
/// Cleared when it goes.
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

/// The live panel of a `watch` command, on stdout, the same for every
/// device: on a terminal it redraws in place (no scrolling), at most 80
/// columns. When a refresh fails the last good panel stays on screen, marked
/// stale with the error and since when; faults are highlighted. Colour only
/// on a terminal and never when NO_COLOR is set (https://no-color.org).
class LivePanel {
 public:
  /// `title`: the device and link ("Inverjet 21 on /dev/ttyUSB0"); `clock`
  /// gives the "updated" and "since" times and must outlive the panel.
  LivePanel(std::string title, unsigned interval_ms, DriverClock& clock = SteadyClock::instance());
  /// Draws a fresh panel (lines of at most 80 columns).
  void show(const std::string& body);
  /// Keeps the last panel, marked stale: "STALE since 14:02:07: no response".
  void stale(std::string_view error);
  /// Whether to colour: stdout is a terminal and NO_COLOR is unset or empty.
  static bool colour();
  /// `text` in bold red when colouring, else as it is.
  static std::string alert(std::string_view text);

 private:
  void draw(std::string_view banner);
  std::string title_;
  unsigned interval_ms_;
  DriverClock& clock_;
  std::string last_body_;
  std::string stale_since_;
};

/// The calendar time of `clock`, broken down in local time or UTC, with its
/// milliseconds (0..999).
struct WallTime {
  std::tm tm{};
  long ms = 0;
};
WallTime wall_time(bool utc, DriverClock& clock = SteadyClock::instance());

/// The wall clock as "14:02:07" (local time).
std::string clock_hms(DriverClock& clock = SteadyClock::instance());

/// One line from stdin without its line end ("\n" or "\r\n"), at most 4096
/// characters; empty at the end of input or on a read error. On a terminal,
/// `prompt` goes to stderr first, the typing is not echoed, and a newline
/// follows on stderr.
std::string read_secret_line(std::string_view prompt);

/// One warning line on stderr when a Modbus TCP listener is reachable from
/// beyond this machine (0.0.0.0, [::] or another address that is not
/// loopback): Modbus has no authentication, so whoever reaches it reads and
/// writes the device. `who` names the listener ("the slave"). Nothing for a
/// serial port, a pty or loopback.
void warn_if_exposed(const io::PortSpec& listen, std::string_view who);

}  // namespace rtukit::term
