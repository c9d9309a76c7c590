// rtukit device profiles, host side: the serial line diagnostics and the
// identification a host asks of a slave through a Master, read and decoded
// (`rtukit diag`: FC07, FC08, FC0B, FC0C; `rtukit ident`: FC2B/0E, FC11), and
// the advice `rtukit doctor` gives from a line test (driver/line_probe.hpp).
// A front-end parses its arguments, calls these and prints; every failure
// comes back as a Status whose code is the Master's and whose reason is the
// failing request in words ("FC0C get comm event log from unit 5 on ...").
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/driver/line_probe.hpp"
#include "rtukit/driver/master.hpp"

namespace rtukit::tool {

/// "unit 5 on /dev/ttyUSB0 9600 8N1": where a request went, for its context.
std::string unit_where(UnitId unit, const Master& master);

/// One FC08 counter: its sub-function, its JSON key ("bus_crc_errors") and
/// its words ("bus CRC errors").
struct DiagCounter {
  Diagnostic sub;
  const char* key;
  const char* text;
};
/// The FC08 counters in the specification's order (bus messages first, the
/// diagnostic register last).
std::span<const DiagCounter> diag_counters() noexcept;

/// What read_counters read.
struct DiagCounters {
  std::vector<uint16_t> values;  ///< one per diag_counters() entry, in order, as far as read
  uint8_t exception_status = 0;  ///< FC07
  uint16_t event_count = 0;      ///< FC0B: completed requests
};
/// Reads every diag_counters() entry (FC08), then the exception status (FC07)
/// and the event counter (FC0B), stopping at the first failure; `out.values`
/// keeps the counters read before it. Precondition: `unit` is not broadcast.
/// Errors: the Master's; the reason names the step: "FC08 diagnostics
/// sub-function 0x0C (bus CRC errors) to <where>", "FC07 read exception
/// status from <where>", "FC0B get comm event counter from <where>".
Status read_counters(Master& master, UnitId unit, DiagCounters& out);

/// FC0C: the event log (status, event and message counts, the newest event
/// first). Errors: the Master's, reason "FC0C get comm event log from <where>".
Outcome<Master::CommEvents> read_event_log(Master& master, UnitId unit);

/// What echo sent and got back, and how long it took.
struct Echo {
  std::vector<uint8_t> sent, answer;
  double ms = 0;  ///< request to answer on `clock`
  bool same() const { return sent == answer; }
};
/// FC08 00 (return query data) with `data` ({0xA5, 0x37} when empty), timed
/// on `clock`. A different answer is not an error: see Echo::same().
/// Errors: the Master's, reason "FC08 return query data to <where>".
Outcome<Echo> echo(Master& master, UnitId unit, std::vector<uint8_t> data, DriverClock& clock);

/// FC08 0A: clears the counters and the diagnostic register.
/// Errors: the Master's, reason "FC08 clear counters to <where>".
Status clear_counters(Master& master, UnitId unit);
/// FC08 01, the event log cleared too with `clear_log`. Returns whether the
/// unit answered: one in listen-only mode restarts silently, so a timeout is
/// `false`, not an error. Errors: any other of the Master's, reason "FC08
/// restart communications to <where>".
Outcome<bool> restart_communications(Master& master, UnitId unit, bool clear_log);
/// FC08 04: the unit answers nothing from now until a restart.
/// Errors: the Master's, reason "FC08 force listen only mode to <where>".
Status force_listen_only(Master& master, UnitId unit);

/// FC11's answer decoded: the server id and run indicator (when the answer
/// has two bytes or more), then the device's own bytes.
struct ServerId {
  bool has_head = false;
  uint8_t id = 0;
  bool running = false;  ///< run indicator 0xFF
  bool printable = true;
  std::string text;           ///< the bytes after the head (all bytes without one)
  std::vector<uint8_t> data;  ///< the whole answer
};
/// FC11. Errors: the Master's, reason "FC11 report server id to <where>".
Outcome<ServerId> report_server_id(Master& master, UnitId unit);

/// --level basic | regular | extended as an access; `individual` (one object
/// asked for) wins. Errors: invalid_argument, reason "--level X: use basic,
/// regular or extended".
Outcome<DeviceIdAccess> device_id_access(std::string_view level, bool individual);

/// FC2B/0E's answer in words.
struct Identification {
  const char* level = "unknown";  ///< conformity_level_name
  bool individual = false;        ///< the device allows individual access
  /// Each object: its name (device_object_name, else "0x80"), its text; by id.
  std::vector<std::pair<std::string, std::string>> objects;
};
/// FC2B/0E from `object` on (or that one object, individual access).
/// Errors: the Master's, reason "FC2B/0E read device identification from <where>".
Outcome<Identification> read_identification(Master& master, UnitId unit, DeviceIdAccess access,
                                            uint8_t object = 0);

/// What `rtukit doctor` says to set after a line test.
struct LineAdvice {
  /// More than 2 ms added beyond the wire and t3.5: an adapter holds bytes back.
  bool high_latency = false;
  /// "--baud 9600 --timeout 60 [--echo] [--delay N | --retries 2] [--rs485]".
  std::string options;
};
/// Pure: the advice from a line test's measurements at `baud`, and whether
/// the kernel's RS-485 mode is available for the port.
LineAdvice line_advice(const LineTestResult& r, uint32_t baud, bool kernel_rs485);

}  // namespace rtukit::tool
