// A command ends on a signal by returning, never by dying: a server's loop
// stops and it cleans up (a pty's link removed, state saved), a `watch`
// leaves its loop. The handlers below only set flags (and, for SIGPIPE,
// look at our own streams); the program reads the flags.
#include "rtukit/term/terminal.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <utility>

#include "rtukit/io/asio.hpp"

namespace rtukit::term {

namespace {
std::atomic<bool> g_interrupted{false};
volatile std::sig_atomic_t g_stop_signal = 0;
volatile std::sig_atomic_t g_output_broken = 0;

// Called on SIGPIPE, also from a signal handler: only async-signal-safe
// calls (poll, open, dup2, close). A pipe whose reader has gone polls as
// POLLERR on its write end; such a stream is pointed at /dev/null.
bool take_broken_output() {
  bool broken = false;
  for (int fd : {STDOUT_FILENO, STDERR_FILENO}) {
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, 0) != 1 || (p.revents & POLLERR) == 0) continue;
    broken = true;
    if (const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC); null >= 0) {
      ::dup2(null, fd);
      ::close(null);
    }
  }
  if (broken) g_output_broken = 1;
  return broken;
}

void on_stop_signal(int sig) {
  if (sig != SIGPIPE || take_broken_output()) {
    if (g_stop_signal == 0) g_stop_signal = sig;
    g_interrupted = true;
  }
}

constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};

void rearm(asio::signal_set& signals, asio::io_context& ctx) {
  signals.async_wait([&signals, &ctx](const boost::system::error_code& ec, int sig) {
    if (ec) return;
    if (sig == SIGPIPE && !take_broken_output()) return rearm(signals, ctx);
    ctx.stop();
  });
}
}  // namespace

bool output_broken() {
  // Also a write that failed with EPIPE before any handler saw the signal.
  return g_output_broken != 0 || take_broken_output();
}

void catch_broken_output() {
  std::signal(SIGPIPE, on_stop_signal);
}

void stop_on_signals(asio::signal_set& signals, asio::io_context& ctx) {
  for (int sig : kStopSignals) signals.add(sig);
  signals.add(SIGPIPE);  // while the loop runs; catch_broken_output's handler before and after
  // Output broken while starting (`| head -n 1` took the first line): the
  // loop returns at once and the server cleans up.
  if (g_output_broken != 0) ctx.stop();
  rearm(signals, ctx);
}

Interruptible::Interruptible(DriverClock& clock) : clock_(clock) {
  g_interrupted = g_output_broken != 0;
  g_stop_signal = g_output_broken != 0 ? SIGPIPE : 0;
  for (int sig : kStopSignals) std::signal(sig, on_stop_signal);
}

Interruptible::~Interruptible() {
  for (int sig : kStopSignals) std::signal(sig, SIG_DFL);
}

bool Interruptible::interrupted() const {
  return g_interrupted;
}

int Interruptible::signal() const {
  return g_stop_signal;
}

bool Interruptible::sleep(std::chrono::milliseconds d) const {
  // Small steps, so Ctrl-C ends the command at once.
  const auto until = clock_.now() + d;
  while (!g_interrupted && clock_.now() < until)
    clock_.sleep_until(std::min(until, clock_.now() + std::chrono::milliseconds(20)));
  return !g_interrupted;
}

KeysAtOnce::KeysAtOnce() {
  static_assert(sizeof(termios) <= sizeof saved_);
  termios t{};
  if (::isatty(STDIN_FILENO) == 0 || ::tcgetattr(STDIN_FILENO, &t) != 0) return;
  std::memcpy(saved_, &t, sizeof t);
  t.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);  // ISIG stays: Ctrl-C is a signal
  t.c_cc[VMIN] = 1;
  t.c_cc[VTIME] = 0;
  changed_ = ::tcsetattr(STDIN_FILENO, TCSANOW, &t) == 0;
}

KeysAtOnce::~KeysAtOnce() {
  if (!changed_) return;
  termios t{};
  std::memcpy(&t, saved_, sizeof t);
  (void)::tcsetattr(STDIN_FILENO, TCSANOW, &t);
}

bool stdout_is_terminal() {
  return ::isatty(STDOUT_FILENO) != 0;
}

bool stdin_is_terminal() {
  return ::isatty(STDIN_FILENO) != 0;
}

Progress::Progress() : active_(::isatty(STDERR_FILENO) != 0) {}

Progress::~Progress() {
  clear();
}

void Progress::show(std::string_view text) {
  if (!active_) return;
  // Carriage return and erase-line: the line is rewritten, never scrolled.
  fmt::print(stderr, "\r\x1b[K{}", text.substr(0, 79));
  std::fflush(stderr);
  shown_ = true;
}

void Progress::clear() {
  if (!active_ || !shown_) return;
  fmt::print(stderr, "\r\x1b[K");
  std::fflush(stderr);
  shown_ = false;
}

WallTime wall_time(bool utc, DriverClock& clock) {
  const auto now = clock.wall();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  WallTime w;
  // The _r forms: localtime's static buffer is shared with every other caller.
  if (utc)
    ::gmtime_r(&t, &w.tm);
  else
    ::localtime_r(&t, &w.tm);
  w.ms = static_cast<long>(
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000);
  return w;
}

std::string clock_hms(DriverClock& clock) {
  const WallTime w = wall_time(false, clock);
  return fmt::format("{:02}:{:02}:{:02}", w.tm.tm_hour, w.tm.tm_min, w.tm.tm_sec);
}

LivePanel::LivePanel(std::string title, unsigned interval_ms, DriverClock& clock)
    : title_(std::move(title)), interval_ms_(interval_ms), clock_(clock) {}

bool LivePanel::colour() {
  const char* no_color = std::getenv("NO_COLOR");
  return ::isatty(STDOUT_FILENO) && (no_color == nullptr || *no_color == '\0');
}

std::string LivePanel::alert(std::string_view text) {
  return colour() ? fmt::format("\x1b[1;31m{}\x1b[0m", text) : std::string(text);
}

void LivePanel::show(const std::string& body) {
  last_body_ = body;
  stale_since_.clear();
  draw({});
}

void LivePanel::stale(std::string_view error) {
  if (stale_since_.empty()) stale_since_ = clock_hms(clock_);
  draw(alert(fmt::format("STALE since {}: {}", stale_since_, error)));
}

void LivePanel::draw(std::string_view banner) {
  // Home and clear, then the whole panel at once: no scrolling, no flicker of half panels.
  std::string out = "\x1b[H\x1b[2J";
  out += fmt::format("{}\n(every {} ms, Ctrl-C to stop; updated {})\n\n", title_.substr(0, 80), interval_ms_,
                     clock_hms(clock_));
  if (!banner.empty()) out += fmt::format("{}\n\n", banner);
  out += last_body_.empty() ? std::string("(no data yet)\n") : last_body_;
  fmt::print("{}", out);
  std::fflush(stdout);
}

std::string read_secret_line(std::string_view prompt) {
  // Byte by byte with read(2), not through stdin's buffer: nothing past the
  // line is taken from a pipe, so a second line ("Again: ") is still there.
  const bool tty = ::isatty(STDIN_FILENO) != 0;
  termios old{};
  if (tty) {
    fmt::print(stderr, "{}", prompt);
    std::fflush(stderr);
    ::tcgetattr(STDIN_FILENO, &old);
    termios quiet = old;
    quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
    ::tcsetattr(STDIN_FILENO, TCSAFLUSH, &quiet);
  }
  std::string line;
  char c = 0;
  while (line.size() < 4096) {
    const ssize_t n = ::read(STDIN_FILENO, &c, 1);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0 || c == '\n') break;
    line += c;
  }
  if (tty) {
    ::tcsetattr(STDIN_FILENO, TCSAFLUSH, &old);
    fmt::print(stderr, "\n");
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

void warn_if_exposed(const io::PortSpec& listen, std::string_view who) {
  const std::string exposure = io::listener_exposure(listen);
  if (exposure.empty()) return;
  fmt::print(stderr,
             "warning: {} listens on {} ({}): Modbus has no passwords, so anyone who can reach it reads and "
             "writes the device; listen on tcp://127.0.0.1:PORT unless that is what you want\n",
             who, exposure, listen.describe());
}

}  // namespace rtukit::term
