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
//  - Commands on .../set/<command>: validated as the typed client validates
//    (inverjet::Client), answered on .../result with the reason when refused;
//    never applied halfway. Retained commands and commands whose "ts" is older
//    than `max_age_s` are dropped (a swimmer must never have the machine start
//    because a stale message came in late).
//  - Reconnects to the broker (1 s doubling to 30 s) and to the machine.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <string_view>

#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::programs {

struct BridgeMachine {
  uint8_t unit = 21;
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
  unsigned max_age_s = 5;                          ///< older commands are dropped
  std::string discovery_prefix = "homeassistant";  ///< empty: no discovery
  unsigned response_timeout_ms = 300;
};

/// The machine's status as the bridge and the pool panel publish it: mode,
/// state by name, speed, time (remaining or elapsed), faults by name,
/// temperatures, current, rpm, bus voltage, versions (docs/inverjet.md).
nlohmann::json machine_state_json(const inverjet::MachineStatus& s);

/// Runs one command as the bridge's set/<name> topics and the pool panel take
/// it: start {mode free|timer|plan, speed, duration, plan, from} (anything
/// not an object: free mode from memory), pause, resume, stop, speed (a
/// number or {speed}), plan {plan, segments: [{speed, end}]}, plan_select
/// ("Plan 1".."Plan 4"). Checked as the typed client checks (it runs them);
/// never applied halfway. Errors: invalid_argument with the rule, or the
/// machine's answer (Modbus exception with its reason), timeouts.
rtukit::Status inverjet_command(inverjet::Client& client, std::string_view name, const nlohmann::json& body,
                                nlohmann::json& result);

/// The body of a command message on .../set/<name>, for inverjet_command:
/// the payload's JSON, or the payload as a JSON string when it is not JSON (a
/// button's "PRESS"). Stale commands are refused before anything runs: a
/// retained message, or one whose "ts" (seconds, or milliseconds, since the
/// epoch) is more than `max_age_s` before `now_s`. Errors: refused with the
/// reason ("stale: ..."). Pure: the bridge passes the time (and the fuzzer
/// any payload).
rtukit::Status mqtt_command_body(std::string_view payload, bool retained, double now_s, unsigned max_age_s,
                                 nlohmann::json& body);

/// "mqtt://host:port" / "mqtts://host:port" into `o` (host, port; mqtts needs
/// --tls-ca). Errors: invalid_argument with the reason.
rtukit::Status parse_mqtt_url(const std::string& url, BridgeOptions& o);

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

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit::programs
