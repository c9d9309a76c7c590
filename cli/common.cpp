#include "common.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <thread>

#include "rtukit/devices/profile/typed_value.hpp"

namespace rtukit::cli {

void LinkOptions::add_to(CLI::App& cmd_app, bool listening, uint32_t default_baud) {
  baud = default_baud;
  // Shown after the command's own options in --help.
  CLI::Option_group& cmd = *cmd_app.add_option_group("Link options");
  if (listening) {
    cmd.add_option("--listen,-l", port,
                   "pty | pty:/path/link | /dev/ttyX | tcp://HOST:PORT | rtu+tcp://HOST:PORT")
        ->required();
  } else {
    cmd.add_option("--port,-p", port, "/dev/ttyX | tcp://HOST:PORT | rtu+tcp://HOST:PORT")->required();
    cmd.add_option("--timeout", timeout_ms, "response timeout in ms")->capture_default_str();
    cmd.add_option("--retries", retries, "extra attempts after a timeout")->capture_default_str();
    cmd.add_option("--delay", delay_ms, "minimum ms between requests (slow devices)")->capture_default_str();
    cmd.add_flag("--echo", echo, "discard the echo of our own request (half-duplex adapters)");
    cmd.add_flag("--stats", stats, "print the master's counters to stderr at the end");
    cmd.add_flag("--trace", trace, "print every frame sent and received to stderr, with a timestamp");
    cmd.add_option("--log", log_file, "append every frame sent and received to this file");
  }
  cmd.add_option(
         "--quirk", quirks,
         "accept a documented frame deviation on RTU links (repeatable): fc10-no-count (FC10 requests "
         "without byte count; a master also sends them so), fc03-two-byte-count (FC03/04 responses with a "
         "2-byte count)")
      ->check(CLI::IsMember({"fc10-no-count", "fc03-two-byte-count"}));
  cmd.add_option("--baud,-b", baud, "serial baud rate (1200..921600)")->capture_default_str();
  cmd.add_option("--parity", parity, "none, even or odd (N, E, O)")->capture_default_str();
  cmd.add_option("--data-bits", data_bits, "7 or 8")->capture_default_str();
  cmd.add_option("--stop-bits", stop_bits, "1 or 2")->capture_default_str();
  cmd.add_flag("--rs485", rs485, "RS-485 direction control (TIOCSRS485, else RTS toggling)");
  cmd.add_option("--rs485-delay-before", rs485_before_us, "RS-485: us between RTS and the first bit");
  cmd.add_option("--rs485-delay-after", rs485_after_us, "RS-485: us between the last bit and RTS release");
}

void ServerArgs::add_to(CLI::App& cmd_app, bool serial) {
  CLI::Option_group& cmd = *cmd_app.add_option_group("Server options");
  cmd.add_option("--max-connections", max_connections, "TCP: clients served at once; more are refused")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  cmd.add_option("--idle-timeout", idle_timeout_s,
                 "TCP: close a connection silent for this many s (0: never)")
      ->capture_default_str();
  if (!serial) return;
  cmd.add_option("--turnaround-ms", turnaround_ms,
                 "serial: silence before each answer (default: t3.5 on serial ports, 0 on ptys)")
      ->check(CLI::Range(0.0, 1000.0));
}

ServerOptions ServerArgs::options() const {
  ServerOptions o;
  o.max_connections = max_connections;
  o.idle_timeout = std::chrono::seconds(idle_timeout_s);
  if (turnaround_ms >= 0)
    o.turnaround = std::chrono::microseconds(static_cast<int64_t>(turnaround_ms * 1000.0));
  return o;
}

char parity_letter(std::string_view text) {
  std::string t;
  for (char c : text) t += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (t == "n" || t == "none") return 'N';
  if (t == "e" || t == "even") return 'E';
  if (t == "o" || t == "odd") return 'O';
  throw Failure{kUsage, fmt::format("--parity '{}' is not one of none, even, odd (or N, E, O)", text)};
}

namespace {
// The port this command was given (its path), for fail()'s "PATH is not a
// serial port": one command per process, one port.
std::string& command_port_path() {
  static std::string path;
  return path;
}
}  // namespace

io::PortSpec LinkOptions::spec(bool listening) const {
  // "127.0.0.1:1502" is a TCP address without its scheme, not a file name.
  const size_t colon = port.rfind(':');
  if (colon != std::string::npos && colon > 0 && !port.starts_with("/") && !port.starts_with("pty") &&
      port.find("://") == std::string::npos && colon + 1 < port.size() &&
      port.find_first_not_of("0123456789", colon + 1) == std::string::npos)
    throw Failure{kUsage, fmt::format("bad port '{}': did you mean tcp://{} (Modbus TCP) or rtu+tcp://{}?",
                                      port, port, port)};
  Result<io::PortSpec> spec = io::parse_port(port, listening);
  if (!spec.ok()) throw Failure{kUsage, fmt::format("bad port '{}': {}", port, spec.error().text())};
  spec->serial.baud = baud;
  spec->serial.parity = parity_letter(parity);
  spec->serial.data_bits = static_cast<uint8_t>(data_bits);
  spec->serial.stop_bits = static_cast<uint8_t>(stop_bits);
  spec->serial.rs485.enabled = rs485;
  spec->serial.rs485.delay_before_us = rs485_before_us;
  spec->serial.rs485.delay_after_us = rs485_after_us;
  if (Error e = spec->serial.validate()) throw Failure{kUsage, std::string(e.text())};
  command_port_path() = spec->path;
  return *spec;
}

FrameQuirks LinkOptions::frame_quirks() const {
  FrameQuirks q;
  for (const std::string& name : quirks) {
    if (name == "fc10-no-count") q.fc10_without_byte_count = true;
    if (name == "fc03-two-byte-count") q.fc03_two_byte_count = true;
  }
  return q;
}

MasterOptions LinkOptions::master_options() const {
  MasterOptions o;
  o.quirks = frame_quirks();
  o.fc10_without_byte_count = o.quirks.fc10_without_byte_count;
  o.response_timeout = std::chrono::milliseconds(timeout_ms);
  o.retries = retries;
  o.inter_request_delay = std::chrono::milliseconds(delay_ms);
  o.discard_echo = echo;
  return o;
}

namespace {

// The wall clock now, broken down (local time or UTC), with its milliseconds.
struct WallTime {
  std::tm tm{};
  long ms = 0;
};
WallTime wall_time(bool utc) {
  const auto now = time_source().wall();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  WallTime w;
  if (utc)
    ::gmtime_r(&t, &w.tm);
  else
    ::localtime_r(&t, &w.tm);
  w.ms = static_cast<long>(
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000);
  return w;
}

// "14:02:07.123" in local time.
std::string clock_text() {
  const WallTime w = wall_time(false);
  return fmt::format("{:02}:{:02}:{:02}.{:03}", w.tm.tm_hour, w.tm.tm_min, w.tm.tm_sec, w.ms);
}

}  // namespace

std::function<void(const TraceEvent&)> LinkOptions::tracer() const {
  if (!trace && log_file.empty()) return {};
  std::shared_ptr<std::FILE> log;
  if (!log_file.empty()) {
    log.reset(std::fopen(log_file.c_str(), "a"), [](std::FILE* f) {
      if (f) std::fclose(f);
    });
    if (!log)
      throw Failure{kIoError,
                    fmt::format("--log {}: cannot open for appending: {}", log_file, std::strerror(errno))};
  }
  const bool to_stderr = trace;
  return [log, to_stderr](const TraceEvent& e) {
    // "14:02:07.123 > 15 03 00 21 00 04 xx xx" and
    // "14:02:07.141 < 15 03 08 ... (ok, 18.2 ms)".
    std::string line;
    if (e.direction == TraceEvent::Direction::sent) {
      line = fmt::format("{} > {}{}{}\n", clock_text(), hex(e.bytes), e.outcome.empty() ? "" : "  (",
                         e.outcome.empty() ? std::string() : std::string(e.outcome) + ")");
    } else {
      line = fmt::format("{} < {}({}, {:.1f} ms)\n", clock_text(),
                         e.bytes.empty() ? std::string("nothing ") : hex(e.bytes) + "  ", e.outcome,
                         static_cast<double>(e.elapsed.count()) / 1000.0);
    }
    if (to_stderr) std::fputs(line.c_str(), stderr);
    if (log) {
      std::fputs(line.c_str(), log.get());
      std::fflush(log.get());
    }
  };
}

std::unique_ptr<Master> LinkOptions::make_master() const {
  MasterOptions o = master_options();
  o.trace = tracer();
  return std::make_unique<Master>(io::make_link(spec(false)), std::move(o));
}

void examples(CLI::App& cmd, std::initializer_list<std::string_view> lines) {
  examples(cmd, std::span<const std::string_view>(lines.begin(), lines.size()));
}

void examples(CLI::App& cmd, std::span<const std::string_view> lines) {
  std::string text = "Examples:";
  for (std::string_view l : lines) text += fmt::format("\n  {}", l);
  cmd.footer(text);
}

std::string clock_hms() {
  const WallTime w = wall_time(false);
  return fmt::format("{:02}:{:02}:{:02}", w.tm.tm_hour, w.tm.tm_min, w.tm.tm_sec);
}

LivePanel::LivePanel(std::string title, unsigned interval_ms)
    : title_(std::move(title)), interval_ms_(interval_ms) {}

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
  if (stale_since_.empty()) stale_since_ = clock_hms();
  draw(alert(fmt::format("STALE since {}: {}", stale_since_, error)));
}

void LivePanel::draw(std::string_view banner) {
  // Home and clear, then the whole panel at once: no scrolling, no flicker of half panels.
  std::string out = "\x1b[H\x1b[2J";
  out += fmt::format("{}\n(every {} ms, Ctrl-C to stop; updated {})\n\n", title_.substr(0, 80), interval_ms_,
                     clock_hms());
  if (!banner.empty()) out += fmt::format("{}\n\n", banner);
  out += last_body_.empty() ? std::string("(no data yet)\n") : last_body_;
  fmt::print("{}", out);
  std::fflush(stdout);
}

Json json_document(std::string_view device, int unit) {
  const WallTime w = wall_time(true);
  Json j;
  j["time"] = fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", w.tm.tm_year + 1900, w.tm.tm_mon + 1,
                          w.tm.tm_mday, w.tm.tm_hour, w.tm.tm_min, w.tm.tm_sec, w.ms);
  j["ok"] = true;
  if (!device.empty()) j["device"] = device;
  if (unit >= 0) j["unit"] = unit;
  return j;
}

void print_json(const Json& document) {
  fmt::print("{}\n", document.dump());
}

Json json_failure(const Failure& f) {
  static constexpr const char* kKinds[] = {"ok",          "modbus_exception", "usage",
                                           "no_response", "io_error",         "refused"};
  Json j = json_document();
  j["ok"] = false;
  j["error"] = {{"exit", f.code},
                {"kind", f.code >= 0 && f.code <= 5 ? kKinds[f.code] : "error"},
                {"message", f.message}};
  return j;
}

bool& json_requested() {
  static bool requested = false;
  return requested;
}

int64_t parse_number(std::string_view text, std::string_view what, int64_t min, int64_t max) {
  const Outcome<int64_t> n = profile::parse_number(text, what, min, max);
  if (!n.ok()) throw Failure{kUsage, std::string(n.error().reason())};
  return *n;
}

// "1-247", "21", "1,5,21-30" -> the units in order, each once.
std::vector<unsigned> parse_units(const std::string& text, unsigned max) {
  std::vector<unsigned> units;
  std::vector<bool> seen(max + 1);
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    const std::string item = text.substr(start, end - start);
    const size_t dash = item.find('-');
    const auto lo = parse_number(item.substr(0, dash), "unit", 1, max);
    const auto hi = dash == std::string::npos ? lo : parse_number(item.substr(dash + 1), "unit", lo, max);
    for (auto u = lo; u <= hi; ++u) {
      if (!seen[u]) units.push_back(static_cast<unsigned>(u));
      seen[u] = true;
    }
    start = end + 1;
  }
  return units;
}

UnitId device_unit(const std::string& text, const profile::Profile& p) {
  const profile::UnitRange units = profile::unit_range(p);
  if (text.empty()) return UnitId{units.fallback};
  return UnitId{
      static_cast<uint8_t>(parse_number(text, fmt::format("{} unit", p.name), units.min, units.max))};
}

std::string device_title(const profile::Profile& p) {
  const profile::LinkDefaults link = profile::link_defaults(p);
  return fmt::format("{} (unit {}, {} 8{}{} by default)", p.title, link.unit, link.baud, link.parity,
                     link.stop_bits);
}

std::string device_unit_help(const profile::Profile& p) {
  const profile::UnitRange units = profile::unit_range(p);
  return fmt::format("the device's address, {}..{} (default {})", units.min, units.max, units.fallback);
}

UnitId parse_unit(const std::string& text, bool tcp) {
  return UnitId{static_cast<uint8_t>(parse_number(text, "unit", 0, tcp ? 255 : kMaxSerialUnit))};
}

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

void warn_if_exposed(const io::PortSpec& listen, std::string_view who) {
  const std::string exposure = io::listener_exposure(listen);
  if (exposure.empty()) return;
  fmt::print(stderr,
             "warning: {} listens on {} ({}): Modbus has no passwords, so anyone who can reach it reads and "
             "writes the device; listen on tcp://127.0.0.1:PORT unless that is what you want\n",
             who, exposure, listen.describe());
}

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

Interruptible::Interruptible() {
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
  const auto until = time_source().now() + d;
  while (!g_interrupted && time_source().now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return !g_interrupted;
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

void WatchOptions::add_to(CLI::App& cmd) {
  cmd.add_option("--interval", interval_ms, "ms between refreshes")
      ->capture_default_str()
      ->check(CLI::Range(50, 60000));
  cmd.add_option("--count", count, "stop after N refreshes (0 = until Ctrl-C)")->capture_default_str();
}

void watch_loop(const WatchOptions& options, const std::function<void(unsigned n)>& refresh) {
  Interruptible interrupt;
  for (unsigned n = 0; options.count == 0 || n < options.count; ++n) {
    if (n > 0 && !interrupt.sleep(std::chrono::milliseconds(options.interval_ms))) break;
    refresh(n);
    std::fflush(stdout);
  }
}

std::string tap_line(const BusCharacter& c) {
  return fmt::format("{} {} {} {:02X} {:02X}{}{}{}\n", c.start_us, c.end_us, c.sender, c.sent, c.heard,
                     c.collided || c.dropped ? " " : "", c.collided ? "c" : "", c.dropped ? "d" : "");
}

std::optional<BusCharacter> parse_tap_line(const std::string& line) {
  if (line.empty() || line[0] == '#') return std::nullopt;
  unsigned long long start = 0, end = 0;
  int sender = 0;
  unsigned sent = 0, heard = 0;
  char flags[8] = {};
  const int n =
      std::sscanf(line.c_str(), "%llu %llu %d %x %x %7s", &start, &end, &sender, &sent, &heard, flags);
  if (n < 5 || sent > 0xFF || heard > 0xFF) return std::nullopt;
  BusCharacter c;
  c.start_us = start;
  c.end_us = end;
  c.sender = sender;
  c.sent = static_cast<uint8_t>(sent);
  c.heard = static_cast<uint8_t>(heard);
  c.collided = std::strchr(flags, 'c') != nullptr;
  c.dropped = std::strchr(flags, 'd') != nullptr;
  return c;
}

std::string bus_tap_socket(const std::string& name) {
  const bool good = !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  });
  if (!good)
    throw Failure{kUsage, fmt::format("bus name '{}': use 1 to 64 letters, digits, '-' or '_'", name)};
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  const std::string dir =
      runtime && *runtime ? std::string(runtime) + "/rtukit" : fmt::format("/tmp/rtukit-{}", ::getuid());
  return dir + "/bus-" + name + ".sock";
}

int exit_code(Error e) {
  if (e.ok()) return kOk;
  if (e.is_exception()) return kModbusException;
  switch (e.code()) {
    case Errc::timeout:
    case Errc::unexpected_response:
    case Errc::malformed:
    case Errc::bad_crc:
      return kNoResponse;
    case Errc::invalid_argument:
      return kUsage;
    case Errc::refused:
      return kRefused;
    default:
      return kIoError;
  }
}

void fail(Error e, std::string_view context) {
  std::string line;
  if (e.is_exception()) {
    line = fmt::format("{}: Modbus exception {:02X} ({})", context, e.exception_code(), e.name());
  } else if (e.code() == Errc::timeout) {
    line = fmt::format(
        "{}: no response (timeout). Check the unit address, the baud rate and parity, and the A/B wiring; "
        "`rtukit scan` lists the units that answer",
        context);
  } else if (e.code() == Errc::io_error && !e.reason().empty()) {
    line = fmt::format("{}: {}", context, e.reason());
  } else if (e.code() == Errc::io_error && e.os_error() == ENOTTY) {
    // "Inappropriate ioctl for device": the path is a file or a device without a serial line.
    const std::string& path = command_port_path();
    line = fmt::format(
        "{}: {} is not a serial port (give /dev/ttyUSB0, /dev/ttyS0 or a pty, or tcp://HOST:PORT)", context,
        path.empty() ? std::string("the port") : path);
  } else if (e.code() == Errc::io_error && e.os_error() != 0) {
    line = fmt::format("{}: I/O error: {}", context, std::strerror(e.os_error()));
    if (e.os_error() == EBUSY)
      line += " (another program holds the port: close it, or let one process own the bus)";
    else if (e.os_error() == EACCES)
      line += " (join the dialout group: sudo usermod -aG dialout $USER, then log in again)";
    else if (e.os_error() == ECONNREFUSED)
      line += " (nothing listens there: is the server or simulator running?)";
  } else {
    line = fmt::format("{}: {}", context, e.text());
  }
  throw Failure{exit_code(e), line};
}

void print_stats(const Master& master) {
  const MasterStats s = master.stats();
  fmt::print(stderr,
             "stats: requests={} responses={} exceptions={} timeouts={} crc_errors={} unexpected={} "
             "io_errors={} retries={} reopens={}\n",
             s.requests, s.responses, s.exceptions, s.timeouts, s.crc_errors, s.unexpected, s.io_errors,
             s.retries, s.reopens);
}

}  // namespace rtukit::cli
