// The CLI's terminal and signal plumbing (rtukit/term/terminal.hpp), in one
// process: a stop signal sets the flags and ends a wait, a SIGPIPE only
// counts when our own output is broken, and the progress line, the live
// panel and the password prompt write exactly their bytes, to a pipe (no
// terminal) or to a pseudo-terminal (a terminal). Sleeps are on a
// ManualClock; the standard streams are redirected and put back by each test.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <optional>
#include <string>
#include <thread>

#include "rtukit/base/clock.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/io/port.hpp"
#include "rtukit/term/terminal.hpp"

namespace rtukit::term {
namespace {

using namespace rtukit::io;  // the transports they run on

using namespace std::chrono_literals;

// Points `target` (0, 1 or 2) at `replacement` until destroyed; the C
// streams are flushed on the way in and out.
class Redirect {
 public:
  Redirect(int target, int replacement) : target_(target), saved_(::dup(target)) {
    std::fflush(nullptr);
    ::dup2(replacement, target);
  }
  ~Redirect() {
    std::fflush(nullptr);
    ::dup2(saved_, target_);
    ::close(saved_);
  }
  Redirect(const Redirect&) = delete;
  Redirect& operator=(const Redirect&) = delete;

 private:
  int target_;
  int saved_;
};

// Everything readable on `fd` now (waits at most 1 s for the first byte).
std::string drain(int fd, int first_wait_ms = 1000) {
  std::string out;
  int wait = first_wait_ms;
  for (;;) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, wait) != 1 || (p.revents & POLLIN) == 0) return out;
    char buffer[4096];
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n <= 0) return out;
    out.append(buffer, static_cast<size_t>(n));
    wait = 0;
  }
}

struct Pipe {
  Pipe() { EXPECT_EQ(::pipe2(fd, O_CLOEXEC), 0); }
  ~Pipe() {
    for (int f : fd)
      if (f >= 0) ::close(f);
  }
  void close_write() {
    ::close(fd[1]);
    fd[1] = -1;
  }
  int fd[2] = {-1, -1};
};

// A pseudo-terminal: what the program sees as its terminal (slave) and the
// other end, where a terminal emulator would be (master).
struct Pty {
  Pty() {
    master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    EXPECT_GE(master, 0);
    EXPECT_EQ(::grantpt(master), 0);
    EXPECT_EQ(::unlockpt(master), 0);
    slave = ::open(::ptsname(master), O_RDWR | O_NOCTTY | O_CLOEXEC);
    EXPECT_GE(slave, 0);
  }
  ~Pty() {
    ::close(slave);
    ::close(master);
  }
  int master = -1;
  int slave = -1;
};

// Sets (or unsets, with nullopt) an environment variable until destroyed.
class Env {
 public:
  Env(const char* name, std::optional<std::string> value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value)
      ::setenv(name, value->c_str(), 1);
    else
      ::unsetenv(name);
  }
  ~Env() {
    if (old_)
      ::setenv(name_, old_->c_str(), 1);
    else
      ::unsetenv(name_);
  }
  Env(const Env&) = delete;
  Env& operator=(const Env&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

// Local time is UTC until destroyed.
class UtcZone {
 public:
  UtcZone() {
    if (const char* old = std::getenv("TZ")) old_ = old;
    ::setenv("TZ", "UTC", 1);
    ::tzset();
  }
  ~UtcZone() {
    if (old_)
      ::setenv("TZ", old_->c_str(), 1);
    else
      ::unsetenv("TZ");
    ::tzset();
  }
  UtcZone(const UtcZone&) = delete;
  UtcZone& operator=(const UtcZone&) = delete;

 private:
  std::optional<std::string> old_;
};

// Puts a signal's disposition back as it was.
class KeepSignal {
 public:
  explicit KeepSignal(int sig) : sig_(sig) { ::sigaction(sig, nullptr, &old_); }
  ~KeepSignal() { ::sigaction(sig_, &old_, nullptr); }
  KeepSignal(const KeepSignal&) = delete;
  KeepSignal& operator=(const KeepSignal&) = delete;

 private:
  int sig_;
  struct sigaction old_ {};
};

void (*handler_of(int sig))(int) {
  struct sigaction sa {};
  ::sigaction(sig, nullptr, &sa);
  return sa.sa_handler;
}

TEST(Interruptible, SleepsOnItsClockUntilInterrupted) {
  KeepSignal keep(SIGINT);
  ManualClock clock;
  const auto start = clock.now();
  {
    const Interruptible interrupt(clock);
    EXPECT_FALSE(interrupt.interrupted());
    EXPECT_EQ(interrupt.signal(), 0);
    EXPECT_NE(handler_of(SIGINT), SIG_DFL);  // Ctrl-C sets a flag now
    EXPECT_TRUE(interrupt.sleep(1h));        // virtual time: no real wait
    EXPECT_GE(clock.now() - start, 1h);
  }
  EXPECT_EQ(handler_of(SIGINT), SIG_DFL);  // given back when it goes
}

TEST(Interruptible, ASignalEndsTheSleepAndIsRemembered) {
  KeepSignal keep_int(SIGINT), keep_term(SIGTERM);
  ManualClock clock;
  {
    const Interruptible interrupt(clock);
    ASSERT_EQ(std::raise(SIGINT), 0);  // the process lives on
    EXPECT_TRUE(interrupt.interrupted());
    EXPECT_EQ(interrupt.signal(), SIGINT);
    const auto before = clock.now();
    EXPECT_FALSE(interrupt.sleep(1h));
    EXPECT_EQ(clock.now(), before);  // returned at once
    ASSERT_EQ(std::raise(SIGTERM), 0);
    EXPECT_EQ(interrupt.signal(), SIGINT);  // the first signal is the one reported
  }
  const Interruptible again(clock);  // a new one starts clean
  EXPECT_FALSE(again.interrupted());
  EXPECT_EQ(again.signal(), 0);
}

TEST(BrokenOutput, AHealthyOutputIsNotBrokenAndItsSigpipeEndsNothing) {
  KeepSignal keep_pipe(SIGPIPE), keep_int(SIGINT);
  ManualClock clock;
  catch_broken_output();
  EXPECT_NE(handler_of(SIGPIPE), SIG_DFL);
  const Interruptible interrupt(clock);
  EXPECT_FALSE(output_broken());
  // A SIGPIPE from elsewhere (a socket whose peer left): not ours, so no stop.
  ASSERT_EQ(std::raise(SIGPIPE), 0);
  EXPECT_FALSE(interrupt.interrupted());
  EXPECT_EQ(interrupt.signal(), 0);
  EXPECT_FALSE(output_broken());
}

// Run in a child: breaks its own stdout for good. 0 when everything held.
int break_stdout_and_check() {
  catch_broken_output();
  int fd[2];
  if (::pipe(fd) != 0) return 10;
  ::close(fd[0]);  // the reader has gone (`| head` after its lines)
  ::dup2(fd[1], STDOUT_FILENO);
  const Interruptible interrupt;
  if (::write(STDOUT_FILENO, "x", 1) != -1) return 11;  // EPIPE, and the SIGPIPE handled
  if (!output_broken()) return 12;
  if (!interrupt.interrupted() || interrupt.signal() != SIGPIPE) return 13;
  if (::write(STDOUT_FILENO, "x", 1) != 1) return 14;  // now /dev/null: writes succeed
  const Interruptible later;                           // made after the break: interrupted from the start
  if (!later.interrupted() || later.signal() != SIGPIPE) return 15;
  return 0;
}

TEST(BrokenOutput, AStdoutWhoseReaderLeftIsBrokenAndInterrupts) {
  EXPECT_EXIT(std::_Exit(break_stdout_and_check()), ::testing::ExitedWithCode(0), "");
}

TEST(StopOnSignals, ATerminationSignalStopsTheLoop) {
  KeepSignal keep(SIGTERM);
  asio::io_context ctx;
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
  asio::post(ctx, [] { std::raise(SIGTERM); });
  ctx.run();  // would run forever (the signal set waits) unless stopped
  EXPECT_TRUE(ctx.stopped());
}

TEST(StopOnSignals, ASigpipeFromElsewhereDoesNotStopTheLoop) {
  KeepSignal keep_pipe(SIGPIPE), keep_hup(SIGHUP);
  asio::io_context ctx;
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
  bool hup_raised = false;
  asio::steady_timer later(ctx);
  asio::post(ctx, [&] {
    std::raise(SIGPIPE);  // our output is healthy: the loop goes on
    later.expires_after(50ms);
    later.async_wait([&](const boost::system::error_code&) {
      hup_raised = true;
      std::raise(SIGHUP);
    });
  });
  ctx.run();
  EXPECT_TRUE(hup_raised);  // it was SIGHUP that stopped it, not SIGPIPE
  EXPECT_TRUE(ctx.stopped());
}

TEST(Progress, NothingWhenStderrIsNoTerminal) {
  Pipe pipe;
  {
    const Redirect to_pipe(STDERR_FILENO, pipe.fd[1]);
    Progress progress;
    EXPECT_FALSE(progress.active());
    progress.show("scanning unit 5");
    progress.clear();
    progress.show("scanning unit 6");
  }
  pipe.close_write();
  EXPECT_EQ(drain(pipe.fd[0]), "");
}

TEST(Progress, OneLineRedrawnInPlaceOnATerminal) {
  Pty pty;
  std::string shown;
  {
    const Redirect to_terminal(STDERR_FILENO, pty.slave);
    Progress progress;
    EXPECT_TRUE(progress.active());
    progress.show(std::string(100, 'a'));  // cut to 79 columns
    shown = drain(pty.master);
    progress.clear();
    progress.clear();  // twice: nothing more
    progress.show("b");
  }  // cleared as it goes
  EXPECT_EQ(shown, "\r\x1b[K" + std::string(79, 'a'));
  EXPECT_EQ(drain(pty.master), "\r\x1b[K\r\x1b[Kb\r\x1b[K");
}

TEST(LivePanel, AlertIsPlainWhenNoColorIsSet) {
  Pty pty;
  bool with_no_color = true, with_empty = false, unset = false;
  std::string plain, red;
  {
    const Redirect to_terminal(STDOUT_FILENO, pty.slave);
    {
      const Env no_color("NO_COLOR", "1");
      with_no_color = LivePanel::colour();
      plain = LivePanel::alert("FAULT");
    }
    {
      const Env empty("NO_COLOR", "");  // set but empty: as if unset (no-color.org)
      with_empty = LivePanel::colour();
    }
    const Env none("NO_COLOR", std::nullopt);
    unset = LivePanel::colour();
    red = LivePanel::alert("FAULT");
  }
  EXPECT_FALSE(with_no_color);
  EXPECT_EQ(plain, "FAULT");
  EXPECT_TRUE(with_empty);
  EXPECT_TRUE(unset);
  EXPECT_EQ(red, "\x1b[1;31mFAULT\x1b[0m");
}

TEST(LivePanel, AlertIsPlainWhenStdoutIsNoTerminal) {
  Pipe pipe;
  bool colour = true;
  std::string alert;
  {
    const Redirect to_pipe(STDOUT_FILENO, pipe.fd[1]);
    const Env unset("NO_COLOR", std::nullopt);
    colour = LivePanel::colour();
    alert = LivePanel::alert("FAULT");
  }
  EXPECT_FALSE(colour);
  EXPECT_EQ(alert, "FAULT");
}

TEST(LivePanel, DrawsThePanelAndKeepsItStaleWithTheFirstFailureTime) {
  const UtcZone utc;
  const Env plain("NO_COLOR", "1");
  ManualClock clock;  // 2026-01-01T00:00:00Z
  Pipe pipe;
  std::string fresh, stale, still_stale;
  {
    const Redirect to_pipe(STDOUT_FILENO, pipe.fd[1]);
    LivePanel panel(std::string(90, 'T'), 500, clock);
    panel.show("speed 5\n");
    fresh = drain(pipe.fd[0]);
    clock.advance(7s);
    panel.stale("no response");
    stale = drain(pipe.fd[0]);
    clock.advance(3s);
    panel.stale("no response");
    still_stale = drain(pipe.fd[0]);
  }
  const std::string title = std::string(80, 'T') + "\n";
  EXPECT_EQ(fresh, "\x1b[H\x1b[2J" + title + "(every 500 ms, Ctrl-C to stop; updated 00:00:00)\n\nspeed 5\n");
  EXPECT_EQ(stale, "\x1b[H\x1b[2J" + title +
                       "(every 500 ms, Ctrl-C to stop; updated 00:00:07)\n\n"
                       "STALE since 00:00:07: no response\n\nspeed 5\n");
  EXPECT_EQ(still_stale, "\x1b[H\x1b[2J" + title +
                             "(every 500 ms, Ctrl-C to stop; updated 00:00:10)\n\n"
                             "STALE since 00:00:07: no response\n\nspeed 5\n");
}

TEST(WallTime, BrokenDownFromTheClock) {
  ManualClock clock;  // 2026-01-01T00:00:00Z
  clock.advance(3'723'456ms);
  const WallTime w = wall_time(true, clock);
  EXPECT_EQ(w.tm.tm_year, 126);
  EXPECT_EQ(w.tm.tm_mon, 0);
  EXPECT_EQ(w.tm.tm_mday, 1);
  EXPECT_EQ(w.tm.tm_hour, 1);
  EXPECT_EQ(w.tm.tm_min, 2);
  EXPECT_EQ(w.tm.tm_sec, 3);
  EXPECT_EQ(w.ms, 456);
  const UtcZone utc;
  EXPECT_EQ(clock_hms(clock), "01:02:03");
}

TEST(SecretLine, ReadsLinesFromAPipeWithoutAPrompt) {
  Pipe input, errors;
  const std::string text = "hunter22\r\nsecond\nlast";
  ASSERT_EQ(::write(input.fd[1], text.data(), text.size()), static_cast<ssize_t>(text.size()));
  input.close_write();
  std::string first, second, third, after;
  {
    const Redirect from_pipe(STDIN_FILENO, input.fd[0]);
    const Redirect to_errors(STDERR_FILENO, errors.fd[1]);
    EXPECT_FALSE(stdin_is_terminal());
    first = read_secret_line("Password: ");
    second = read_secret_line("Again: ");
    third = read_secret_line("Again: ");
    after = read_secret_line("Again: ");
  }
  EXPECT_EQ(first, "hunter22");  // without its "\r\n"
  EXPECT_EQ(second, "second");   // nothing past a line was taken
  EXPECT_EQ(third, "last");
  EXPECT_EQ(after, "");  // end of input
  errors.close_write();
  EXPECT_EQ(drain(errors.fd[0]), "");  // no prompt when nobody types
}

TEST(SecretLine, OnATerminalPromptsAndDoesNotEcho) {
  Pty pty;
  Pipe errors;
  // Typed once the echo is off (what is typed before is flushed, as on a real terminal).
  std::thread typist([&] {
    termios t{};
    for (int i = 0; i < 500; ++i) {
      if (::tcgetattr(pty.slave, &t) == 0 && (t.c_lflag & ECHO) == 0) break;
      std::this_thread::sleep_for(2ms);
    }
    ASSERT_EQ(::write(pty.master, "s3cret\n", 7), 7);
  });
  std::string line;
  {
    const Redirect from_terminal(STDIN_FILENO, pty.slave);
    const Redirect to_errors(STDERR_FILENO, errors.fd[1]);
    EXPECT_TRUE(stdin_is_terminal());
    line = read_secret_line("Password: ");
  }
  typist.join();
  EXPECT_EQ(line, "s3cret");
  EXPECT_EQ(drain(pty.master, 100), "");  // nothing echoed back to the screen
  termios after{};
  ASSERT_EQ(::tcgetattr(pty.slave, &after), 0);
  EXPECT_NE(after.c_lflag & ECHO, 0u);  // the echo is back on
  errors.close_write();
  EXPECT_EQ(drain(errors.fd[0]), "Password: \n");
}

TEST(WarnIfExposed, OneLineForAListenerBeyondLoopbackOnly) {
  Pipe errors;
  {
    const Redirect to_errors(STDERR_FILENO, errors.fd[1]);
    warn_if_exposed(*parse_port("tcp://127.0.0.1:1502", true), "the slave");
    warn_if_exposed(*parse_port("pty", true), "the slave");
  }
  EXPECT_EQ(drain(errors.fd[0], 0), "");
  {
    const Redirect to_errors(STDERR_FILENO, errors.fd[1]);
    warn_if_exposed(*parse_port("tcp://0.0.0.0:1502", true), "the slave");
  }
  errors.close_write();
  const std::string warning = drain(errors.fd[0]);
  EXPECT_TRUE(warning.starts_with("warning: the slave listens on ")) << warning;
  EXPECT_NE(warning.find("Modbus has no passwords"), std::string::npos) << warning;
  EXPECT_EQ(warning.find('\n'), warning.size() - 1) << warning;  // one line
}

}  // namespace
}  // namespace rtukit::term
