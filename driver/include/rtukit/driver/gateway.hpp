// rtukit driver: a Modbus TCP gateway, the one process that owns a serial
// bus. Many TCP clients (watch windows, scripts, SCADA, the HMI, the MQTT
// bridge) share one RTU line through it:
//
//   rtukit::Master bus(rtukit::io::make_link(serial_spec));
//   auto gw = rtukit::Gateway::start(ctx, bus, {tcp_spec}, {});
//   ctx.run();
//
// Each request is checked on arrival (unit allowed, read-only, a function
// the gateway relays), then queued; one bus thread runs the queues round
// robin, one transaction at a time, and answers each client on its own
// connection. Answers: the device's own response or exception; 0x0B when the
// device does not answer (or answers garbage), 0x0A when the bus is down or
// the unit is not allowed, 0x01 for a function not relayed or, on a
// read-only gateway, for every request outside its allow-list
// (relays_when_read_only), 0x06 when a client already has too many requests
// waiting.
//
// Read coalescing (`cache`): identical reads within that time share one bus
// transaction, reads already queued behind it included. Any write through the gateway invalidates the cached
// reads it may change, whatever its outcome, so a write between two reads is never hidden. Changes made by
// the device itself can be up to `cache` old.
//
// Quarantine (`quarantine_after`): a unit that left that many requests in a
// row without an answer (each after the master's timeout and retries) is
// quarantined. Its requests are then answered 0x0B at once by the gateway and
// never reach the bus, so the other units' clients stop queueing behind its
// timeouts. After `probe_backoff` the next request for it is let through as a
// probe: an answer (its response or its own exception) ends the quarantine;
// no answer doubles the back-off, up to `probe_backoff_max`. A dead unit costs
// the others one timeout per back-off period, and one that comes back is
// served again without a restart.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit {

/// A unit entering or leaving quarantine (GatewayOptions::on_quarantine).
struct GatewayUnitEvent {
  uint8_t unit = 0;
  bool quarantined = false;                 ///< true: entered; false: answered a probe, relayed again
  unsigned timeouts = 0;                    ///< entered: the requests in a row it left without an answer
  std::chrono::milliseconds next_probe{0};  ///< entered: when its first probe may go out
};

struct GatewayOptions {
  /// Relay only the requests that change nothing (relays_when_read_only: an
  /// allow-list); every other request gets exception 01 from the gateway and
  /// never reaches the bus.
  bool read_only = false;
  /// Units relayed; empty: 1..247, and unit 0 (the broadcast address) for
  /// the writes a broadcast carries (05, 06, 0F, 10, 16): relayed as a
  /// broadcast, which every unit executes and none answers, and confirmed to
  /// the client with the write's normal response once sent. Others get
  /// exception 0x0A. A list never lets a broadcast through (it would reach
  /// units the list does not name).
  std::vector<uint8_t> allowed_units;
  /// Serve identical reads from the last answer for this long (0: never).
  std::chrono::milliseconds cache{0};
  /// Requests one client may have waiting; more get exception 06.
  unsigned max_queued_per_client = 32;
  /// Connection limit, idle timeout, output bound of the TCP side.
  ServerOptions server;
  /// Quarantine a unit after this many requests in a row got no answer from it
  /// (a timeout after the master's retries); 0: never. While quarantined its
  /// requests get 0x0B at once and never reach the bus.
  unsigned quarantine_after = 3;
  /// How long a quarantined unit is left alone before the next request for it
  /// goes to the bus as a probe; doubled after each probe it leaves
  /// unanswered, up to `probe_backoff_max`.
  std::chrono::milliseconds probe_backoff{1000};
  std::chrono::milliseconds probe_backoff_max{30000};
  /// The clock of the cache and the quarantine; nullptr: the steady clock.
  /// Must outlive the gateway. Tests pass a ManualClock.
  DriverClock* clock = nullptr;
  /// Called on the bus thread when a unit enters or leaves quarantine (a log
  /// line); must not call back into the gateway.
  std::function<void(const GatewayUnitEvent&)> on_quarantine;
  /// One line for the operator (the first request to unit 0 of each client
  /// that wants an answer: why it got 0A); called on the TCP side's thread,
  /// must not call back into the gateway.
  std::function<void(std::string_view)> notice;
};

struct GatewayStats {
  uint64_t requests = 0;                   ///< requests from clients
  uint64_t bus_transactions = 0;           ///< requests sent on the bus
  uint64_t cache_hits = 0;                 ///< reads answered from the cache
  uint64_t refused = 0;                    ///< answered by the gateway itself (01, 06, 0A for a unit)
  uint64_t no_answer = 0;                  ///< 0x0B: the device did not answer
  uint64_t bus_down = 0;                   ///< 0x0A: the bus failed
  uint64_t quarantined_answers = 0;        ///< 0x0B at once: the unit is quarantined, the bus not used
  uint64_t quarantines = 0;                ///< times a unit entered quarantine
  uint64_t probes = 0;                     ///< requests let through to a quarantined unit
  std::vector<uint8_t> quarantined_units;  ///< the units quarantined now, in order
};

/// What the gateway does with one request as it arrives, before its queues
/// and cache: the checks of the request path, pure (no session, no bus, no
/// clock), so they can be fuzzed and tested alone.
struct GatewayAdmission {
  enum class Action {
    relay,   ///< queue it for the bus (or answer it from the cache)
    refuse,  ///< answer `exception` at once; nothing reaches the bus
    drop,    ///< no answer: an RTU frame too short for its function, as a line drops it
  };
  Action action = Action::drop;
  Errc exception = Errc::ok;  ///< refuse: 01, 02, 03, 04 (the codec's), 0A (unit not allowed)
  Request request{};          ///< relay: the decoded request
};

/// Decides for a request `pdu` (function code first, at least 1 byte) to
/// `unit`. `ordered`: it came as an RTU frame (rtu+tcp://), whose truncated
/// PDUs are dropped; an MBAP request's length says it is whole, so a short
/// PDU gets 03. Order of the checks: the codec (a function not relayed: 01;
/// fields out of range: 02/03), the unit allow-list (0A), read-only (01 for
/// every request relays_when_read_only does not name).
GatewayAdmission admit_gateway_request(const GatewayOptions& options, uint8_t unit,
                                       std::span<const uint8_t> pdu, bool ordered);

/// True for the functions that change a device's data (FC05, 06, 0F, 10, 16, 17):
/// the ones whose relaying invalidates cached reads.
bool gateway_counts_as_write(uint8_t function);

/// The allow-list of a read-only gateway: true only for a request that
/// changes nothing on the device or its line. Exactly: FC01, 02, 03, 04
/// (reads); FC08 with sub-function 00 (echo), 02 (diagnostic register) or
/// 0B..12 (the counters, bus messages .. character overruns); FC0B (comm
/// event counter), FC0C (comm event log), FC11 (report server id); FC2B with
/// MEI type 0E (read device identification). False for everything else:
/// every write (05, 06, 0F, 10, 16, 17), FC07, FC08 restart (01), ASCII
/// delimiter (03), listen-only (04), the clears (0A, 14) and any other
/// sub-function, FC2B with another MEI type, file records, user-defined
/// codes, and any function added later until someone decides it reads only:
/// the list fails closed. One function for the gateway and its fuzz oracle.
bool relays_when_read_only(const Request& request);

class Gateway {
 public:
  /// Opens `bus` first, then listens on every spec of `listen` and relays to
  /// `bus`, which must outlive the gateway. A bus that cannot be opened (a
  /// port that does not exist, a file that is no serial port) fails the
  /// start with io_error, "port PORT 9600 8N1: No such file or directory"
  /// (or "...: not a serial port"), and nothing listens. tcp:// takes Modbus TCP (MBAP, answers matched by
  /// transaction id); rtu+tcp:// takes RTU frames (unit, PDU, CRC) over TCP,
  /// answered in the order of the requests (a frame with a bad CRC gets no
  /// answer, as on a line). Starts the bus thread. Errors as
  /// SlaveListener::start (address in use, not an IP address);
  /// invalid_argument for a listen spec that is not TCP.
  static Outcome<std::unique_ptr<Gateway>> start(asio::io_context& ctx, Master& bus,
                                                 std::span<const io::PortSpec> listen,
                                                 GatewayOptions options);
  /// Stops the bus thread (a transaction under way finishes first).
  ~Gateway();
  Gateway(const Gateway&) = delete;
  Gateway& operator=(const Gateway&) = delete;

  /// Where clients connect: "tcp://127.0.0.1:1502", "rtu+tcp://...", one per listener.
  std::vector<std::string> where() const;
  /// The first listener's TCP port (useful with port 0).
  uint16_t tcp_port() const;
  GatewayStats stats() const;

  struct Impl;

 private:
  explicit Gateway(std::shared_ptr<Impl> impl);
  std::shared_ptr<Impl> impl_;  // shared with the client sessions, which may outlive the gateway
};

}  // namespace rtukit
