// The MQTT bridge. BridgeLogic decides (commands first, then each machine's
// held state, health and due poll); the Bridge runs it on a BusWorker, the
// one thread that owns the serial bus, and carries its messages on
// libmosquitto. Each machine's network thread (callbacks) only queues
// commands, sets flags and wakes the worker.
#include "rtukit/programs/inverjet_bridge.hpp"

#include <fmt/core.h>
#include <mosquitto.h>
#include <mqtt_protocol.h>
#include <sys/random.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <ctime>
#include <deque>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <thread>

#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/driver/bus_worker.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/poll_schedule.hpp"
#include "rtukit/io/atomic_file.hpp"

namespace rtukit::programs {
namespace {

using Json = nlohmann::json;
namespace ij = inverjet;

struct Command {
  std::string name;  ///< the topic's last level: start, pause, ...
  std::string payload;
  bool retained = false;
};

bool is_loopback_host(const std::string& host) {
  return host == "localhost" || host == "::1" || host == "[::1]" || host.rfind("127.", 0) == 0;
}

bool valid_topic_level(const std::string& id) {
  return !id.empty() && id.size() <= 64 && id.find_first_of("/+#") == std::string::npos &&
         id.find_first_of(" \t\n") == std::string::npos;
}

std::string iso_time(WallClock::time_point at) {
  const std::time_t t = WallClock::to_time_t(at);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char out[32];
  std::strftime(out, sizeof out, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return out;
}

}  // namespace

rtukit::Status parse_mqtt_url(const std::string& url, BridgeOptions& o) {
  std::string rest;
  uint16_t default_port = 1883;
  if (url.rfind("mqtt://", 0) == 0) {
    rest = url.substr(7);
  } else if (url.rfind("mqtts://", 0) == 0) {
    rest = url.substr(8);
    default_port = 8883;
    if (o.tls_ca.empty()) return rtukit::Status(Errc::invalid_argument, "mqtts:// needs --tls-ca FILE");
  } else {
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("{}: expected mqtt://HOST[:PORT] or mqtts://...", url));
  }
  const size_t colon = rest.rfind(':');
  o.host = rest.substr(0, colon);
  o.port = default_port;
  if (colon != std::string::npos) {
    const std::string p = rest.substr(colon + 1);
    if (p.empty() || p.size() > 5 || p.find_first_not_of("0123456789") != std::string::npos ||
        std::stoul(p) > 65535 || std::stoul(p) == 0)
      return rtukit::Status(Errc::invalid_argument, fmt::format("{}: the port must be 1..65535", url));
    o.port = static_cast<uint16_t>(std::stoul(p));
  }
  if (o.host.empty()) return rtukit::Status(Errc::invalid_argument, fmt::format("{}: no host", url));
  return {};
}

rtukit::Outcome<std::vector<BridgeMachine>> bridge_machines(std::span<const std::string> units,
                                                            std::string_view id) {
  // No --unit at all is one machine at the factory address, named by --id.
  static const std::string kFactory;
  const std::span<const std::string> list = units.empty() ? std::span(&kFactory, 1) : units;
  // The range is the table's (the address row), as for every other
  // Inverjet command, so the bridge never accepts a unit the machine would not.
  std::vector<BridgeMachine> machines;
  for (const std::string& entry : list) {
    const size_t eq = entry.find('=');
    const Outcome<uint8_t> unit = profile::device_unit(ij::kProfile, std::string_view(entry).substr(0, eq));
    if (!unit) return unit.error();
    BridgeMachine m;
    m.unit = *unit;
    if (eq != std::string::npos)
      m.id = entry.substr(eq + 1);
    else if (list.size() == 1)
      m.id = id;
    else if (!id.empty())  // several machines share --id: each is told apart by its unit
      m.id = fmt::format("{}-{}", id, m.unit);
    // else: no name at all ("-21" is no machine's name): refused below.
    if (m.id.empty())
      return rtukit::Status(Errc::invalid_argument,
                            "--id is required (the machine's name in the topics: rtukit/inverjet/ID/...)");
    machines.push_back(std::move(m));
  }
  return machines;
}

rtukit::Outcome<std::string> read_mqtt_password(const std::string& path) {
  Outcome<std::string> text = io::read_regular_file(path, kMaxPasswordFile);
  if (!text) return text.error();
  // `echo secret > file` leaves a line end (CR LF from an editor on
  // Windows) that is no part of the password the broker knows.
  std::string password = std::move(*text);
  while (!password.empty() && (password.back() == '\n' || password.back() == '\r')) password.pop_back();
  return password;
}

rtukit::Status mqtt_command_body(std::string_view name, std::string_view payload, bool retained, double now_s,
                                 unsigned max_age_s, Json& body) {
  const auto refuse = [&](std::string why) {
    const std::string example = ij::command_example(name);
    if (!example.empty()) why += fmt::format("; for example {}", example);
    return rtukit::Status(Errc::refused, std::move(why));
  };
  // Retained: left on the broker by someone, at some time. Never run.
  if (retained)
    return rtukit::Status(Errc::refused,
                          "retained: a retained command is never run (publish commands without the retain "
                          "flag; clear this one with mosquitto_pub -r -n -t TOPIC)");
  body = Json::parse(payload, nullptr, false);
  if (body.is_discarded() || !body.is_object()) {
    body = Json();
    return refuse(payload.empty() ? "an empty message is not a command" : "expected one JSON object");
  }
  if (!body.contains("ts") || !body["ts"].is_number())
    return refuse("\"ts\" is required: the time it was sent, in seconds since the epoch");
  double ts = body["ts"].get<double>();
  if (ts > 1e12) ts /= 1000;  // milliseconds
  const double age = now_s - ts;
  if (!(age <= max_age_s))  // NaN too
    return rtukit::Status(Errc::refused,
                          fmt::format("stale: sent {:.0f} s ago (limit {} s)", age, max_age_s));
  if (-age > kMaxCommandAheadS)
    return rtukit::Status(
        Errc::refused, fmt::format("\"ts\" is {:.0f} s in the future (limit {} s): check the sender's clock",
                                   -age, kMaxCommandAheadS));
  return {};
}

// ---------------------------------------------------------------- the logic: one machine

namespace {

/// How often each machine's health figures go to .../bridge.
constexpr std::chrono::seconds kStatsPeriod{10};

struct Machine {
  Machine(Master& master, BridgeMachine m, const BridgeOptions& o, size_t i, const Publish& p,
          Clock::time_point now)
      : config(std::move(m)),
        index(i),
        client(master, UnitId{config.unit}),
        base("rtukit/inverjet/" + config.id),
        out(p),
        schedule(PollPolicy::at_hz(o.poll_hz), now) {}

  BridgeMachine config;
  size_t index;
  ij::Client client;
  std::string base;
  const Publish& out;

  std::mutex mutex;  ///< guards commands (filled on the MQTT thread)
  std::deque<Command> commands;
  std::atomic<bool> announce{false};  ///< (re)connected: discovery and availability again

  // The bus worker's only.
  ij::Family remembered = ij::Family::none;  ///< the run family through a fault screen
  bool online = false;
  PollSchedule schedule;  ///< also the health published on .../bridge every 10 s
  Clock::time_point last_state_publish{};
  Json pending_doc;  ///< a changed state held back by --max-rate
  uint64_t commands_run = 0;
  Clock::time_point last_stats{};
  std::string last_state;
  std::map<std::string, std::string> last_values;
  bool state_pending = false;

  void publish(const std::string& topic, const std::string& payload, bool retain, int qos = 1) {
    out(index, MqttMessage{topic, payload, retain, qos});
  }
};

}  // namespace

struct BridgeLogic::Impl {
  Impl(Master& master, const BridgeOptions& o, DriverClock& c, Publish p)
      : options(o), clock(c), out(std::move(p)) {
    for (size_t i = 0; i < options.machines.size(); ++i)
      machines.push_back(
          std::make_unique<Machine>(master, options.machines[i], options, i, out, clock.now()));
  }

  const BridgeOptions& options;
  DriverClock& clock;
  Publish out;
  std::vector<std::unique_ptr<Machine>> machines;

  rtukit::Status run_command(Machine& m, const Command& c, Json& result) {
    Json body;
    const double now_s = std::chrono::duration<double>(clock.wall().time_since_epoch()).count();
    if (rtukit::Status e = mqtt_command_body(c.name, c.payload, c.retained, now_s, options.max_age_s, body))
      return e;
    return ij::run_command(m.client, c.name, body, result);
  }

  void publish_discovery(Machine& m) {
    if (options.discovery_prefix.empty()) return;
    const std::string node = "rtukit_inverjet_" + m.config.id;
    const Json device{{"identifiers", Json::array({node})},
                      {"name", fmt::format("Inverjet {}", m.config.id)},
                      {"manufacturer", "Inverjet"},
                      {"model", "counter-current swimming machine"},
                      {"via_device", "rtukit"}};
    const auto entity = [&](const std::string& component, const std::string& object, Json config) {
      config["unique_id"] = node + "_" + object;
      config["object_id"] = node + "_" + object;
      config["device"] = device;
      config["availability_topic"] = m.base + "/availability";
      config["payload_available"] = "online";
      config["payload_not_available"] = "offline";
      m.publish(fmt::format("{}/{}/{}/{}/config", options.discovery_prefix, component, node, object),
                config.dump(), true);
    };
    const std::string state = m.base + "/state";
    const Json limits = ij::limits_document();  // the rows' ranges and the plan count
    const auto sensor = [&](const std::string& object, const std::string& name, const std::string& key,
                            Json extra = {}) {
      Json c{{"name", name}, {"state_topic", state}, {"value_template", "{{ value_json." + key + " }}"}};
      for (auto& [k, v] : extra.items()) c[k] = v;
      entity("sensor", object, c);
    };
    sensor("state", "State", "state", {{"json_attributes_topic", state}, {"icon", "mdi:swim"}});
    sensor("mode", "Mode", "mode");
    sensor("remaining", "Remaining time", "remaining_s",
           {{"unit_of_measurement", "s"}, {"device_class", "duration"}});
    sensor("elapsed", "Elapsed time", "elapsed_s",
           {{"unit_of_measurement", "s"}, {"device_class", "duration"}});
    sensor("mosfet_temperature", "MOSFET temperature", "mosfet_c",
           {{"unit_of_measurement", "°C"}, {"device_class", "temperature"}, {"state_class", "measurement"}});
    sensor("motor_temperature", "Motor temperature", "motor_c",
           {{"unit_of_measurement", "°C"}, {"device_class", "temperature"}, {"state_class", "measurement"}});
    sensor("current", "Current", "current_a",
           {{"unit_of_measurement", "A"}, {"device_class", "current"}, {"state_class", "measurement"}});
    sensor("rpm", "Motor speed", "rpm", {{"unit_of_measurement", "rpm"}, {"state_class", "measurement"}});
    sensor("bus_voltage", "Bus voltage", "bus_v",
           {{"unit_of_measurement", "V"}, {"device_class", "voltage"}, {"state_class", "measurement"}});
    entity("number", "speed",
           {{"name", "Speed"},
            {"state_topic", state},
            {"value_template", "{{ value_json.speed }}"},
            {"command_topic", m.base + "/set/speed"},
            {"command_template", "{\"speed\": {{ value | int }}, \"ts\": {{ now().timestamp() | int }}}"},
            {"min", limits["speed"]["min"]},
            {"max", limits["speed"]["max"]},
            {"step", 1},
            {"unit_of_measurement", "%"},
            {"mode", "slider"}});
    entity("binary_sensor", "fault",
           {{"name", "Fault"},
            {"state_topic", state},
            {"value_template", "{{ 'ON' if value_json.fault else 'OFF' }}"},
            {"payload_on", "ON"},
            {"payload_off", "OFF"},
            {"device_class", "problem"},
            {"json_attributes_topic", state},
            {"json_attributes_template", "{{ {'faults': value_json.faults} | tojson }}"}});
    for (const char* b : {"start", "pause", "resume", "stop"}) {
      std::string name = b;
      name[0] = static_cast<char>(name[0] - 'a' + 'A');
      // Home Assistant renders command_template when the button is pressed:
      // the command carries the time it was sent, as every command must.
      const std::string body = std::string(b) == "start"
                                   ? "{\"mode\": \"free\", \"ts\": {{ now().timestamp() | int }}}"
                                   : "{\"ts\": {{ now().timestamp() | int }}}";
      entity("button", b,
             {{"name", name}, {"command_topic", m.base + "/set/" + b}, {"command_template", body}});
    }
    Json plan_options = Json::array();  // "Plan 1".."Plan N", as the state's plan_select names them
    for (unsigned p = 1; p <= limits["plans"].get<unsigned>(); ++p)
      plan_options.push_back(fmt::format("Plan {}", p));
    entity("select", "plan",
           {{"name", "Training plan"},
            {"state_topic", state},
            {"value_template", "{{ value_json.plan_select }}"},
            {"command_topic", m.base + "/set/start"},
            {"command_template",
             "{\"mode\": \"plan\", \"plan\": {{ value[-1] | int }}, \"ts\": {{ now().timestamp() | int }}}"},
            {"options", plan_options}});
  }

  // `command_effect`: the poll right after a command, published at once and
  // not counted by --max-rate. Counting it shifted the regular publishes by
  // up to a period behind their polls (a change waited 0.9 s at 2 Hz).
  // --max-rate as the gap between two documents. A poll's timing jitters by a
  // few ms: a regular poll at the rate limit is not held back a whole period
  // for being 1 ms early.
  std::chrono::duration<double> min_publish_gap() const {
    return std::chrono::duration<double>(options.max_rate > 0 ? std::max(0.0, 1.0 / options.max_rate - 0.025)
                                                              : 0);
  }

  void publish_state(Machine& m, const Json& doc, Clock::time_point now, bool command_effect = false) {
    const std::string text = doc.dump();
    if (text == m.last_state) {
      m.state_pending = false;
      return;
    }
    if (!command_effect && now - m.last_state_publish < min_publish_gap()) {
      m.state_pending = true;  // published by the loop once the gap has passed
      m.pending_doc = doc;
      return;
    }
    m.last_state = text;
    if (!command_effect) m.last_state_publish = now;
    m.state_pending = false;
    m.publish(m.base + "/state", text, true);
    for (const char* key : {"mode", "state", "speed", "time", "remaining_s", "elapsed_s", "mosfet_c",
                            "motor_c", "current_a", "rpm", "bus_v", "faults"}) {
      const std::string v = doc[key].is_string() ? doc[key].get<std::string>() : doc[key].dump();
      std::string& last = m.last_values[key];
      if (last == v) continue;
      last = v;
      m.publish(m.base + "/value/" + key, v, true);
    }
  }

  void set_online(Machine& m, bool online) {
    if (m.online == online && !m.announce) return;
    m.online = online;
    m.publish(m.base + "/availability", online ? "online" : "offline", true);
  }

  void run_commands(Machine& m) {
    std::deque<Command> todo;
    {
      std::lock_guard g(m.mutex);
      todo.swap(m.commands);
    }
    for (const Command& c : todo) {
      Json result{{"command", c.name}, {"at", iso_time(clock.wall())}};
      // A caller's correlation id comes back with the answer.
      if (const Json body = Json::parse(c.payload, nullptr, false); body.is_object() && body.contains("id"))
        result["id"] = body["id"];
      const rtukit::Status e = run_command(m, c, result);
      result["ok"] = !e;
      if (e) ij::describe_failure(e, result);  // "error", and "code" and "advice" for programs
      m.publish(m.base + "/result", result.dump(), false);
      ++m.commands_run;
      if (!e) m.schedule.poll_soon();  // show the effect at once
    }
  }

  // One machine's turn: its commands first, then what is held back, the
  // health figures, and the poll if it is due. Returns when it is next due.
  Clock::time_point step(Machine& m, Clock::time_point now) {
    if (m.announce.exchange(false)) {
      publish_discovery(m);
      m.publish(m.base + "/availability", m.online ? "online" : "offline", true);
      m.last_state.clear();  // the broker may have lost retained messages: publish again
      m.last_values.clear();
    }
    run_commands(m);
    if (m.state_pending && now - m.last_state_publish >= min_publish_gap())
      publish_state(m, Json(m.pending_doc), now);
    if (now - m.last_stats >= kStatsPeriod) {
      m.last_stats = now;
      m.publish(m.base + "/bridge",
                Json{{"polls", m.schedule.polls()},
                     {"late_polls", m.schedule.late_polls()},
                     {"max_poll_gap_ms",
                      std::lround(std::chrono::duration<double, std::milli>(m.schedule.worst_gap()).count())},
                     {"commands", m.commands_run}}
                    .dump(),
                false, 0);
    }
    if (m.schedule.due(now)) {
      const bool command_effect = now < m.schedule.next();  // an extra poll
      const Result<ij::MachineStatus> s = m.client.status();
      m.schedule.polled(now, bool(s));
      if (!s) {
        // Offline: polled again after the schedule's back-off, so it costs
        // the others one response timeout per back-off at most.
        if (m.schedule.offline()) set_online(m, false);
      } else {
        set_online(m, true);
        m.remembered = ij::remember_family(*s, m.remembered);
        publish_state(m, ij::state_document(*s, m.remembered), now, command_effect);
      }
    }
    Clock::time_point next = std::min(m.schedule.next(), m.last_stats + kStatsPeriod);
    if (m.state_pending)
      next = std::min(next,
                      m.last_state_publish + std::chrono::duration_cast<Clock::duration>(min_publish_gap()));
    return next;
  }
};

BridgeLogic::BridgeLogic(Master& master, const BridgeOptions& options, DriverClock& clock, Publish publish)
    : impl_(std::make_unique<Impl>(master, options, clock, std::move(publish))) {}

BridgeLogic::~BridgeLogic() = default;

size_t BridgeLogic::machines() const {
  return impl_->machines.size();
}

const std::string& BridgeLogic::base(size_t machine) const {
  return impl_->machines.at(machine)->base;
}

bool BridgeLogic::queue_command(size_t machine, std::string name, std::string payload, bool retained) {
  Machine& m = *impl_->machines.at(machine);
  Command c{std::move(name), std::move(payload), retained};
  {
    std::lock_guard lock(m.mutex);
    if (m.commands.size() < kCommandQueueLimit) {
      m.commands.push_back(std::move(c));
      return true;
    }
  }
  // A flood is cut, not queued, and every command cut gets its answer:
  // a sender that hears nothing would not know to try again.
  Json result{{"command", profile::excerpt(c.name, 40)}, {"at", iso_time(impl_->clock.wall())}};
  ij::describe_busy(
      fmt::format("busy: {} commands are waiting for the machine; send it again", kCommandQueueLimit),
      result);
  if (const Json body = Json::parse(c.payload, nullptr, false); body.is_object() && body.contains("id"))
    result["id"] = body["id"];
  m.publish(m.base + "/result", result.dump(-1, ' ', false, Json::error_handler_t::replace), false);
  return false;
}

void BridgeLogic::announce(size_t machine) {
  impl_->machines.at(machine)->announce = true;
}

Clock::time_point BridgeLogic::step(Clock::time_point now) {
  Clock::time_point next = Clock::time_point::max();
  for (auto& m : impl_->machines) next = std::min(next, impl_->step(*m, now));
  return next;
}

// ---------------------------------------------------------------- the bridge: MQTT and the bus worker

namespace {

/// One machine's MQTT connection. Its callbacks run on libmosquitto's
/// network thread: they only queue commands, set flags and wake the worker.
struct Connection {
  ~Connection() {
    if (mosq) mosquitto_destroy(mosq);
  }
  size_t index = 0;
  std::string base;
  BridgeLogic* logic = nullptr;
  BusWorker* worker = nullptr;
  mosquitto* mosq = nullptr;
  std::string client_id;
  std::atomic<bool> connected{false};
  std::atomic<int> connack{-1};    ///< the broker's last answer to a connect (0 accepted), -1 none yet
  std::atomic<unsigned> acked{0};  ///< QoS 1 publishes the broker acknowledged

  void publish(const MqttMessage& m) {
    mosquitto_publish(mosq, nullptr, m.topic.c_str(), static_cast<int>(m.payload.size()), m.payload.data(),
                      m.qos, m.retain);
  }

  static void on_connect(mosquitto* mq, void* self, int rc) {
    auto& c = *static_cast<Connection*>(self);
    c.connack = rc;
    if (rc != 0) return;  // refused (credentials): libmosquitto retries with back-off
    c.connected = true;
    const std::string topic = c.base + "/set/#";
    // Retain as published: a command someone left retained arrives with its
    // retain flag even while we are subscribed, and is refused as such.
    mosquitto_subscribe_v5(mq, nullptr, topic.c_str(), 1, MQTT_SUB_OPT_RETAIN_AS_PUBLISHED, nullptr);
    c.logic->announce(c.index);
    c.worker->wake();
  }
  static void on_disconnect(mosquitto*, void* self, int) {
    static_cast<Connection*>(self)->connected = false;
  }
  static void on_publish(mosquitto*, void* self, int) { ++static_cast<Connection*>(self)->acked; }
  static void on_message(mosquitto*, void* self, const mosquitto_message* msg) {
    auto& c = *static_cast<Connection*>(self);
    const std::string topic = msg->topic;
    const std::string prefix = c.base + "/set/";
    if (topic.rfind(prefix, 0) != 0) return;
    if (c.logic->queue_command(
            c.index, topic.substr(prefix.size()),
            std::string(static_cast<const char*>(msg->payload), static_cast<size_t>(msg->payloadlen)),
            msg->retain))
      c.worker->wake();
  }
};

}  // namespace

struct Bridge::Impl {
  Impl(std::unique_ptr<io::Link> link, BridgeOptions o)
      : options(std::move(o)),
        clock(clock_or_steady(options.clock)),
        master(std::move(link),
               MasterOptions{.response_timeout = std::chrono::milliseconds(options.response_timeout_ms),
                             .clock = &clock}),
        logic(master, options, clock,
              [this](size_t machine, const MqttMessage& m) { connections.at(machine)->publish(m); }),
        worker([this](Clock::time_point now) { return logic.step(now); }, {.clock = &clock}) {}

  BridgeOptions options;
  DriverClock& clock;
  Master master;
  std::vector<std::unique_ptr<Connection>> connections;
  BridgeLogic logic;
  BusWorker worker;
  std::string broker_problem;  ///< set by start() when the broker did not take us at once
};

Bridge::Bridge(std::unique_ptr<io::Link> link, BridgeOptions options)
    : impl_(std::make_unique<Impl>(std::move(link), std::move(options))) {}

Bridge::~Bridge() {
  stop();
}

rtukit::Status Bridge::start() {
  Impl& b = *impl_;
  if (b.options.machines.empty()) return rtukit::Status(Errc::invalid_argument, "no machine (--unit)");
  std::set<std::string> ids;
  std::set<uint8_t> units;
  for (const BridgeMachine& m : b.options.machines) {
    if (!valid_topic_level(m.id))
      return rtukit::Status(Errc::invalid_argument,
                            fmt::format("id '{}': one MQTT topic level (no '/', '+', '#', spaces)", m.id));
    if (!ids.insert(m.id).second)
      return rtukit::Status(Errc::invalid_argument, fmt::format("id '{}' twice", m.id));
    if (!units.insert(m.unit).second)
      return rtukit::Status(Errc::invalid_argument, fmt::format("unit {} twice", m.unit));
  }
  // A port that does not exist (or is no serial port) is a start failure, not
  // something to poll in silence: the machine would never be seen.
  if (Error e = b.master.open())
    return rtukit::Status(Errc::io_error,
                          fmt::format("port {}: {}", b.master.describe(),
                                      e.os_error() == ENOTTY ? std::string("not a serial port")
                                      : e.os_error() != 0    ? std::string(std::strerror(e.os_error()))
                                                             : std::string(e.text())));
  mosquitto_lib_init();
  int connect_rc = MOSQ_ERR_SUCCESS, connect_errno = 0;
  for (const BridgeMachine& config : b.options.machines) {
    auto m = std::make_unique<Connection>();
    m->index = b.connections.size();
    m->base = b.logic.base(m->index);
    m->logic = &b.logic;
    m->worker = &b.worker;
    // Unique per machine and per run: nobody takes the id from docs or a guess.
    uint32_t nonce = 0;
    if (::getrandom(&nonce, sizeof nonce, 0) != sizeof nonce)
      return rtukit::Status(Errc::io_error, "getrandom: no random number for the client id");
    m->client_id = fmt::format("rtukit-inverjet-{}-{:08x}", config.id, nonce);
    m->mosq = mosquitto_new(m->client_id.c_str(), true, m.get());
    if (!m->mosq) return rtukit::Status(Errc::io_error, "libmosquitto: cannot create a client");
    mosquitto_int_option(m->mosq, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5);
    if (!b.options.user.empty())
      mosquitto_username_pw_set(m->mosq, b.options.user.c_str(),
                                b.options.password.empty() ? nullptr : b.options.password.c_str());
    if (!b.options.tls_ca.empty()) {
      if (int rc = mosquitto_tls_set(m->mosq, b.options.tls_ca.c_str(), nullptr, nullptr, nullptr, nullptr);
          rc != MOSQ_ERR_SUCCESS)
        return rtukit::Status(Errc::io_error,
                              fmt::format("--tls-ca {}: {}", b.options.tls_ca, mosquitto_strerror(rc)));
    }
    const std::string will = m->base + "/availability";
    mosquitto_will_set(m->mosq, will.c_str(), 7, "offline", 1, true);
    mosquitto_connect_callback_set(m->mosq, &Connection::on_connect);
    mosquitto_disconnect_callback_set(m->mosq, &Connection::on_disconnect);
    mosquitto_message_callback_set(m->mosq, &Connection::on_message);
    mosquitto_publish_callback_set(m->mosq, &Connection::on_publish);
    mosquitto_reconnect_delay_set(m->mosq, 1, 30, true);
    // A broker that is down now is retried by the loop (connect_async).
    errno = 0;
    if (const int rc = mosquitto_connect_async(m->mosq, b.options.host.c_str(), b.options.port, 30);
        rc != MOSQ_ERR_SUCCESS && connect_rc == MOSQ_ERR_SUCCESS) {
      connect_rc = rc;
      connect_errno = errno;
    }
    mosquitto_loop_start(m->mosq);
    b.connections.push_back(std::move(m));
  }
  b.worker.start();
  // The broker answers within moments when it is there. When it does not, the
  // bridge keeps retrying, and says so once (warnings()) instead of in silence.
  const auto all_connected = [&b] {
    return std::all_of(b.connections.begin(), b.connections.end(),
                       [](const auto& m) { return m->connected.load(); });
  };
  const auto refused = [&b] {
    for (const auto& m : b.connections)
      if (m->connack > 0) return m->connack.load();
    return 0;
  };
  // The broker is a real one: these waits are on the real clock.
  DriverClock& real = SteadyClock::instance();
  const auto wait_until = real.now() + std::chrono::seconds(3);
  while (!all_connected() && refused() == 0 && real.now() < wait_until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (!all_connected()) {
    std::string why;
    if (const int rc = refused())
      why = fmt::format("it refuses the connection: {}", mosquitto_reason_string(rc));
    else if (connect_rc == MOSQ_ERR_ERRNO && connect_errno != 0)
      why = std::strerror(connect_errno);
    else if (connect_rc != MOSQ_ERR_SUCCESS)
      why = mosquitto_strerror(connect_rc);
    else
      why = "no answer within 3 s";
    b.broker_problem = fmt::format(
        "the broker at {}:{} does not answer ({}); retrying every 1 s, then less often (every 30 s at most)",
        b.options.host, b.options.port, why);
  }
  return {};
}

std::vector<std::string> Bridge::client_ids() const {
  std::vector<std::string> ids;
  for (const auto& m : impl_->connections) ids.push_back(m->client_id);
  return ids;
}

std::vector<std::string> Bridge::warnings() const {
  const BridgeOptions& o = impl_->options;
  std::vector<std::string> out;
  if (!impl_->broker_problem.empty()) out.push_back(impl_->broker_problem);
  if (o.user.empty())
    out.push_back(
        fmt::format("warning: no broker credentials (--user): if the broker at {} lets anonymous clients in, "
                    "every one of "
                    "them can start the machine (docs/security.md, \"Pool\")",
                    o.host));
  if (o.tls_ca.empty() && !is_loopback_host(o.host))
    out.push_back(
        fmt::format("warning: plain MQTT to {}: credentials and commands cross the network in the clear (use "
                    "mqtts:// and "
                    "--tls-ca)",
                    o.host));
  return out;
}

void Bridge::stop() {
  Impl& b = *impl_;
  if (b.connections.empty()) return;
  b.worker.stop();
  // "offline" for every machine, acknowledged by the broker (1 s at most),
  // before a clean disconnect (which suppresses the last will).
  for (auto& m : b.connections) {
    m->acked = 0;
    if (m->connected) m->publish({m->base + "/availability", "offline", true, 1});
  }
  DriverClock& real = SteadyClock::instance();  // the broker's acknowledgements: real time
  const auto deadline = real.now() + std::chrono::seconds(1);
  for (auto& m : b.connections)
    while (m->connected && m->acked == 0 && real.now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
  for (auto& m : b.connections) {
    mosquitto_disconnect(m->mosq);
    mosquitto_loop_stop(m->mosq, false);
  }
  b.connections.clear();
  mosquitto_lib_cleanup();
}

}  // namespace rtukit::programs
