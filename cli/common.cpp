#include "common.hpp"

#include <fmt/core.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/driver/trace_log.hpp"
#include "rtukit/term/tap_client.hpp"

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
    // 0 would never wait for an answer: every request a timeout (issue 38).
    cmd.add_option("--timeout", timeout_ms, "response timeout in ms (1..600000)")
        ->check(CLI::Range(1u, 600000u).description(""))  // the range is in the text: keep the type "UINT"
        ->capture_default_str();
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
  cmd.add_option("--max-per-source", max_per_source,
                 "TCP: connections one client address may hold (its share of --max-connections; 0: no share)")
      ->capture_default_str()
      ->check(CLI::Range(0, 10000));
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
  o.max_per_source = max_per_source;
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

std::function<void(const TraceEvent&)> LinkOptions::tracer() const {
  Outcome<std::function<void(const TraceEvent&)>> writer = trace_writer(trace, log_file, time_source());
  if (!writer) throw Failure{kIoError, fmt::format("--log {}: {}", log_file, writer.error().reason())};
  return std::move(*writer);
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

Json json_document(std::string_view device, int unit) {
  const term::WallTime w = term::wall_time(true, time_source());
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
  const Outcome<uint8_t> unit = profile::device_unit(p, text);
  if (!unit) throw Failure{kUsage, std::string(unit.error().reason())};
  return UnitId{*unit};
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

void watch_view(const WatchOptions& options, bool json, std::string_view device, UnitId unit,
                const std::string& title, const std::function<ViewFrame(unsigned n)>& refresh) {
  const bool tty = term::stdout_is_terminal() && !json;
  LivePanel panel(title, options.interval_ms);
  std::string down_since;
  watch_loop(options, [&](unsigned n) {
    ViewFrame f = refresh(n);
    if (!f.ok && down_since.empty()) down_since = clock_hms();
    if (f.ok) down_since.clear();
    if (json) {
      Json doc = json_document(device, unit.value);
      if (!f.values.is_null()) doc["values"] = std::move(f.values);
      if (!f.ok) {
        doc["ok"] = false;
        doc["error"] = {{"kind", f.kind}, {"message", f.why}, {"since", down_since}};
      }
      print_json(doc);
    } else if (tty) {
      if (f.ok)
        panel.show(f.panel + "\n");
      else
        panel.stale(f.why);
    } else {
      fmt::print("{}\n", f.ok ? fmt::format("{} {}", clock_hms(), f.line)
                              : fmt::format("{} stale since {}: {}", clock_hms(), down_since, f.why));
    }
  });
}

int serve_until_stopped(std::string_view name, const std::function<rtukit::Status()>& start,
                        const std::function<void()>& announce, const std::function<void()>& stop) {
  const Interruptible interrupt;  // before start: a signal meanwhile still stops it cleanly
  if (const rtukit::Status e = start())
    throw Failure{e.code() == Errc::invalid_argument || e.code() == Errc::malformed ? kUsage : kIoError,
                  fmt::format("{}: {}", name, e.reason())};
  announce();
  std::fflush(stdout);
  while (interrupt.sleep(std::chrono::milliseconds(200))) {
  }
  stop();
  return kOk;
}

std::string bus_tap_socket(const std::string& name) {
  Outcome<std::string> path = term::bus_tap_socket(name);
  if (!path.ok()) throw Failure{kUsage, std::string(path.error().reason())};
  return *path;
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

RequestLog print_requests() {
  return [](std::span<const uint8_t> rx, std::span<const uint8_t> tx) {
    fmt::print("rx {} -> {}\n", hex(rx), tx.empty() ? std::string("(silence)") : "tx " + hex(tx));
    std::fflush(stdout);
  };
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
