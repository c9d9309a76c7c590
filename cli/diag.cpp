// `rtukit diag` (FC07, FC08, FC0B, FC0C: what a slave saw on its line) and
// `rtukit ident` (FC2B/0E and FC11: who the device is).
#include <fmt/core.h>
#include <fmt/format.h>

#include <chrono>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/devices/profile/protocol_text.hpp"

namespace rtukit::cli {
namespace {

struct DiagArgs {
  LinkOptions link;
  std::string unit = "1";
  std::string action = "counters";
  std::vector<std::string> data;  ///< echo: hex bytes
  bool clear_log = false;
  bool json = false;
};

// The FC08 counters in the specification's order.
struct CounterName {
  Diagnostic sub;
  const char* key;
  const char* text;
};
constexpr CounterName kCounters[] = {
    {Diagnostic::bus_message_count, "bus_messages", "bus messages"},
    {Diagnostic::bus_communication_error_count, "bus_crc_errors", "bus CRC errors"},
    {Diagnostic::bus_exception_error_count, "bus_exceptions", "exceptions sent"},
    {Diagnostic::server_message_count, "server_messages", "messages to this unit"},
    {Diagnostic::server_no_response_count, "server_no_response", "left unanswered"},
    {Diagnostic::server_nak_count, "server_nak", "NAK sent"},
    {Diagnostic::server_busy_count, "server_busy", "busy (06) sent"},
    {Diagnostic::bus_character_overrun_count, "bus_overruns", "character overruns"},
    {Diagnostic::return_diagnostic_register, "diagnostic_register", "diagnostic register"},
};

// One FC0C event byte in words.
std::string event_text(uint8_t e) {
  return profile::comm_event_text(e);
}

int run_diag(const DiagArgs& a) {
  const UnitId unit = parse_unit(a.unit, a.link.spec(false).kind == io::PortSpec::Kind::tcp);
  if (unit == kBroadcast) throw Failure{kUsage, "diagnostics need an answer: unit 0 (broadcast) has none"};
  if (!a.data.empty() && a.action != "echo")
    throw Failure{kUsage, fmt::format("'{}' takes no data (only echo does)", a.action)};
  auto master = a.link.make_master();
  const std::string where = fmt::format("unit {} on {}", unit.value, master->describe());
  Json doc = json_document({}, unit.value);
  doc["action"] = a.action;
  std::vector<uint8_t> answer;
  if (a.action == "counters") {
    Json counters = Json::object();
    for (const CounterName& c : kCounters) {
      uint16_t v = 0;
      if (Error e = master->diagnostic_value(unit, c.sub, v))
        fail(e, fmt::format("FC08 diagnostics sub-function 0x{:02X} ({}) to {}", static_cast<unsigned>(c.sub),
                            c.text, where));
      counters[c.key] = v;
      if (!a.json) fmt::print("{:<22} {}\n", c.text, v);
    }
    uint8_t status = 0;
    if (Error e = master->read_exception_status(unit, status))
      fail(e, "FC07 read exception status from " + where);
    Master::CommEvents events;
    if (Error e = master->comm_events(unit, false, events))
      fail(e, "FC0B get comm event counter from " + where);
    counters["exception_status"] = status;
    counters["event_count"] = events.event_count;
    doc["counters"] = counters;
    if (!a.json) {
      fmt::print("{:<22} 0x{:02X}\n", "exception status", status);
      fmt::print("{:<22} {}\n", "completed requests", events.event_count);
    }
  } else if (a.action == "events") {
    Master::CommEvents log;
    if (Error e = master->comm_events(unit, true, log)) fail(e, "FC0C get comm event log from " + where);
    doc["status"] = log.status;
    doc["event_count"] = log.event_count;
    doc["message_count"] = log.message_count;
    Json events = Json::array();
    for (uint8_t e : log.events) events.push_back({{"code", e}, {"text", event_text(e)}});
    doc["events"] = events;
    if (!a.json) {
      fmt::print("{} completed requests, {} bus messages{}; the newest event first:\n", log.event_count,
                 log.message_count, log.status ? " (busy)" : "");
      for (uint8_t e : log.events) fmt::print("  0x{:02X}  {}\n", e, event_text(e));
    }
  } else if (a.action == "echo") {
    std::vector<uint8_t> data;
    for (const std::string& d : a.data)
      data.push_back(static_cast<uint8_t>(parse_number(d, "echo byte", 0, 255)));
    if (data.empty()) data = {0xA5, 0x37};
    const auto t0 = time_source().now();
    if (Error e = master->diagnostics(unit, Diagnostic::return_query_data, data, answer))
      fail(e, "FC08 return query data to " + where);
    const double ms = std::chrono::duration<double, std::milli>(time_source().now() - t0).count();
    if (answer != data)
      throw Failure{kNoResponse,
                    fmt::format("echo from {} differs: sent {}, got {}", where, hex(data), hex(answer))};
    doc["echo"] = hex(data);
    doc["ms"] = ms;
    if (!a.json) fmt::print("echo ok: {} ({} bytes) in {:.1f} ms\n", hex(data), data.size(), ms);
  } else if (a.action == "clear") {
    const uint8_t zero[2] = {0, 0};
    if (Error e = master->diagnostics(unit, Diagnostic::clear_counters, zero, answer))
      fail(e, "FC08 clear counters to " + where);
    if (!a.json) fmt::print("counters and diagnostic register cleared\n");
  } else if (a.action == "restart") {
    const uint8_t data[2] = {static_cast<uint8_t>(a.clear_log ? 0xFF : 0x00), 0x00};
    // A unit in listen-only mode restarts without answering.
    const Error e = master->diagnostics(unit, Diagnostic::restart_communications, data, answer);
    if (e && e.code() != Errc::timeout) fail(e, "FC08 restart communications to " + where);
    doc["answered"] = !e;
    if (!a.json)
      fmt::print("{}\n", e ? "restart sent (no answer: it was in listen-only mode, and now listens again)"
                           : "communications restarted, counters cleared" +
                                 std::string(a.clear_log ? ", event log cleared" : ""));
  } else if (a.action == "listen-only") {
    const uint8_t zero[2] = {0, 0};
    if (Error e = master->diagnostics(unit, Diagnostic::force_listen_only, zero, answer))
      fail(e, "FC08 force listen only mode to " + where);
    if (!a.json)
      fmt::print("unit {} now only listens: it answers nothing until `rtukit diag restart`\n", unit.value);
  } else {
    throw Failure{
        kUsage, fmt::format("diag {}: use counters, events, echo, clear, restart or listen-only", a.action)};
  }
  if (a.link.stats) print_stats(*master);
  if (a.json) print_json(doc);
  return kOk;
}

struct IdentArgs {
  LinkOptions link;
  std::string unit = "1";
  std::string level = "regular";
  int object = -1;
  bool server_id = false;
  bool json = false;
};

int run_ident(const IdentArgs& a) {
  const UnitId unit = parse_unit(a.unit, a.link.spec(false).kind == io::PortSpec::Kind::tcp);
  if (unit == kBroadcast)
    throw Failure{kUsage, "identification needs an answer: unit 0 (broadcast) has none"};
  auto master = a.link.make_master();
  const std::string where = fmt::format("unit {} on {}", unit.value, master->describe());
  Json doc = json_document({}, unit.value);
  if (a.server_id) {
    std::vector<uint8_t> data;
    if (Error e = master->report_server_id(unit, data)) fail(e, "FC11 report server id to " + where);
    // Server id, run indicator, then device-specific bytes (text when printable).
    const bool has_head = data.size() >= 2;
    std::string rest;
    bool printable = true;
    for (size_t i = has_head ? 2 : 0; i < data.size(); ++i) {
      printable = printable && data[i] >= 0x20 && data[i] < 0x7F;
      rest += static_cast<char>(data[i]);
    }
    doc["server_id"] = has_head ? data[0] : 0;
    doc["running"] = has_head && data[1] == 0xFF;
    doc["data"] = printable ? rest : hex(data);
    if (a.json) {
      print_json(doc);
    } else {
      if (has_head) fmt::print("server id {}, {}\n", data[0], data[1] == 0xFF ? "running" : "stopped");
      fmt::print("{}\n", printable ? rest : hex(data));
    }
    return kOk;
  }
  DeviceIdAccess access = DeviceIdAccess::regular;
  if (a.object >= 0)
    access = DeviceIdAccess::individual;
  else if (a.level == "basic")
    access = DeviceIdAccess::basic;
  else if (a.level == "extended")
    access = DeviceIdAccess::extended;
  else if (a.level != "regular")
    throw Failure{kUsage, fmt::format("--level {}: use basic, regular or extended", a.level)};
  Master::DeviceIdentification id;
  if (Error e = master->read_device_identification(unit, access, id,
                                                   a.object >= 0 ? static_cast<uint8_t>(a.object) : 0))
    fail(e, "FC2B/0E read device identification from " + where);
  const char* level_name = profile::conformity_level_name(id.conformity);
  doc["conformity"] = level_name;
  Json objects = Json::object();
  for (const auto& [oid, text] : id.objects) {
    const char* name = profile::device_object_name(oid);
    objects[name ? std::string(name) : fmt::format("0x{:02X}", oid)] = text;
  }
  doc["objects"] = objects;
  if (a.json) {
    print_json(doc);
    return kOk;
  }
  for (const auto& [oid, text] : id.objects) {
    const char* name = profile::device_object_name(oid);
    fmt::print("{:<13} {}\n", name ? std::string(name) : fmt::format("0x{:02X}", oid), text);
  }
  fmt::print("(conformity: {}{})\n", level_name, id.conformity & 0x80 ? ", individual access" : "");
  return kOk;
}

}  // namespace

void add_diag_commands(CLI::App& app, Action& action) {
  add_command<DiagArgs>(
      app, action, "diag",
      "what a slave saw on its line: counters, event log, echo, listen-only (FC07/08/0B/0C)",
      [](CLI::App& cmd, DiagArgs& a) {
        cmd.add_option("action", a.action, "counters | events | echo [BYTES] | clear | restart | listen-only")
            ->capture_default_str()
            ->check(CLI::IsMember({"counters", "events", "echo", "clear", "restart", "listen-only"}));
        cmd.add_option("data", a.data, "echo: the bytes to send (default A5 37)");
        cmd.add_option("--unit,-u", a.unit, "slave unit address")->capture_default_str();
        cmd.add_flag("--clear-log", a.clear_log, "restart: clear the event log too");
        cmd.add_flag("--json", a.json, "print the result as JSON (docs/json.md)");
        a.link.add_to(cmd, false);
        examples(cmd, {"rtukit diag --port /dev/ttyUSB0 --baud 19200 --unit 21",
                       "rtukit diag --port /dev/ttyUSB0 --unit 21 echo 0x12 0x34",
                       "rtukit diag --port /dev/ttyUSB0 --unit 21 events",
                       "rtukit diag --port /dev/ttyUSB0 --unit 21 listen-only   (then: diag restart)"});
      },
      [](const DiagArgs& a) { return run_diag(a); });
  add_command<IdentArgs>(
      app, action, "ident", "who the device is: vendor, product code, revision (FC2B/0E, FC11)",
      [](CLI::App& cmd, IdentArgs& a) {
        cmd.add_option("--unit,-u", a.unit, "slave unit address")->capture_default_str();
        cmd.add_option("--level", a.level, "basic | regular | extended")
            ->capture_default_str()
            ->check(CLI::IsMember({"basic", "regular", "extended"}));
        cmd.add_option("--object", a.object, "one object by id (individual access)")
            ->check(CLI::Range(0, 255));
        cmd.add_flag("--server-id", a.server_id, "FC11 report server id instead");
        cmd.add_flag("--json", a.json, "print the result as JSON (docs/json.md)");
        a.link.add_to(cmd, false);
        examples(cmd, {"rtukit ident --port /dev/ttyUSB0 --baud 19200 --unit 21",
                       "rtukit ident --port tcp://127.0.0.1:1502 --unit 1 --level extended --json",
                       "rtukit ident --port /dev/ttyUSB0 --unit 21 --server-id"});
      },
      [](const IdentArgs& a) { return run_ident(a); });
}

}  // namespace rtukit::cli
