// `rtukit doctor`: measures the path to a device and says what to set.
// It talks to the device (FC03 reads of one register), so run it where a
// master may run; it never writes.
#include <fcntl.h>
#include <fmt/core.h>
#include <linux/serial.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <thread>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/core/rtu.hpp"

namespace rtukit::cli {
namespace {

struct DoctorArgs {
  LinkOptions link;
  std::string unit = "1";
  std::string address = "0";
  unsigned rounds = 20;
  bool json = false;
};

double ms(double us) {
  return us / 1000.0;
}
// Milliseconds with two decimals, for JSON.
double ms2(double us) {
  return std::round(us / 10.0) / 100.0;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p / 100.0 * static_cast<double>(v.size() - 1) + 0.5))];
}

// One probe: the request on the raw link, every byte back with its time.
struct Probe {
  bool answered = false;  ///< a valid response to our request
  bool echo = false;      ///< our own request came back first
  double first_us = 0;    ///< write done -> first response byte
  double last_us = 0;     ///< write done -> last response byte
  size_t reads = 0;       ///< how many reads the response took (1: delivered in one batch)
};

Probe probe(io::Link& link, std::span<const uint8_t> request, size_t response_size,
            std::chrono::milliseconds timeout) {
  Probe p;
  link.discard_input();
  const auto deadline = time_source().now() + timeout;
  if (link.write(request, deadline)) return p;
  const auto sent = time_source().now();
  std::vector<uint8_t> got;
  std::array<uint8_t, 256> buf{};
  size_t want = response_size;
  std::vector<std::pair<size_t, double>> reads;  // bytes so far, when
  while (got.size() < want) {
    const Result<size_t> n = link.read_some(buf, deadline);
    if (!n.ok() || *n == 0) break;
    const double at = std::chrono::duration<double, std::micro>(time_source().now() - sent).count();
    got.insert(got.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(*n));
    // Our own request coming back first is a half-duplex adapter's echo; while
    // what came so far is a prefix of the request, it may still be one.
    const size_t match = static_cast<size_t>(
        std::mismatch(got.begin(),
                      got.begin() + static_cast<std::ptrdiff_t>(std::min(got.size(), request.size())),
                      request.begin())
            .first -
        got.begin());
    p.echo = match == request.size();
    const bool maybe_echo = p.echo || match == got.size();
    want = maybe_echo ? request.size() + response_size : response_size;
    reads.push_back({got.size(), at});
  }
  // The answer's bytes: those after the echo, if there was one.
  const size_t response_start = p.echo ? request.size() : 0;
  for (const auto& [size_after, at] : reads) {
    if (size_after <= response_start) continue;
    if (p.reads == 0) p.first_us = at;
    p.last_us = at;
    ++p.reads;
  }
  const size_t start = p.echo ? request.size() : 0;
  p.answered =
      got.size() >= start + response_size && got[start] == request[0] && got[start + 1] == request[1];
  return p;
}

int run_doctor(const DoctorArgs& a) {
  const io::PortSpec spec = a.link.spec(false);
  const UnitId unit = parse_unit(a.unit, spec.is_tcp());
  if (unit.value == 0)
    throw Failure{kUsage, fmt::format("the doctor needs a unit that answers (1..{})", kMaxSerialUnit)};
  const auto address = static_cast<uint16_t>(parse_number(a.address, "address", 0, 0xFFFF));
  if (spec.is_tcp())
    throw Failure{kUsage, "the doctor measures serial lines (a TCP link has no baud rate or echo)"};

  // Kernel RS-485 mode: asked of the driver before we take the port.
  bool kernel_rs485 = false;
  if (const int fd = ::open(spec.path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK); fd >= 0) {
    serial_rs485 rs{};
    kernel_rs485 = ::ioctl(fd, TIOCGRS485, &rs) == 0;
    ::close(fd);
  }

  std::array<uint8_t, 5> pdu{};
  std::array<uint8_t, 8> request{};
  if (!encode_read_request(Function::read_holding_registers, address, 1, pdu).ok() ||
      !rtu_encode(unit.value, pdu, request).ok())
    throw Failure{kUsage, "cannot build the probe request"};
  const size_t response_size = 7;  // unit, 03, 02, value (2), CRC (2)
  const double char_us = 1e6 * spec.serial.bits_per_char() / spec.serial.baud;
  const double t35_us = RtuTiming::for_serial(spec.serial.baud, spec.serial.bits_per_char()).t35_us;
  const double wire_us = char_us * (request.size() + response_size);

  std::unique_ptr<io::Link> link = io::make_link(spec);
  if (Error e = link->open()) fail(e, "doctor " + spec.path);
  const auto timeout = std::chrono::milliseconds(std::max(a.link.timeout_ms, 200U));
  std::vector<double> first, extra;
  unsigned answered = 0, echoes = 0, batched = 0;
  // Each step on a terminal as it runs (stderr; nothing in pipes and files):
  // a silent unit costs rounds x timeout before the doctor can say so.
  Progress progress;
  for (unsigned i = 0; i < a.rounds; ++i) {
    progress.show(fmt::format("doctor: step 1 of 2, echo and turnaround: probe {} of {} ({} answered)", i + 1,
                              a.rounds, answered));
    const Probe p = probe(*link, request, response_size, timeout);
    if (p.echo) ++echoes;
    if (!p.answered) continue;
    ++answered;
    first.push_back(p.first_us);
    // Beyond the wire (request + response characters) and the t3.5 a device
    // must wait: what the adapter, the driver and the device added.
    extra.push_back(std::max(0.0, p.last_us - wire_us - t35_us));
    if (p.reads == 1 && response_size * char_us > 2000) ++batched;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  link->close();
  if (answered == 0)
    throw Failure{
        kNoResponse,
        fmt::format("doctor {}: unit {} never answered {} probes (FC03 at {}); check the unit, baud, parity "
                    "and wiring first (`rtukit scan`)",
                    spec.path, unit.value, a.rounds, address)};
  const bool echo = echoes * 2 > a.rounds;
  const double added = percentile(extra, 50);
  const bool latency = added > 2000;

  // The smallest gap between requests that stays free of errors.
  std::optional<unsigned> best_gap;
  unsigned errors_at_best = 0, worst_errors = 0;
  for (unsigned gap : {0U, 1U, 2U, 5U, 10U, 20U, 50U}) {
    MasterOptions o = a.link.master_options();
    o.discard_echo = echo;
    o.inter_request_delay = std::chrono::milliseconds(gap);
    o.response_timeout = std::chrono::milliseconds(
        static_cast<long>(std::max(100.0, 3 * ms(percentile(first, 99) + wire_us + added))));
    o.retries = 0;
    Master m(io::make_link(spec), o);
    unsigned errors = 0;
    for (unsigned i = 0; i < a.rounds; ++i) {
      progress.show(fmt::format("doctor: step 2 of 2, error-free gap: {} ms, request {} of {} ({} failed)",
                                gap, i + 1, a.rounds, errors));
      uint16_t v = 0;
      if (Error e = m.read_holding_registers(unit, address, {&v, 1}); e && !e.is_exception()) ++errors;
    }
    worst_errors = std::max(worst_errors, errors);
    if (errors == 0) {
      best_gap = gap;
      break;
    }
    errors_at_best = errors;
  }

  progress.clear();
  const double p50 = percentile(first, 50), p99 = percentile(first, 99);
  // The device's turnaround: first answer byte, less the request on the wire and that byte itself.
  const double request_wire_us = char_us * static_cast<double>(request.size());
  const double turn50 = std::max(0.0, p50 - request_wire_us - char_us),
               turn99 = std::max(0.0, p99 - request_wire_us - char_us);
  const auto timeout_ms = static_cast<unsigned>(std::max(50.0, 2 * ms(p99 + wire_us + added) + 20));
  std::string options = fmt::format("--baud {} --timeout {}", spec.serial.baud, timeout_ms);
  if (echo) options += " --echo";
  if (best_gap && *best_gap > 0) options += fmt::format(" --delay {}", *best_gap);
  if (!best_gap) options += " --retries 2";
  if (kernel_rs485) options += " --rs485";

  if (a.json) {
    Json j = json_document({}, unit.value);
    j["port"] = spec.path;
    j["answered"] = answered;
    j["probes"] = a.rounds;
    j["echo"] = echo;
    j["turnaround_p50_ms"] = ms2(turn50);
    j["turnaround_p99_ms"] = ms2(turn99);
    j["added_latency_ms"] = ms2(added);
    j["batched_delivery"] = batched * 2 > answered;
    j["kernel_rs485"] = kernel_rs485;
    j["error_free_gap_ms"] = best_gap ? Json(*best_gap) : Json(nullptr);
    j["recommended_options"] = options;
    print_json(j);
    return kOk;
  }
  fmt::print("doctor: {} unit {}, {} probes, {} answered\n", spec.path, unit.value, a.rounds, answered);
  fmt::print("  echo of our request    {}\n",
             echo ? "yes: the adapter echoes what we send (use --echo)" : "no");
  fmt::print(
      "  device turnaround      p50 {:.2f} ms, p99 {:.2f} ms (spread {:.2f} ms; Modbus asks at least t3.5 = "
      "{:.2f} ms)\n",
      ms(turn50), ms(turn99), ms(turn99 - turn50), ms(t35_us));
  fmt::print("  wire time              {:.2f} ms for request + answer at {} baud, plus t3.5 {:.2f} ms\n",
             ms(wire_us), spec.serial.baud, ms(t35_us));
  fmt::print(
      "  added latency          {:.2f} ms{}\n", ms(added),
      latency ? " : the adapter or driver holds bytes back (a USB adapter's latency timer? set it to 1 ms: "
                "echo 1 > /sys/bus/usb-serial/devices/ttyUSB0/latency_timer)"
              : "");
  fmt::print("  delivery               {}\n",
             batched * 2 > answered ? "in batches (whole answers at once)" : "character by character");
  fmt::print("  kernel RS-485 mode     {}\n",
             kernel_rs485 ? "available (--rs485: the kernel drives the direction line)" : "not available");
  if (best_gap)
    fmt::print("  error-free gap         {} ms between requests\n", *best_gap);
  else
    fmt::print(
        "  error-free gap         none up to 50 ms: {} of {} requests failed even then; the line has errors "
        "(termination, grounding, cable length)\n",
        errors_at_best, a.rounds);
  fmt::print("recommended: {}\n", options);
  (void)worst_errors;
  return kOk;
}

}  // namespace

void add_doctor_command(CLI::App& app, Action& action) {
  add_command<DoctorArgs>(
      app, action, "doctor",
      "measure the line to a device (echo, turnaround, latency, gaps) and say what to set",
      [](CLI::App& cmd, DoctorArgs& a) {
        cmd.add_option("--unit,-u", a.unit, "a unit that answers")->capture_default_str();
        cmd.add_option("--address", a.address, "a holding register it answers (read only)")
            ->capture_default_str();
        cmd.add_option("--rounds", a.rounds, "probes per measurement")
            ->capture_default_str()
            ->check(CLI::Range(3, 1000));
        cmd.add_flag("--json", a.json, "print JSON (docs/json.md)");
        a.link.add_to(cmd, false);
        examples(cmd, {"rtukit doctor --port /dev/ttyUSB0 --baud 9600 --unit 21",
                       "rtukit doctor --port /dev/ttyS3 --baud 115200 --unit 1 --json"});
      },
      [](const DoctorArgs& a) { return run_doctor(a); });
}

}  // namespace rtukit::cli
