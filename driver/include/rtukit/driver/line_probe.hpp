// rtukit driver: measuring the serial line to a device (`rtukit doctor`):
// whether the adapter echoes, the device's turnaround, what the adapter and
// driver add, and the smallest gap between requests that stays free of
// errors. It reads one holding register (FC03) and never writes.
//
// Numbers only: what to recommend and how to say it is the caller's.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/link.hpp"

namespace rtukit {

/// The value below which `p` percent of `values` lie (nearest rank, rounded:
/// p 50 of {1, 2, 3, 4} is 3); 0 for no values. `p` in 0..100.
double percentile(std::vector<double> values, double p);

/// One probe: the request on the raw link, every byte back with its time.
struct LineProbe {
  bool answered = false;  ///< a valid response to our request (unit and function match, whole)
  bool echo = false;      ///< our own request came back first
  double first_us = 0;    ///< write done -> first response byte
  double last_us = 0;     ///< write done -> last response byte
  size_t reads = 0;       ///< how many reads the response took (1: delivered in one batch)
};

/// Drops stale input, writes `request` on `link` (open) and reads until
/// `response_size` bytes (after an echo of the request, if one comes) or
/// until `timeout` after the start. Errors are not reported: a failed write
/// or read is a probe not answered.
LineProbe probe_line(io::Link& link, std::span<const uint8_t> request, size_t response_size,
                     std::chrono::milliseconds timeout, DriverClock& clock);

struct LineTestOptions {
  UnitId unit{1};        ///< a unit that answers (1..247)
  uint16_t address = 0;  ///< a holding register it answers
  unsigned rounds = 20;  ///< probes per measurement (at least 1)
  uint32_t baud = 9600;  ///< the line's rate and character size, for wire times
  uint32_t bits_per_char = 10;
  /// How long a probe of step 1 waits for its answer.
  std::chrono::milliseconds probe_timeout{1000};
  /// The master of step 2 (its link options, quirks); the test sets the echo,
  /// the delay, the response timeout and no retries.
  MasterOptions master;
  /// Deadlines, times and pauses; nullptr: the steady clock. Must outlive the call.
  DriverClock* clock = nullptr;
};

/// Where the test is, before each probe or request.
struct LineTestProgress {
  unsigned step = 1;   ///< 1: echo and turnaround; 2: error-free gap
  unsigned index = 0;  ///< this probe or request, 1..rounds
  unsigned rounds = 0;
  unsigned count = 0;   ///< step 1: probes answered so far; step 2: requests failed at this gap
  unsigned gap_ms = 0;  ///< step 2: the gap being tried
};

struct LineTestResult {
  unsigned answered = 0;  ///< step 1's probes answered (0: no step 2, nothing else measured)
  unsigned echoes = 0;    ///< probes whose request came back first
  bool echo = false;      ///< more than half the probes echoed: the adapter echoes
  double char_us = 0;     ///< one character on the wire
  double t35_us = 0;      ///< the silence a device must wait before answering
  double wire_us = 0;     ///< request and response on the wire
  /// Beyond the wire and t3.5, what the adapter, the driver and the device added (median).
  double added_us = 0;
  double first_p50_us = 0, first_p99_us = 0;  ///< write done -> first answer byte
  /// The device's turnaround: first answer byte, less the request and that byte on the wire.
  double turnaround_p50_us = 0, turnaround_p99_us = 0;
  /// More than half the answers came in one read although they take over 2 ms on the wire.
  bool batched = false;
  /// The smallest gap of 0, 1, 2, 5, 10, 20, 50 ms with no failed request; none: errors at all of them.
  std::optional<unsigned> error_free_gap_ms;
  unsigned errors_at_largest_gap = 0;  ///< requests failed at 50 ms, when no gap was free of errors
  /// A response timeout with room: twice the slowest answer, plus 20 ms (at least 50 ms).
  unsigned timeout_ms = 0;
};

/// Makes a new link to the line (not opened): step 1 probes on one, each
/// gap of step 2 runs a Master on another.
using LinkFactory = std::function<std::unique_ptr<io::Link>()>;

/// Step 1: `rounds` probes on a raw link (echo, turnaround, batching, added
/// latency), 20 ms apart. Step 2, when any probe was answered: `rounds`
/// reads through a Master at each gap in turn until one gap has no failure
/// (a Modbus exception is an answer, not a failure). `progress` (may be
/// empty) is called before each probe and request.
/// Errors: invalid_argument when no request can be built for the unit and
/// address ("cannot build the probe request"); the link's open() error.
Result<LineTestResult> test_line(const LinkFactory& make_link, const LineTestOptions& options,
                                 const std::function<void(const LineTestProgress&)>& progress = {});

}  // namespace rtukit
