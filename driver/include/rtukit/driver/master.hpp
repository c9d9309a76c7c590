// rtukit driver: a Modbus master = the core's transaction logic + a Link + the
// steady clock. Blocking calls with a response timeout, retries, an
// inter-request delay for slow devices, broadcast with a turnaround delay.
//
// Thread-safe: one Master may be shared by several threads; requests are
// serialised (one transaction on the bus at a time, as RTU requires).
// A link that fails (USB adapter unplugged, TCP peer gone) is closed and
// reopened by the next request, so a device that comes back just works again.
//
//   rtukit::Master m(rtukit::io::make_link(spec));
//   std::array<uint16_t, 4> regs;
//   if (rtukit::Error e = m.read_holding_registers(rtukit::UnitId{21}, 0x0021, regs)) { ... e.name() ... }
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/core/master.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/io/link.hpp"

namespace rtukit {

/// What a master put on the wire and what came back, for `--trace` and logs.
/// `bytes` is valid only during the call.
struct TraceEvent {
  enum class Direction { sent, received };
  Direction direction;
  /// Sent: the whole request ADU. Received: every byte read during the
  /// attempt (a response, an echo, noise), empty when nothing came.
  std::span<const uint8_t> bytes;
  /// Received: "ok", "exception 02", "timeout", "unexpected response",
  /// "io error"; sent: "attempt 2" on a retry, else empty.
  std::string_view outcome;
  /// Received: time from the end of sending to this event.
  std::chrono::microseconds elapsed{0};
};

struct MasterOptions {
  std::chrono::milliseconds response_timeout{1000};
  /// Minimum silence between the end of one transaction and the next request.
  std::chrono::milliseconds inter_request_delay{0};
  /// After a broadcast (no answer comes): time the slaves get to act.
  std::chrono::milliseconds turnaround_delay{100};
  /// Extra attempts after a timeout (no or corrupted answer). Exceptions and I/O errors are not retried.
  unsigned retries = 0;
  /// Half-duplex adapters that echo our own request.
  bool discard_echo = false;
  /// Send FC10 without its byte count (Inverjet document form). Off: standard form.
  bool fc10_without_byte_count = false;
  /// Response forms the device is documented to use (the Rehand 6600's FC03
  /// with a 2-byte byte count). Off by default; RTU framing only.
  FrameQuirks quirks{};
  /// The clock deadlines and delays run on; nullptr: the steady clock. Must
  /// outlive the master. Tests pass a ManualClock (base/clock.hpp).
  DriverClock* clock = nullptr;
  /// Called (under the master's lock) for each request sent and each
  /// attempt's received bytes. Empty: no tracing, no cost.
  std::function<void(const TraceEvent&)> trace;
};

/// Counters since construction. Readable from any thread.
struct MasterStats {
  uint64_t requests = 0;    ///< requests sent (each retry counts)
  uint64_t responses = 0;   ///< normal responses received
  uint64_t exceptions = 0;  ///< exception responses received
  uint64_t timeouts = 0;    ///< attempts that got no valid answer in time
  uint64_t crc_errors = 0;  ///< corrupted frames dropped while waiting
  uint64_t unexpected = 0;  ///< valid frames that did not answer the request
  uint64_t io_errors = 0;   ///< transport failures (open, write, read)
  uint64_t retries = 0;     ///< attempts after the first
  uint64_t reopens = 0;     ///< successful (re)opens of the link
};

class Master {
 public:
  /// Takes the link; it is opened by the first request (or by open()).
  explicit Master(std::unique_ptr<io::Link> link, MasterOptions options = {});
  ~Master();
  Master(const Master&) = delete;
  Master& operator=(const Master&) = delete;

  /// Opens the link now (else the first request does). Errors: io_error.
  Error open();

  // Each call returns ok, the Modbus exception the slave answered
  // (Error::is_exception), timeout, unexpected_response, invalid_argument
  // (quantity out of range, read broadcast) or io_error/not_connected.
  // The quantity is the span's size.

  /// FC03.
  Error read_holding_registers(UnitId unit, uint16_t address, std::span<uint16_t> out);
  /// FC04.
  Error read_input_registers(UnitId unit, uint16_t address, std::span<uint16_t> out);
  /// FC01. One element per coil: 0 or 1.
  Error read_coils(UnitId unit, uint16_t address, std::span<uint8_t> out);
  /// FC02. One element per input: 0 or 1.
  Error read_discrete_inputs(UnitId unit, uint16_t address, std::span<uint8_t> out);
  /// FC06.
  Error write_single_register(UnitId unit, uint16_t address, uint16_t value);
  /// FC10.
  Error write_multiple_registers(UnitId unit, uint16_t address, std::span<const uint16_t> values);
  /// FC05.
  Error write_single_coil(UnitId unit, uint16_t address, bool on);
  /// FC0F. One element per coil: 0 = off, anything else = on.
  Error write_multiple_coils(UnitId unit, uint16_t address, std::span<const uint8_t> bits);
  /// FC16: the register becomes (current AND and_mask) OR (or_mask AND NOT and_mask),
  /// in one request (no read-modify-write race with another master).
  Error mask_write_register(UnitId unit, uint16_t address, uint16_t and_mask, uint16_t or_mask);
  /// FC17: writes `values` (1..121) at `write_address`, then reads out.size()
  /// (1..125) registers from `read_address`, in one request; the slave applies
  /// the write first. Not for broadcast.
  Error read_write_multiple_registers(UnitId unit, uint16_t read_address, std::span<uint16_t> out,
                                      uint16_t write_address, std::span<const uint16_t> values);

  // ---- diagnostics and identification (issue 14) ----

  /// FC07: the device's eight exception status outputs.
  Error read_exception_status(UnitId unit, uint8_t& status);
  /// FC08 with `sub_function` and its data field (2 bytes for every
  /// sub-function but 00, return query data, which takes any). `answer`
  /// gets the data field of the response. Force listen only mode (04) is
  /// never answered: it returns ok once sent.
  Error diagnostics(UnitId unit, Diagnostic sub_function, std::span<const uint8_t> data,
                    std::vector<uint8_t>& answer);
  /// FC08 with data 0x0000 that answers one value: a counter (0B..12) or the
  /// diagnostic register (02).
  Error diagnostic_value(UnitId unit, Diagnostic sub_function, uint16_t& value);
  struct CommEvents {
    uint16_t status = 0;          ///< 0xFFFF: still busy with an earlier request
    uint16_t event_count = 0;     ///< successful completions
    uint16_t message_count = 0;   ///< FC0C only: bus messages
    std::vector<uint8_t> events;  ///< FC0C only: the newest first
  };
  /// FC0B (log = false) or FC0C (log = true).
  Error comm_events(UnitId unit, bool log, CommEvents& out);
  /// FC11: the data after the byte count (server id, run indicator, more).
  Error report_server_id(UnitId unit, std::vector<uint8_t>& data);
  struct DeviceIdentification {
    uint8_t conformity = 0;                  ///< 0x01..0x03, +0x80 with individual access
    std::map<uint8_t, std::string> objects;  ///< 0 vendor, 1 product code, 2 revision, ...
  };
  /// FC2B/0E. A stream (basic, regular, extended) from `object_id` on,
  /// following "more follows" with further requests; `individual`: that one object.
  Error read_device_identification(UnitId unit, DeviceIdAccess access, DeviceIdentification& out,
                                   uint8_t object_id = 0);

  /// Any request. `on_response` runs (under the lock) with the decoded
  /// response while its data is valid; not called for broadcasts.
  Error transact(UnitId unit, const Request& request,
                 const std::function<void(const Response&)>& on_response = {});

  MasterStats stats() const;
  const MasterOptions& options() const noexcept { return options_; }
  std::string describe() const;

 private:
  Error transact_locked(UnitId unit, const Request& request,
                        const std::function<void(const Response&)>& on_response);
  void trace_received(const Result<Response>& r, Clock::time_point sent_at);
  Result<Response> receive_rtu(MasterTransaction& tx, Clock::time_point deadline);
  void drain_late_answer();
  Result<Response> receive_tcp(MasterTransaction& tx, Clock::time_point deadline);

  std::unique_ptr<io::Link> link_;
  MasterOptions options_;
  mutable std::mutex mutex_;
  MasterStats stats_{};
  RtuFramer framer_{FrameShape::response};
  std::array<uint8_t, kMaxMbapAduSize * 2> rx_{};
  size_t rx_len_ = 0;
  uint16_t transaction_id_ = 0;
  std::vector<uint8_t> traced_rx_;  ///< bytes of the current attempt, kept only when tracing
  DriverClock& clock_;
  Clock::time_point last_end_{};
};

}  // namespace rtukit
