// The doctor's measurements, apart from how they are shown. Step 1 uses the
// raw link (a Master would hide the echo and the batching); step 2 uses a
// Master because the gap it finds is the Master's inter-request delay.
#include "rtukit/driver/line_probe.hpp"

#include <algorithm>
#include <array>
#include <utility>

#include "rtukit/core/rtu.hpp"

namespace rtukit {
namespace {

double ms(double us) {
  return us / 1000.0;
}

}  // namespace

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1,
                         static_cast<size_t>(p / 100.0 * static_cast<double>(values.size() - 1) + 0.5))];
}

LineProbe probe_line(io::Link& link, std::span<const uint8_t> request, size_t response_size,
                     std::chrono::milliseconds timeout, DriverClock& clock) {
  LineProbe p;
  link.discard_input();
  const auto deadline = clock.now() + timeout;
  if (link.write(request, deadline)) return p;
  const auto sent = clock.now();
  std::vector<uint8_t> got;
  std::array<uint8_t, 256> buf{};
  size_t want = response_size;
  std::vector<std::pair<size_t, double>> reads;  // bytes so far, when
  while (got.size() < want) {
    const Result<size_t> n = link.read_some(buf, deadline);
    if (!n.ok() || *n == 0) break;
    const double at = std::chrono::duration<double, std::micro>(clock.now() - sent).count();
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

Result<LineTestResult> test_line(const LinkFactory& make_link, const LineTestOptions& o,
                                 const std::function<void(const LineTestProgress&)>& progress) {
  DriverClock& clock = clock_or_steady(o.clock);
  const auto show = [&progress](const LineTestProgress& p) {
    if (progress) progress(p);
  };
  std::array<uint8_t, 5> pdu{};
  std::array<uint8_t, 8> request{};
  if (!encode_read_request(Function::read_holding_registers, o.address, 1, pdu).ok() ||
      !rtu_encode(o.unit.value, pdu, request).ok())
    return Error(Errc::invalid_argument, "cannot build the probe request");
  const size_t response_size = 7;  // unit, 03, 02, value (2), CRC (2)
  LineTestResult r;
  r.char_us = 1e6 * o.bits_per_char / o.baud;
  r.t35_us = RtuTiming::for_serial(o.baud, o.bits_per_char).t35_us;
  r.wire_us = r.char_us * (request.size() + response_size);

  std::unique_ptr<io::Link> link = make_link();
  if (Error e = link->open()) return e;
  std::vector<double> first, extra;
  unsigned batched = 0;
  for (unsigned i = 0; i < o.rounds; ++i) {
    show({.step = 1, .index = i + 1, .rounds = o.rounds, .count = r.answered});
    const LineProbe p = probe_line(*link, request, response_size, o.probe_timeout, clock);
    if (p.echo) ++r.echoes;
    if (!p.answered) continue;
    ++r.answered;
    first.push_back(p.first_us);
    // Beyond the wire (request + response characters) and the t3.5 a device
    // must wait: what the adapter, the driver and the device added.
    extra.push_back(std::max(0.0, p.last_us - r.wire_us - r.t35_us));
    if (p.reads == 1 && response_size * r.char_us > 2000) ++batched;
    clock.sleep_for(std::chrono::milliseconds(20));
  }
  link->close();
  if (r.answered == 0) return r;
  r.echo = r.echoes * 2 > o.rounds;
  r.added_us = percentile(extra, 50);
  r.batched = batched * 2 > r.answered;
  r.first_p50_us = percentile(first, 50);
  r.first_p99_us = percentile(first, 99);

  // The smallest gap between requests that stays free of errors.
  for (unsigned gap : {0U, 1U, 2U, 5U, 10U, 20U, 50U}) {
    MasterOptions mo = o.master;
    mo.discard_echo = r.echo;
    mo.inter_request_delay = std::chrono::milliseconds(gap);
    mo.response_timeout = std::chrono::milliseconds(
        static_cast<long>(std::max(100.0, 3 * ms(r.first_p99_us + r.wire_us + r.added_us))));
    mo.retries = 0;
    if (o.clock) mo.clock = o.clock;
    Master m(make_link(), mo);
    unsigned errors = 0;
    for (unsigned i = 0; i < o.rounds; ++i) {
      show({.step = 2, .index = i + 1, .rounds = o.rounds, .count = errors, .gap_ms = gap});
      uint16_t v = 0;
      if (Error e = m.read_holding_registers(o.unit, o.address, {&v, 1}); e && !e.is_exception()) ++errors;
    }
    if (errors == 0) {
      r.error_free_gap_ms = gap;
      break;
    }
    r.errors_at_largest_gap = errors;
  }

  // The device's turnaround: first answer byte, less the request on the wire and that byte itself.
  const double request_wire_us = r.char_us * static_cast<double>(request.size());
  r.turnaround_p50_us = std::max(0.0, r.first_p50_us - request_wire_us - r.char_us);
  r.turnaround_p99_us = std::max(0.0, r.first_p99_us - request_wire_us - r.char_us);
  r.timeout_ms = static_cast<unsigned>(std::max(50.0, 2 * ms(r.first_p99_us + r.wire_us + r.added_us) + 20));
  return r;
}

}  // namespace rtukit
