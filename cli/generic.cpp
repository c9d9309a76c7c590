// The generic subcommands: read, write, scan, slave. Protocol work is done by
// the library; this file only turns arguments into calls and results into text.
#include <fmt/core.h>
#include <fmt/format.h>

#include <chrono>
#include <cstring>
#include <ctime>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.hpp"
#include "common.hpp"
#include "profiles.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/tool/address_notation.hpp"
#include "rtukit/tool/bank_file.hpp"
#include "rtukit/tool/typed_request.hpp"

namespace rtukit::cli {
namespace {

using profile::Space;

// Addresses as typed and shown, tables as output names them, reads and
// writes planned, sent and shown: the kit's (profile/typed_request.hpp).
using tool::put_address;
using tool::ReadPlan;
using tool::table_name;

// A reference is never taken silently: the same digits may also be a plain
// address (parse_address's note), so the note is printed, also before a refusal.
void print_note(std::string_view note) {
  if (!note.empty()) fmt::print(stderr, "note: {}\n", note);
}

// --type and --word-order as the kit's (profile/typed_value.hpp); CLI11 checked the names.
profile::ValueType value_type_of(const std::string& type) {
  return profile::value_type(type).value_or(profile::ValueType::u16);
}
profile::WordOrder word_order_of(const std::string& order) {
  return order == "low-first" ? profile::WordOrder::low_first : profile::WordOrder::high_first;
}

void add_type_options(CLI::App& cmd, std::string& type, std::string& order) {
  cmd.add_option("--type,-t", type, "u16 | i16 | u32 | i32 | f32 (32-bit types span two registers)")
      ->check(CLI::IsMember({"u16", "i16", "u32", "i32", "f32"}))
      ->capture_default_str();
  cmd.add_option("--word-order", order, "32-bit word order: high-first | low-first")
      ->check(CLI::IsMember({"high-first", "low-first"}))
      ->capture_default_str();
}

struct ReadArgs {
  LinkOptions link;
  std::string unit = "1";
  bool holding = false, input = false, coils = false, discrete = false;
  std::vector<std::string> operands;  ///< ADDRESS [COUNT], or KEY... with --map
  std::string map;
  bool unit_given = false;
  std::string address;
  std::string count = "1";
  std::string type = "u16";
  std::string order = "high-first";
  std::string format = "dec";
  bool json = false;
  bool one_based = false;
};

// The read/poll arguments as the kit's plan (profile/typed_request.hpp);
// a refused plan is a usage error, and a reference's note is printed even then.
ReadPlan plan_read(ReadArgs& a) {
  if (a.operands.empty() || a.operands.size() > 2)
    throw Failure{kUsage, "read takes ADDRESS [COUNT] (or --map FILE [KEY...])"};
  a.address = a.operands[0];
  if (a.operands.size() == 2) a.count = a.operands[1];
  const bool tcp = a.link.spec(false).kind == io::PortSpec::Kind::tcp;
  const tool::ReadRequest request{.unit = parse_unit(a.unit, tcp),
                                  .tcp = tcp,
                                  .tables_named = unsigned{a.holding} + a.input + a.coils + a.discrete,
                                  .table = a.input      ? Space::input
                                           : a.coils    ? Space::coil
                                           : a.discrete ? Space::discrete
                                                        : Space::holding,
                                  .address = a.address,
                                  .count = a.count,
                                  .type = value_type_of(a.type),
                                  .order = word_order_of(a.order),
                                  .one_based = a.one_based};
  std::string note;
  Outcome<ReadPlan> plan = tool::plan_read(request, &note);
  print_note(note);
  if (!plan.ok()) throw Failure{kUsage, std::string(plan.error().reason())};
  return *plan;
}

std::string value_text(const nlohmann::json& v, const ReadArgs& a, const ReadPlan& p) {
  return tool::value_text(v, p, a.format == "hex");
}

int run_read(ReadArgs a) {
  if (!a.map.empty()) return run_map_read(a.link, a.unit_given ? a.unit : "", a.map, a.operands, a.json);
  const ReadPlan p = plan_read(a);
  auto master = a.link.make_master();
  nlohmann::json values;
  const Error e = tool::read_values(*master, p, values);
  if (a.link.stats) print_stats(*master);
  if (e) fail(e, tool::read_context(p, *master));
  if (a.json) {
    Json out = json_document({}, p.unit.value);
    out["table"] = table_name(p.table);
    put_address(out, p.notation, p.address);
    out["type"] = p.bits ? "bit" : a.type;
    out["values"] = values;
    print_json(out);
    return kOk;
  }
  for (size_t i = 0; i < p.count; ++i) {
    const size_t at = p.address + i * p.per_value;
    fmt::print("{}: {}\n", p.notation.where(at), value_text(values[i], a, p));
  }
  return kOk;
}

// `rtukit poll`: mbpoll's -l, with a timestamp on every line. A failed poll
// is a line too (the bus glitched), and polling goes on.
struct PollArgs {
  ReadArgs read;
  WatchOptions watch{1000};
  std::string output = "table";
};

int run_poll(PollArgs args) {
  ReadArgs& a = args.read;
  const ReadPlan p = plan_read(a);
  auto master = a.link.make_master();
  const std::string context = tool::read_context(p, *master);
  if (args.output == "csv") {
    std::string header = "time";
    for (size_t i = 0; i < p.count; ++i) header += "," + p.notation.text(p.address + i * p.per_value);
    fmt::print("{},error\n", header);
  }
  Error last;
  unsigned failures = 0, polls = 0;
  watch_loop(args.watch, [&](unsigned) {
    nlohmann::json values;
    last = tool::read_values(*master, p, values);
    ++polls;
    if (last) ++failures;
    Json line = json_document({}, p.unit.value);
    const std::string time = line["time"];
    if (args.output == "jsonl") {
      line["table"] = table_name(p.table);
      put_address(line, p.notation, p.address);
      line["type"] = p.bits ? "bit" : a.type;
      if (last) {
        line["ok"] = false;
        line["error"] = {{"kind", last.name()}, {"message", std::string(last.text())}};
      } else {
        line["values"] = values;
      }
      print_json(line);
    } else if (args.output == "csv") {
      std::string row = time;
      for (size_t i = 0; i < p.count; ++i) row += "," + (last ? std::string() : value_text(values[i], a, p));
      fmt::print("{},{}\n", row, last ? std::string(last.text()) : "");
    } else {
      std::string row = time;
      if (last) row += fmt::format("  error: {}", last.text());
      for (size_t i = 0; !last && i < p.count; ++i)
        row += fmt::format("  [{}]={}", p.notation.text(p.address + i * p.per_value),
                           value_text(values[i], a, p));
      fmt::print("{}\n", row);
    }
  });
  if (a.link.stats) print_stats(*master);
  fmt::print(stderr, "poll: {} polls, {} failed\n", polls, failures);
  if (polls > 0 && failures == polls) fail(last, context);
  return kOk;
}

struct WriteArgs {
  LinkOptions link;
  std::string unit = "1";
  std::string address;
  std::vector<std::string> values;
  bool multiple = false;
  bool coils = false;
  std::string type = "u16";
  std::string order = "high-first";
  bool one_based = false;
  bool json = false;
  bool quiet = false;             ///< no line on success
  std::vector<std::string> mask;  ///< FC16: AND OR
};

int run_write(const WriteArgs& a) {
  if (!a.mask.empty() && (a.coils || a.multiple || !a.values.empty()))
    throw Failure{kUsage, "--mask AND OR writes one register: no values, --coils or --multiple with it"};
  if (a.mask.empty() && a.values.empty()) throw Failure{kUsage, "write needs values (or --mask AND OR)"};
  const bool tcp = a.link.spec(false).kind == io::PortSpec::Kind::tcp;
  const UnitId unit = parse_unit(a.unit, tcp);
  // Checked and encoded by the kit (profile/typed_request.hpp) before the port is opened.
  std::string note;
  const tool::WriteRequest request{.unit = unit,
                                   .address = a.address,
                                   .one_based = a.one_based,
                                   .coils = a.coils,
                                   .multiple = a.multiple,
                                   .values = a.values,
                                   .mask = a.mask,
                                   .type = value_type_of(a.type),
                                   .order = word_order_of(a.order)};
  Outcome<tool::WritePlan> plan = tool::plan_write(request, &note);
  print_note(note);
  if (!plan.ok()) throw Failure{kUsage, std::string(plan.error().reason())};
  const tool::WritePlan& p = *plan;
  auto master = a.link.make_master();
  const std::string context = tool::write_context(p, *master);
  const Error e = tool::send_write(*master, p);
  if (a.link.stats) print_stats(*master);
  if (e) fail(e, context);
  const std::string text = tool::write_text(request, p, tcp);
  if (a.json) {
    Json out = json_document({}, unit.value);
    out["table"] = a.coils ? "coils" : "holding";
    put_address(out, p.notation, p.address);
    out["written"] = a.values.size();
    out["text"] = text;
    print_json(out);
  } else if (!a.quiet) {
    fmt::print("{}\n", text);
  }
  return kOk;
}

struct ReadWriteArgs {
  LinkOptions link;
  std::string unit = "1";
  std::string read_address, write_address;
  unsigned count = 1;
  std::vector<std::string> values;
  bool json = false;
  bool one_based = false;
};

int run_readwrite(const ReadWriteArgs& a) {
  const UnitId unit = parse_unit(a.unit, a.link.spec(false).kind == io::PortSpec::Kind::tcp);
  std::vector<std::string> notes;
  Outcome<tool::ReadWritePlan> plan = tool::plan_readwrite({.unit = unit,
                                                            .read_address = a.read_address,
                                                            .count = static_cast<uint16_t>(a.count),
                                                            .write_address = a.write_address,
                                                            .values = a.values,
                                                            .one_based = a.one_based},
                                                           &notes);
  for (const std::string& note : notes) print_note(note);
  if (!plan.ok()) throw Failure{kUsage, std::string(plan.error().reason())};
  const tool::ReadWritePlan& p = *plan;
  auto master = a.link.make_master();
  std::vector<uint16_t> out(p.count);
  const Error e = master->read_write_multiple_registers(unit, p.read_at, out, p.write_at, p.values);
  if (a.link.stats) print_stats(*master);
  if (e) fail(e, tool::readwrite_context(p, *master));
  if (a.json) {
    Json doc = json_document({}, unit.value);
    doc["table"] = "holding";
    Json written;
    put_address(written, p.write_notation, p.write_at);
    written["count"] = p.values.size();
    doc["written"] = written;
    put_address(doc, p.read_notation, p.read_at);
    doc["values"] = out;
    print_json(doc);
    return kOk;
  }
  for (size_t i = 0; i < out.size(); ++i)
    fmt::print("{}: {}\n", p.read_notation.where(p.read_at + i), out[i]);
  return kOk;
}

struct ScanArgs {
  LinkOptions link;
  std::string units = fmt::format("1-{}", kMaxSerialUnit);
  bool json = false;
};

int run_scan(const ScanArgs& a) {
  const bool tcp = a.link.spec(false).kind == io::PortSpec::Kind::tcp;
  const std::vector<unsigned> units = parse_units(a.units, tcp ? 255 : kMaxSerialUnit);
  auto master = a.link.make_master();
  if (Error e = master->open()) fail(e, fmt::format("scan on {}", master->describe()));
  // 247 units at 100 ms is 25 s of silence: on a terminal, a line says how far
  // the scan is and what it found (stderr; pipes and files get none of it).
  Progress progress;
  nlohmann::json found = nlohmann::json::array();
  std::string found_text;
  for (size_t i = 0; i < units.size(); ++i) {
    const unsigned u = units[i];
    progress.show(fmt::format("scan: unit {} ({} of {}), {} found{}{}", u, i + 1, units.size(), found.size(),
                              found.empty() ? "" : ": ", found_text));
    uint16_t reg = 0;
    const Error e = master->read_holding_registers(UnitId{static_cast<uint8_t>(u)}, 0, {&reg, 1});
    // An exception is an answer too: the unit is there.
    if (e.ok() || e.is_exception()) {
      found.push_back(u);
      found_text += fmt::format("{}{}", found_text.empty() ? "" : ", ", u);
      if (!a.json) {
        progress.clear();
        fmt::print("unit {} answers{}\n", u,
                   e.ok() ? "" : fmt::format(" (exception {:02X})", e.exception_code()));
        std::fflush(stdout);
      }
    } else if (e.code() == Errc::io_error || e.code() == Errc::not_connected) {
      progress.clear();
      fail(e, fmt::format("scan on {}", master->describe()));
    }
  }
  progress.clear();
  if (a.link.stats) print_stats(*master);
  // Nothing found is a failure: its one document is the failure's (main prints it).
  if (found.empty()) {
    throw Failure{
        kNoResponse,
        fmt::format("scan on {}: no unit of {} answered (timeout {} ms; a slow line may need --timeout)",
                    master->describe(), a.units, a.link.timeout_ms)};
  }
  if (a.json) {
    Json out = json_document();
    out["units"] = found;
    print_json(out);
  }
  return kOk;
}

struct SlaveArgs {
  LinkOptions link;
  std::vector<std::string> units{"1"};
  std::string registers = "10000";
  std::string init;
  bool verbose = false;
  bool any_unit = false;
  ServerArgs server;
};

int run_slave(const SlaveArgs& a) {
  const io::PortSpec spec = a.link.spec(true);
  const auto size = static_cast<size_t>(parse_number(a.registers, "--registers", 1, 65536));
  std::vector<std::unique_ptr<MemoryBank>> banks;
  SlaveEngine engine;
  for (const auto& u : a.units) {
    const UnitId unit = parse_unit(u, spec.kind == io::PortSpec::Kind::tcp);
    if (unit.value == 0) throw Failure{kUsage, "unit 0 is the broadcast address"};
    banks.push_back(std::make_unique<MemoryBank>(size));
    banks.back()->accepted_quirks = a.link.frame_quirks();
    banks.back()->objects[2] = RTUKIT_VERSION;  // the revision, unless --init names one
    if (!a.init.empty()) {
      const Status e = tool::load_bank_file(a.init, *banks.back());
      if (!e.ok()) throw Failure{e.code() == Errc::io_error ? kIoError : kUsage, std::string(e.reason())};
    }
    if (engine.add_unit(unit, *banks.back()))
      throw Failure{kUsage, fmt::format("unit {} given twice", unit.value)};
  }
  if (a.any_unit && spec.kind != io::PortSpec::Kind::tcp)
    throw Failure{kUsage,
                  "--any-unit is for Modbus TCP (tcp://): on a serial line the unit address is the device's"};
  engine.set_answer_any_unit_over_tcp(a.any_unit);
  warn_if_exposed(spec, "the slave");
  asio::io_context ctx;
  // Armed before anything says it is ready: a SIGHUP or SIGTERM that comes
  // right after "listening on" ends the server cleanly too.
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
  auto listener = SlaveListener::start(ctx, engine, spec, a.verbose ? print_requests() : RequestLog{},
                                       a.server.options());
  if (!listener.ok())
    throw Failure{exit_code(listener.error().error()), std::string(listener.error().reason())};
  fmt::print("listening on {} (units", (*listener)->where());
  for (const auto& u : a.units) fmt::print(" {}", parse_unit(u, true).value);
  fmt::print(")\n");
  std::fflush(stdout);
  ctx.run();
  return kOk;
}

}  // namespace

namespace {

void add_table_flags(CLI::App& cmd, ReadArgs& a) {
  auto* g = cmd.add_option_group("table");
  g->add_flag("--holding", a.holding, "holding registers, FC03 (default)");
  g->add_flag("--input", a.input, "input registers, FC04");
  g->add_flag("--coils", a.coils, "coils, FC01");
  g->add_flag("--discrete", a.discrete, "discrete inputs, FC02");
}

}  // namespace

void add_generic_commands(CLI::App& app, Action& action) {
  add_command<ReadArgs>(
      app, action, "read", "read registers, coils or inputs",
      [](CLI::App& cmd, ReadArgs& a) {
        cmd.add_option("--unit,-u", a.unit, "slave unit address")->capture_default_str();
        add_table_flags(cmd, a);
        cmd.add_option("operands", a.operands,
                       "ADDRESS [COUNT]: first address, 0-based (33 or 0x21), how many values (default 1); "
                       "with --map: register keys (none: all)");
        cmd.add_option("--map", a.map, "decode by name with a register-map file (docs/register-maps.md)");
        add_type_options(cmd, a.type, a.order);
        cmd.add_option("--format", a.format, "dec | hex")
            ->check(CLI::IsMember({"dec", "hex"}))
            ->capture_default_str();
        cmd.add_flag("--json", a.json, "print JSON (docs/json.md)");
        cmd.add_flag("--one-based", a.one_based,
                     "addresses count from 1, as mbpoll and Modbus Poll show them");
        a.link.add_to(cmd, false);
        examples(cmd, {"rtukit read --port /dev/ttyUSB0 --unit 21 0x21 4",
                       "rtukit read --port tcp://127.0.0.1:1502 --input 0 2 --type f32 --json",
                       "rtukit read --port /dev/ttyUSB0 --one-based 34      (mbpoll -r 34)",
                       "rtukit read --port /dev/ttyUSB0 40034               (reference notation, the same)",
                       "rtukit read --port /dev/ttyUSB0 --map meter.yaml voltage current"});
      },
      [](ReadArgs& a, const CLI::App& cmd) {
        a.unit_given = cmd.count("--unit") > 0;
        return run_read(a);
      });
  add_command<PollArgs>(
      app, action, "poll", "poll registers again and again, one timestamped line each (like mbpoll -l)",
      [](CLI::App& cmd, PollArgs& a) {
        cmd.add_option("--unit,-u", a.read.unit, "slave unit address")->capture_default_str();
        add_table_flags(cmd, a.read);
        cmd.add_option("operands", a.read.operands, "ADDRESS [COUNT]")->required();
        add_type_options(cmd, a.read.type, a.read.order);
        cmd.add_option("--format", a.read.format, "dec | hex")
            ->check(CLI::IsMember({"dec", "hex"}))
            ->capture_default_str();
        cmd.add_option("--output,-o", a.output, "table | csv | jsonl (one JSON document per line)")
            ->check(CLI::IsMember({"table", "csv", "jsonl"}))
            ->capture_default_str();
        cmd.add_flag("--one-based", a.read.one_based,
                     "addresses count from 1, as mbpoll and Modbus Poll show them");
        a.watch.add_to(cmd);
        a.read.link.add_to(cmd, false);
        examples(cmd,
                 {"rtukit poll --port /dev/ttyUSB0 --unit 21 0x21 4 --interval 500",
                  "rtukit poll --port tcp://127.0.0.1:1502 --input 0 2 --output csv --count 60 > log.csv"});
      },
      [](const PollArgs& a) { return run_poll(a); });
  add_command<WriteArgs>(
      app, action, "write", "write registers (FC06 / FC10) or coils (FC05 / FC0F)",
      [](CLI::App& cmd, WriteArgs& a) {
        cmd.add_option("--unit,-u", a.unit, "slave unit address (0 = broadcast)")->capture_default_str();
        cmd.add_option("address", a.address, "first address, 0-based (33 or 0x21; 40001 notation)")
            ->required();
        cmd.add_option("values", a.values, "values to write");
        cmd.add_option("--mask", a.mask,
                       "FC16: the register becomes (value AND A) OR (O AND NOT A), in one request")
            ->expected(2)
            ->type_name("A O");
        cmd.add_flag("--multiple", a.multiple, "use FC10 / FC0F even for one value");
        cmd.add_flag("--coils", a.coils, "write coils (values 0 or 1)");
        cmd.add_flag("--one-based", a.one_based,
                     "addresses count from 1, as mbpoll and Modbus Poll show them");
        cmd.add_flag("--json", a.json, "print the result as JSON (docs/json.md)");
        cmd.add_flag("--quiet,-q", a.quiet,
                     "print nothing on success (without it: what was written, one line)");
        add_type_options(cmd, a.type, a.order);
        a.link.add_to(cmd, false);
        examples(cmd,
                 {"rtukit write --port /dev/ttyUSB0 --unit 21 0x23 80",
                  "rtukit write --port tcp://127.0.0.1:1502 --unit 5 30 1 2 3      (FC10)",
                  "rtukit write --port /dev/ttyUSB0 --coils 7 1",
                  "rtukit write --port /dev/ttyUSB0 --unit 5 --mask 0xFFF7 0x0000 40   (FC16: clear bit 3)"});
      },
      [](const WriteArgs& a) { return run_write(a); });
  add_command<ReadWriteArgs>(
      app, action, "readwrite", "write registers, then read registers, in one request (FC17)",
      [](CLI::App& cmd, ReadWriteArgs& a) {
        cmd.add_option("--unit,-u", a.unit, "slave unit address")->capture_default_str();
        cmd.add_option("read_address", a.read_address, "first register to read, 0-based (or 40001 notation)")
            ->required();
        cmd.add_option("count", a.count, "registers to read (1..125)")->required()->check(CLI::Range(1, 125));
        cmd.add_option("write_address", a.write_address,
                       "first register to write, 0-based (or 40001 notation)")
            ->required();
        cmd.add_option("values", a.values, "values to write (1..121), written before the read")->required();
        cmd.add_flag("--json", a.json, "print the result as JSON (docs/json.md)");
        cmd.add_flag("--one-based", a.one_based,
                     "addresses count from 1, as mbpoll and Modbus Poll show them");
        a.link.add_to(cmd, false);
        examples(
            cmd,
            {"rtukit readwrite --port tcp://127.0.0.1:1502 --unit 1 3 6 14 255 255 255",
             "rtukit readwrite --port /dev/ttyUSB0 --unit 5 100 2 100 7 8   (write 7 8, read them back)"});
      },
      [](const ReadWriteArgs& a) { return run_readwrite(a); });
  add_command<ScanArgs>(
      app, action, "scan", "find which unit addresses answer",
      [](CLI::App& cmd, ScanArgs& a) {
        cmd.add_option("--units", a.units, fmt::format("units to try: 1-{}, 21, 1,5,21-30", kMaxSerialUnit))
            ->capture_default_str();
        cmd.add_flag("--json", a.json, "print JSON (docs/json.md)");
        // Scanning waits on silent units: a short timeout by default, shown as
        // such in --help (at 1200 baud a unit needs more than 100 ms: --timeout).
        a.link.timeout_ms = 100;
        a.link.add_to(cmd, false);
        examples(cmd, {"rtukit scan --port /dev/ttyUSB0 --baud 19200 --parity even",
                       "rtukit scan --port /dev/ttyUSB0 --units 1,5,21-30 --timeout 300"});
      },
      [](const ScanArgs& a) { return run_scan(a); });
  add_command<SlaveArgs>(
      app, action, "slave", "a generic in-memory slave (holding, input, coils, discrete)",
      [](CLI::App& cmd, SlaveArgs& a) {
        cmd.add_option("--unit,-u", a.units, "unit address(es) to answer (repeatable)")
            ->capture_default_str();
        cmd.add_option("--registers", a.registers, "entries per table")->capture_default_str();
        cmd.add_option("--init", a.init, "JSON file with initial values");
        cmd.add_flag("-v,--verbose", a.verbose, "log each request and response");
        cmd.add_flag("--any-unit", a.any_unit, "Modbus TCP: answer every unit id (with the first --unit)");
        a.link.add_to(cmd, true);
        a.server.add_to(cmd);
        examples(cmd, {"rtukit slave --listen pty:/tmp/ttyV0 --unit 5 -v",
                       "rtukit slave --listen tcp://127.0.0.1:1502 --unit 1 --unit 2 --init values.json"});
      },
      [](const SlaveArgs& a) { return run_slave(a); });
}

}  // namespace rtukit::cli
