// The Inverjet MQTT bridge (`rtukit inverjet bridge`): one or several
// machines on one serial bus, each published on an MQTT broker under
// rtukit/inverjet/<id>/ with Home Assistant discovery, and commanded from it.
// docs/inverjet.md, "MQTT bridge", has the topics.
//
// Contract:
//  - Each machine has its own MQTT connection (libmosquitto), its own last
//    will (availability "offline", retained) and its own topics; a machine
//    that does not answer is "offline" and polled with back-off, so it never
//    delays the others by more than one response timeout per back-off.
//  - State: one retained JSON document on change (at most `max_rate` per
//    second) plus retained per-value topics.
//  - Commands on .../set/<command>: one JSON object each, with "ts" (docs/
//    inverjet.md has every command's form), checked by mqtt_command_body
//    then validated as the typed client validates (inverjet::Client), and
//    answered on .../result, with the reason when refused; never applied
//    halfway. Anything else (empty, not JSON, a wrong type, a retained
//    message, a "ts" too old or in the future) is refused and never acts: a
//    swimmer must never have the machine start because a stale or malformed
//    message came in. A full command queue refuses with an answer too.
//  - MQTT 5, subscribed with "retain as published", so a retained command is
//    seen as one even while the bridge is online. Each machine's client id
//    is unique per bridge instance (rtukit-inverjet-<id>-<8 random hex>):
//    another bridge, or a user who read the docs, cannot knock it off with
//    a well-known id (docs/security.md, "Pool").
//  - Reconnects to the broker (1 s doubling to 30 s) and to the machine.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/link.hpp"

namespace rtukit::programs {

/// A command's "ts" may be at most this old, and at most kMaxCommandAheadS
/// in the future (clocks differ a little; a command from the future is a
/// replay or a wrong clock).
inline constexpr unsigned kMaxCommandAgeS = 10;
inline constexpr unsigned kMaxCommandAheadS = 2;
/// Commands waiting for the bus per machine; more are refused ("busy").
inline constexpr size_t kCommandQueueLimit = 32;

struct BridgeMachine {
  uint8_t unit = inverjet::kDefaultAddress;
  std::string id;  ///< topic id: rtukit/inverjet/<id>/...
};

struct BridgeOptions {
  std::vector<BridgeMachine> machines;
  std::string host = "127.0.0.1";
  uint16_t port = 1883;
  std::string user, password;
  std::string tls_ca;  ///< CA file: TLS to the broker
  double poll_hz = 2;
  double max_rate = 2;                             ///< state documents per second per machine, at most
  unsigned max_age_s = kMaxCommandAgeS;            ///< older commands are refused
  std::string discovery_prefix = "homeassistant";  ///< empty: no discovery
  unsigned response_timeout_ms = 300;
  /// The clock of the poll schedule, the command age check and the time
  /// stamps; nullptr: the real one. Must outlive the bridge.
  DriverClock* clock = nullptr;
};

/// The body of a command message on .../set/<name>, for inverjet::run_command
/// (devices/inverjet/verbs.hpp: the verbs every front-end runs).
/// Refused before anything runs (Errc::refused, the reason says what to
/// send instead): a retained message; a payload that is not one JSON object
/// (empty, "PRESS", false, a number); no numeric "ts" (seconds, or
/// milliseconds, since the epoch), or one more than `max_age_s` before
/// `now_s` or more than kMaxCommandAheadS after it. Pure: the bridge passes
/// the time (and the fuzzer any payload).
rtukit::Status mqtt_command_body(std::string_view name, std::string_view payload, bool retained, double now_s,
                                 unsigned max_age_s, nlohmann::json& body);

/// "mqtt://host:port" / "mqtts://host:port" into `o` (host, port; mqtts needs
/// --tls-ca). Errors: invalid_argument with the reason.
rtukit::Status parse_mqtt_url(const std::string& url, BridgeOptions& o);

/// The machines of `rtukit inverjet bridge`, from its `--unit` list and its
/// `--id`. Each entry of `units` is "UNIT" or "UNIT=ID"; UNIT is a number
/// (decimal, or hex as 0x15) within the Inverjet's address range
/// (profile::unit_range of inverjet::kProfile), and an empty UNIT (also an
/// empty list: one machine) is the machine's factory address. A machine's
/// id is its own "=ID"; else `id` when it is the only entry; else "ID-UNIT"
/// (`id`, a dash, the unit in decimal) when there are several. The result
/// keeps the order of `units`; ids are checked later (Bridge::start).
/// Errors (the first, in the order of `units`): invalid_argument, the
/// reason "inverjet unit 255 is out of range 1..254", "inverjet unit 'x' is
/// not a number (decimal, or hex as 0x21)", or "--id is required (the
/// machine's name in the topics: rtukit/inverjet/ID/...)" for a machine
/// left without an id.
rtukit::Outcome<std::vector<BridgeMachine>> bridge_machines(std::span<const std::string> units,
                                                            std::string_view id);

/// The largest MQTT password file read_mqtt_password reads.
inline constexpr size_t kMaxPasswordFile = 4096;
/// The MQTT password kept in `path` (`--password-file`): the file's whole
/// text without its trailing CR and LF characters (any number of them; other
/// whitespace is part of the password). Never blocks on a FIFO, never reads
/// a device or more than kMaxPasswordFile bytes. Errors: those of
/// io::read_regular_file (io_error with the OS error, malformed "not a
/// regular file" / "larger than N bytes"), with the reason.
rtukit::Outcome<std::string> read_mqtt_password(const std::string& path);

/// One message the bridge publishes.
struct MqttMessage {
  std::string topic, payload;
  bool retain = false;
  int qos = 1;
};
/// Where the logic's messages go: the machine's own MQTT connection (each
/// machine has one, with its own last will), or a test's list.
using Publish = std::function<void(size_t machine, const MqttMessage&)>;

/// The bridge's logic, without MQTT and without a thread: for each machine,
/// the commands that came in, the polls on the shared schedule
/// (driver/poll_schedule.hpp), and what to publish (availability, the state
/// document and values, at most `max_rate` a second, the health figures
/// every 10 s, Home Assistant discovery after each connect). The Bridge runs
/// it on a BusWorker and hands its messages to libmosquitto; tests run it
/// on a ManualClock and a MemoryLink, step by step.
/// step() runs on one thread; queue_command() and announce() on any.
class BridgeLogic {
 public:
  /// `master`, `options` and `clock` must outlive the logic.
  BridgeLogic(Master& master, const BridgeOptions& options, DriverClock& clock, Publish publish);
  ~BridgeLogic();
  BridgeLogic(const BridgeLogic&) = delete;
  BridgeLogic& operator=(const BridgeLogic&) = delete;

  size_t machines() const;
  /// "rtukit/inverjet/<id>" of machine `machine` (an index into options.machines).
  const std::string& base(size_t machine) const;
  /// A message on .../set/<name>, run at the next step. With kCommandQueueLimit
  /// commands already waiting it is refused at once ("busy" on .../result)
  /// and false is returned.
  bool queue_command(size_t machine, std::string name, std::string payload, bool retained);
  /// The machine's connection (re)connected: discovery, availability and
  /// state go out again at the next step (the broker may have lost them).
  void announce(size_t machine);
  /// Runs what is due at `now`: each machine's commands, a held state,
  /// the health figures, the poll. Returns when something is next due.
  Clock::time_point step(Clock::time_point now);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class Bridge {
 public:
  Bridge(std::unique_ptr<io::Link> link, BridgeOptions options);
  ~Bridge();
  Bridge(const Bridge&) = delete;
  Bridge& operator=(const Bridge&) = delete;

  /// Connects (asynchronously: a broker that is down is retried) and starts
  /// polling. Errors: invalid_argument (no machine, duplicate ids, an id
  /// that is not a topic level), io_error (TLS file).
  rtukit::Status start();
  /// Publishes "offline" for every machine, disconnects, stops.
  void stop();
  /// Each machine's MQTT client id, in the order of the options (after start()).
  std::vector<std::string> client_ids() const;
  /// What an operator should know about this deployment, one line each:
  /// no broker credentials (anyone on the broker may command, unless its
  /// ACL says otherwise), no TLS to a broker that is not on this machine.
  std::vector<std::string> warnings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit::programs
