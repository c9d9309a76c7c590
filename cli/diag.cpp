// `rtukit diag` (FC07, FC08, FC0B, FC0C: what a slave saw on its line) and
// `rtukit ident` (FC2B/0E and FC11: who the device is).
#include <fmt/core.h>
#include <fmt/format.h>

#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/tool/diagnostics.hpp"
#include "rtukit/tool/protocol_text.hpp"

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

// A library step's failure: its code and its context, as fail() words them.
using cli::fail;
[[noreturn]] void fail(const Status& s) {
  fail(s.error(), s.reason());
}

int run_diag(const DiagArgs& a) {
  const UnitId unit = parse_unit(a.unit, a.link.spec(false).kind == io::PortSpec::Kind::tcp);
  if (unit == kBroadcast) throw Failure{kUsage, "diagnostics need an answer: unit 0 (broadcast) has none"};
  if (!a.data.empty() && a.action != "echo")
    throw Failure{kUsage, fmt::format("'{}' takes no data (only echo does)", a.action)};
  auto master = a.link.make_master();
  Json doc = json_document({}, unit.value);
  doc["action"] = a.action;
  if (a.action == "counters") {
    tool::DiagCounters c;
    const Status s = tool::read_counters(*master, unit, c);
    Json counters = Json::object();
    for (size_t i = 0; i < c.values.size(); ++i) {
      counters[tool::diag_counters()[i].key] = c.values[i];
      if (!a.json) fmt::print("{:<22} {}\n", tool::diag_counters()[i].text, c.values[i]);
    }
    if (s) fail(s);
    counters["exception_status"] = c.exception_status;
    counters["event_count"] = c.event_count;
    doc["counters"] = counters;
    if (!a.json) {
      fmt::print("{:<22} 0x{:02X}\n", "exception status", c.exception_status);
      fmt::print("{:<22} {}\n", "completed requests", c.event_count);
    }
  } else if (a.action == "events") {
    const auto log = tool::read_event_log(*master, unit);
    if (!log.ok()) fail(log.error());
    doc["status"] = log->status;
    doc["event_count"] = log->event_count;
    doc["message_count"] = log->message_count;
    Json events = Json::array();
    for (uint8_t e : log->events) events.push_back({{"code", e}, {"text", tool::comm_event_text(e)}});
    doc["events"] = events;
    if (!a.json) {
      fmt::print("{} completed requests, {} bus messages{}; the newest event first:\n", log->event_count,
                 log->message_count, log->status ? " (busy)" : "");
      for (uint8_t e : log->events) fmt::print("  0x{:02X}  {}\n", e, tool::comm_event_text(e));
    }
  } else if (a.action == "echo") {
    std::vector<uint8_t> data;
    for (const std::string& d : a.data)
      data.push_back(static_cast<uint8_t>(parse_number(d, "echo byte", 0, 255)));
    const auto echo = tool::echo(*master, unit, std::move(data), time_source());
    if (!echo.ok()) fail(echo.error());
    if (!echo->same())
      throw Failure{kNoResponse,
                    fmt::format("echo from {} differs: sent {}, got {}", tool::unit_where(unit, *master),
                                hex(echo->sent), hex(echo->answer))};
    doc["echo"] = hex(echo->sent);
    doc["ms"] = echo->ms;
    if (!a.json)
      fmt::print("echo ok: {} ({} bytes) in {:.1f} ms\n", hex(echo->sent), echo->sent.size(), echo->ms);
  } else if (a.action == "clear") {
    if (const Status s = tool::clear_counters(*master, unit)) fail(s);
    if (!a.json) fmt::print("counters and diagnostic register cleared\n");
  } else if (a.action == "restart") {
    const auto answered = tool::restart_communications(*master, unit, a.clear_log);
    if (!answered.ok()) fail(answered.error());
    doc["answered"] = *answered;
    if (!a.json)
      fmt::print("{}\n", !*answered
                             ? "restart sent (no answer: it was in listen-only mode, and now listens again)"
                             : "communications restarted, counters cleared" +
                                   std::string(a.clear_log ? ", event log cleared" : ""));
  } else if (a.action == "listen-only") {
    if (const Status s = tool::force_listen_only(*master, unit)) fail(s);
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
  Json doc = json_document({}, unit.value);
  if (a.server_id) {
    const auto id = tool::report_server_id(*master, unit);
    if (!id.ok()) fail(id.error());
    const std::string data = id->printable ? id->text : hex(id->data);
    doc["server_id"] = id->id;
    doc["running"] = id->running;
    doc["data"] = data;
    if (a.json) {
      print_json(doc);
    } else {
      if (id->has_head) fmt::print("server id {}, {}\n", id->id, id->running ? "running" : "stopped");
      fmt::print("{}\n", data);
    }
    return kOk;
  }
  const auto access = tool::device_id_access(a.level, a.object >= 0);
  if (!access.ok()) throw Failure{kUsage, std::string(access.error().reason())};
  const auto id =
      tool::read_identification(*master, unit, *access, a.object >= 0 ? static_cast<uint8_t>(a.object) : 0);
  if (!id.ok()) fail(id.error());
  doc["conformity"] = id->level;
  Json objects = Json::object();
  for (const auto& [name, text] : id->objects) objects[name] = text;
  doc["objects"] = objects;
  if (a.json) {
    print_json(doc);
    return kOk;
  }
  for (const auto& [name, text] : id->objects) fmt::print("{:<13} {}\n", name, text);
  fmt::print("(conformity: {}{})\n", id->level, id->individual ? ", individual access" : "");
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
