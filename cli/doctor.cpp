// `rtukit doctor`: measures the path to a device and says what to set.
// It talks to the device (FC03 reads of one register), so run it where a
// master may run; it never writes.
#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/driver/line_probe.hpp"
#include "rtukit/io/serial_config.hpp"
#include "rtukit/tool/diagnostics.hpp"

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

int run_doctor(const DoctorArgs& a) {
  const io::PortSpec spec = a.link.spec(false);
  const UnitId unit = parse_unit(a.unit, spec.is_tcp());
  if (unit.value == 0)
    throw Failure{kUsage, fmt::format("the doctor needs a unit that answers (1..{})", kMaxSerialUnit)};
  const auto address = static_cast<uint16_t>(parse_number(a.address, "address", 0, 0xFFFF));
  if (spec.is_tcp())
    throw Failure{kUsage, "the doctor measures serial lines (a TCP link has no baud rate or echo)"};

  // Kernel RS-485 mode: asked of the driver before we take the port.
  const bool kernel_rs485 = io::kernel_rs485_available(spec.path);

  LineTestOptions o;
  o.unit = unit;
  o.address = address;
  o.rounds = a.rounds;
  o.baud = spec.serial.baud;
  o.bits_per_char = spec.serial.bits_per_char();
  o.probe_timeout = std::chrono::milliseconds(std::max(a.link.timeout_ms, 200U));
  o.master = a.link.master_options();
  // Each step on a terminal as it runs (stderr; nothing in pipes and files):
  // a silent unit costs rounds x timeout before the doctor can say so.
  Progress progress;
  const Result<LineTestResult> tested = test_line(
      [&spec] { return io::make_link(spec); }, o,
      [&progress](const LineTestProgress& p) {
        if (p.step == 1)
          progress.show(fmt::format("doctor: step 1 of 2, echo and turnaround: probe {} of {} ({} answered)",
                                    p.index, p.rounds, p.count));
        else
          progress.show(
              fmt::format("doctor: step 2 of 2, error-free gap: {} ms, request {} of {} ({} failed)",
                          p.gap_ms, p.index, p.rounds, p.count));
      });
  if (!tested.ok()) {
    if (tested.error().code() == Errc::invalid_argument)
      throw Failure{kUsage, "cannot build the probe request"};
    fail(tested.error(), "doctor " + spec.path);
  }
  const LineTestResult& r = *tested;
  if (r.answered == 0)
    throw Failure{
        kNoResponse,
        fmt::format("doctor {}: unit {} never answered {} probes (FC03 at {}); check the unit, baud, parity "
                    "and wiring first (`rtukit scan`)",
                    spec.path, unit.value, a.rounds, address)};
  progress.clear();
  const tool::LineAdvice advice = tool::line_advice(r, spec.serial.baud, kernel_rs485);
  const double turn50 = r.turnaround_p50_us, turn99 = r.turnaround_p99_us;
  const std::optional<unsigned> best_gap = r.error_free_gap_ms;

  if (a.json) {
    Json j = json_document({}, unit.value);
    j["port"] = spec.path;
    j["answered"] = r.answered;
    j["probes"] = a.rounds;
    j["echo"] = r.echo;
    j["turnaround_p50_ms"] = ms2(turn50);
    j["turnaround_p99_ms"] = ms2(turn99);
    j["added_latency_ms"] = ms2(r.added_us);
    j["batched_delivery"] = r.batched;
    j["kernel_rs485"] = kernel_rs485;
    j["error_free_gap_ms"] = best_gap ? Json(*best_gap) : Json(nullptr);
    j["recommended_options"] = advice.options;
    print_json(j);
    return kOk;
  }
  fmt::print("doctor: {} unit {}, {} probes, {} answered\n", spec.path, unit.value, a.rounds, r.answered);
  fmt::print("  echo of our request    {}\n",
             r.echo ? "yes: the adapter echoes what we send (use --echo)" : "no");
  fmt::print(
      "  device turnaround      p50 {:.2f} ms, p99 {:.2f} ms (spread {:.2f} ms; Modbus asks at least t3.5 = "
      "{:.2f} ms)\n",
      ms(turn50), ms(turn99), ms(turn99 - turn50), ms(r.t35_us));
  fmt::print("  wire time              {:.2f} ms for request + answer at {} baud, plus t3.5 {:.2f} ms\n",
             ms(r.wire_us), spec.serial.baud, ms(r.t35_us));
  fmt::print(
      "  added latency          {:.2f} ms{}\n", ms(r.added_us),
      advice.high_latency
          ? " : the adapter or driver holds bytes back (a USB adapter's latency timer? set it to 1 ms: "
            "echo 1 > /sys/bus/usb-serial/devices/ttyUSB0/latency_timer)"
          : "");
  fmt::print("  delivery               {}\n",
             r.batched ? "in batches (whole answers at once)" : "character by character");
  fmt::print("  kernel RS-485 mode     {}\n",
             kernel_rs485 ? "available (--rs485: the kernel drives the direction line)" : "not available");
  if (best_gap)
    fmt::print("  error-free gap         {} ms between requests\n", *best_gap);
  else
    fmt::print(
        "  error-free gap         none up to 50 ms: {} of {} requests failed even then; the line has errors "
        "(termination, grounding, cable length)\n",
        r.errors_at_largest_gap, a.rounds);
  fmt::print("recommended: {}\n", advice.options);
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
