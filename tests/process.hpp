// Test helpers for tests that start programs: start by PID, stop by PID,
// never `sleep` for a fixed time (poll for the condition instead, bounded).
// The bounds are generous on purpose: they are deadlines for events, reached
// only when a test fails anyway; a sanitizer build on a machine whose other
// core is busy (scripts/busy.sh) takes seconds where an idle one takes ms.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#ifndef RTUKIT_NO_GTEST  // the bench programs use these helpers without GoogleTest
#include <gtest/gtest.h>
#endif

namespace rtukit::test {

using namespace std::chrono_literals;

/// A child process's problem (a sanitizer report, an unclean end): a failure
/// of the running test (GoogleTest), else one line on stderr and exit code 1
/// at the end (the bench programs).
inline void child_problem(const std::string& what) {
#ifndef RTUKIT_NO_GTEST
  ADD_FAILURE() << what;
#else
  std::fprintf(stderr, "child process problem: %s\n", what.c_str());
  static const bool registered = [] {
    std::atexit([] { std::_Exit(1); });
    return true;
  }();
  (void)registered;
#endif
}

/// The lines of `output` a sanitizer or UBSan wrote ("ERROR: AddressSanitizer",
/// "WARNING: ThreadSanitizer", "runtime error:", "SUMMARY: ...Sanitizer"), "" if none.
inline std::string sanitizer_lines(const std::string& output) {
  std::string found;
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    if (line.find("Sanitizer") != std::string::npos || line.find("runtime error:") != std::string::npos)
      found += line + "\n";
  }
  return found;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// How long a started program may take to say it is ready ("listening on").
inline constexpr std::chrono::milliseconds kStartDeadline = 30000ms;

/// Polls `cond` every 10 ms until it holds or `timeout` passes.
template <class Cond>
bool eventually(Cond cond, std::chrono::milliseconds timeout = 20000ms) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (cond()) return true;
    std::this_thread::sleep_for(10ms);
  }
  return cond();
}

inline bool path_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

/// The temporary directory: $TMPDIR, else /tmp (as mktemp, Python's tempfile
/// and scripts/test.sh, which checks that a run leaves no rtukit-* there).
inline std::string temp_root() {
  const char* tmp = std::getenv("TMPDIR");
  return tmp && *tmp ? std::string(tmp) : std::string("/tmp");
}

/// A fresh directory under temp_root(), removed with its files at destruction.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = temp_root() + "/rtukit-test-XXXXXX";
    if (::mkdtemp(tmpl.data()) == nullptr) {
      std::perror(("TempDir: mkdtemp " + tmpl).c_str());
      std::abort();
    }
    path_ = tmpl;
  }
  ~TempDir() { std::system(("rm -rf '" + path_ + "'").c_str()); }
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

/// One line to a console on a Unix socket (a simulator's, the relay's), one
/// line back (without its newline); "" when nobody accepts within the start
/// deadline. Connects anew each time: a console may be starting.
inline std::string ask_console(const std::string& socket_path, const std::string& line) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof a.sun_path, "%s", socket_path.c_str());
  if (!eventually([&] { return ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0; },
                  kStartDeadline)) {
    ::close(fd);
    return {};
  }
  const std::string out = line + "\n";
  (void)::write(fd, out.data(), out.size());
  std::string answer;
  char ch = 0;
  while (::read(fd, &ch, 1) == 1 && ch != '\n') answer += ch;
  ::close(fd);
  return answer;
}

/// A TCP connection to 127.0.0.1:port (its file descriptor), -1 if refused.
/// `rcvbuf`: a small receive buffer, for a client that stops reading.
/// `source`: the client's own address, another of 127.0.0.0/8 ("127.0.0.2":
/// a second machine, as the server sees it).
inline int connect_to(uint16_t port, int rcvbuf = 0, const char* source = nullptr) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (rcvbuf) ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  if (source) {
    sockaddr_in from{};
    from.sin_family = AF_INET;
    ::inet_pton(AF_INET, source, &from.sin_addr);
    if (::bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof from) != 0) {
      ::close(fd);
      return -1;
    }
  }
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

/// A TCP port on 127.0.0.1 nobody listens on right now.
inline uint16_t free_tcp_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

/// A started program. Output (stdout + stderr) goes to a log file that has
/// no name: it is unlinked as soon as it is made, so nothing is left in the
/// temporary directory even when the test is killed (ctest's deadline).
class Process {
 public:
  /// `stdin_pipe`: the program reads what send() writes (else /dev/null).
  explicit Process(const std::vector<std::string>& argv, bool stdin_pipe = false)
      : name_(argv.empty() ? std::string() : argv[0]) {
    std::string tmpl = temp_root() + "/rtukit-proc-XXXXXX";
    // Close-on-exec: other programs this test starts do not inherit it (the
    // dup2 onto 1 and 2 below clears the flag for this one's own output).
    const int fd = ::mkostemp(tmpl.data(), O_CLOEXEC);
    if (fd < 0) {
      std::perror(("Process: mkostemp " + tmpl).c_str());
      std::abort();
    }
    ::unlink(tmpl.c_str());
    log_ = fd;
    int in[2] = {-1, -1};
    if (stdin_pipe && ::pipe(in) != 0) in[0] = in[1] = -1;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      if (in[0] >= 0) {
        ::dup2(in[0], 0);
        ::close(in[1]);
      } else {
        const int devnull = ::open("/dev/null", O_RDONLY);
        ::dup2(devnull, 0);
      }
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      ::execvp(args[0], args.data());
      ::_exit(127);
    }
    if (in[0] >= 0) ::close(in[0]);
    stdin_ = in[1];
  }
  /// Stops the program if it still runs, then checks its end (issue 36: a
  /// child's sanitizer report or crash on its shutdown path fails the test
  /// that started it): no sanitizer line in its output, and, for our own
  /// `rtukit` binary stopped here by SIGTERM, an exit of its own within the
  /// deadline with 0 or 128 + SIGTERM (a command cut short says so). Foreign
  /// peers (socat, Python, libmodbus) may die by the signal.
  ~Process() {
    stop();
    check_end();
    if (stdin_ >= 0) ::close(stdin_);
    ::close(log_);
  }
  /// Writes `text` to the program's stdin (Process(argv, true)).
  bool send(const std::string& text) {
    ::signal(SIGPIPE, SIG_IGN);  // a program that died must fail the test, not kill it
    return stdin_ >= 0 && ::write(stdin_, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  }
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  pid_t pid() const { return pid_; }
  /// Everything the program wrote so far. pread: the program shares the
  /// file's offset, which must stay at its end.
  std::string output() const {
    std::string out;
    char buf[65536];
    for (off_t at = 0;;) {
      const ssize_t n = ::pread(log_, buf, sizeof buf, at);
      if (n <= 0) break;
      out.append(buf, static_cast<size_t>(n));
      at += n;
    }
    return out;
  }
  bool running() {
    if (exited_) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      exited_ = true;
      signaled_ = !WIFEXITED(status);
      code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      return false;
    }
    return true;
  }
  /// Waits until the output contains `needle` (false if the process died or time ran out).
  bool wait_for_output(const std::string& needle, std::chrono::milliseconds timeout = kStartDeadline) {
    return eventually([&] { return output().find(needle) != std::string::npos || !running(); }, timeout) &&
           output().find(needle) != std::string::npos;
  }
  /// Waits for the exit; returns the exit code, or -1 on time out (then kills).
  int wait(std::chrono::milliseconds timeout = 20000ms) {
    if (!eventually([&] { return !running(); }, timeout)) {
      stop();
      return -1;
    }
    return code_;
  }
  /// SIGTERM, then SIGKILL when it has not ended within `deadline` (a
  /// failure of the test for our own binary: see ~Process). By PID only.
  void stop(std::chrono::milliseconds deadline = 10000ms) {
    if (pid_ <= 0 || !running()) return;
    ::kill(pid_, SIGTERM);
    terminated_ = true;
    if (!eventually([&] { return !running(); }, deadline)) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
      exited_ = true;
      killed_ = true;
    }
  }
  /// Whether the test expects this program to end unclean on SIGTERM (a test
  /// of what a crash leaves behind, say): the end is then not checked.
  void expect_unclean_end() { unclean_ok_ = true; }

 private:
  bool ours() const {
    const std::string base = name_.substr(name_.find_last_of('/') + 1);
    return base == "rtukit";
  }
  void check_end() {
    if (pid_ <= 0) return;
    if (const std::string lines = sanitizer_lines(output()); !lines.empty())
      child_problem(name_ + " reported:\n" + lines);
    if (unclean_ok_ || !ours() || !terminated_) return;
    if (killed_)
      child_problem(name_ + " did not end within its deadline after SIGTERM (killed)");
    else if (signaled_ || (code_ != 0 && code_ != 128 + SIGTERM))
      child_problem(
          name_ + " ended unclean after SIGTERM: " +
          (signaled_ ? "killed by signal " + std::to_string(code_ - 128) : "exit " + std::to_string(code_)) +
          "\n" + output().substr(output().size() > 2000 ? output().size() - 2000 : 0));
  }

  std::string name_;
  pid_t pid_ = -1;
  int stdin_ = -1;
  int log_ = -1;  // the output file (unlinked), read with pread
  bool exited_ = false;
  bool terminated_ = false;  // stop() sent SIGTERM
  bool killed_ = false;      // ...and it took SIGKILL
  bool signaled_ = false;    // it ended by a signal (not an exit of its own)
  bool unclean_ok_ = false;
  int code_ = -1;
};

struct RunResult {
  int code = -1;
  std::string output;
};

/// Runs a program to completion (bounded) and returns its exit code and output.
inline RunResult run(const std::vector<std::string>& argv, std::chrono::milliseconds timeout = 20000ms) {
  Process p(argv);
  RunResult r;
  r.code = p.wait(timeout);
  r.output = p.output();
  return r;
}

/// Runs `program args...`, with `--port port` appended when `port` is given.
inline RunResult run_cli(const std::string& program, std::vector<std::string> args,
                         const std::string& port = {}) {
  args.insert(args.begin(), program);
  if (!port.empty()) {
    args.push_back("--port");
    args.push_back(port);
  }
  return run(args);
}

/// A socat pty pair: two linked pseudo-terminals at dir/a and dir/b.
class PtyPair {
 public:
  explicit PtyPair(const TempDir& dir)
      : a_(dir / "a"),
        b_(dir / "b"),
        socat_({"socat", "pty,raw,echo=0,link=" + a_, "pty,raw,echo=0,link=" + b_}) {
    ready_ = eventually([&] { return path_exists(a_) && path_exists(b_); });
  }
  bool ready() const { return ready_; }
  const std::string& a() const { return a_; }
  const std::string& b() const { return b_; }

 private:
  std::string a_, b_;
  Process socat_;
  bool ready_ = false;
};

/// Sets an environment variable for a scope and restores what it was (or
/// unsets it) at the end: e.g. XDG_RUNTIME_DIR, where a named bus puts its
/// socket, pointed at a test's own folder.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* was = std::getenv(name)) saved_ = was;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (saved_)
      ::setenv(name_, saved_->c_str(), 1);
    else
      ::unsetenv(name_);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> saved_;
};

}  // namespace rtukit::test
