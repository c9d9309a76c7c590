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
#include "rtukit/devices/profile/address_notation.hpp"
#include "rtukit/devices/profile/bank_file.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio.hpp"

namespace rtukit::cli {
namespace {

using profile::Space;
// An address as typed (0-based, --one-based, 40001 reference) and how to show it back: the kit's.
using Address = profile::TypedAddress;
using Notation = profile::AddressNotation;

// A table as output and JSON name it ("table": "coils").
const char* table_name(Space t) {
  switch (t) {
    case Space::holding:
      return "holding";
    case Space::input:
      return "input";
    case Space::coil:
      return "coils";
    case Space::discrete:
      return "discrete";
  }
  return "?";
}

// JSON: "address" counted as typed (1-based for a reference, whose prefix is
// the "table" key), and "pdu_address", the address on the wire, when that
// count is not 0-based.
void put_address(Json& doc, const Notation& notation, size_t pdu) {
  const bool zero_based = notation.kind == Notation::Kind::zero_based;
  doc["address"] = zero_based ? pdu : pdu + 1;
  if (!zero_based) doc["pdu_address"] = pdu;
}

Address parse_address(const std::string& text, bool one_based) {
  Outcome<Address> at = profile::parse_address(text, one_based);
  if (!at.ok()) throw Failure{kUsage, std::string(at.error().reason())};
  // Never silent: the same digits may also be a plain address.
  if (!at->note.empty()) fmt::print(stderr, "note: {}\n", at->note);
  return *at;
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

// What one read asks for, from the read/poll arguments.
struct ReadPlan {
  UnitId unit{1};
  Space table = Space::holding;
  uint16_t address = 0;
  uint16_t count = 1;
  unsigned per_value = 1;
  bool bits = false;
  Notation notation;  ///< how the address was typed: how to print addresses
};

ReadPlan plan_read(ReadArgs& a) {
  if (a.operands.empty() || a.operands.size() > 2)
    throw Failure{kUsage, "read takes ADDRESS [COUNT] (or --map FILE [KEY...])"};
  a.address = a.operands[0];
  if (a.operands.size() == 2) a.count = a.operands[1];
  ReadPlan p;
  p.unit = parse_unit(a.unit, a.link.spec(false).kind == io::PortSpec::Kind::tcp);
  if (a.holding + a.input + a.coils + a.discrete > 1)
    throw Failure{kUsage, "choose one of --holding, --input, --coils, --discrete"};
  p.table = a.input ? Space::input : a.coils ? Space::coil : a.discrete ? Space::discrete : Space::holding;
  if (p.unit.value == 0 && a.link.spec(false).kind != io::PortSpec::Kind::tcp)
    throw Failure{kUsage,
                  fmt::format("unit 0 is the broadcast address: nobody answers a broadcast, so it cannot be "
                              "read (name a unit 1..{})",
                              kMaxSerialUnit)};
  const Address where = parse_address(a.address, a.one_based);
  if (where.space && *where.space != p.table) {
    if (a.holding + a.input + a.coils + a.discrete > 0)
      throw Failure{kUsage,
                    fmt::format("address {} names the {} registers; drop the table option or the prefix",
                                a.address, table_name(*where.space))};
    p.table = *where.space;
  }
  p.address = where.address;
  p.notation = where.notation;
  p.bits = p.table == Space::coil || p.table == Space::discrete;
  p.per_value = p.bits ? 1 : profile::words_of(value_type_of(a.type));
  const auto max_count = p.bits ? kMaxReadBits : kMaxReadRegisters / p.per_value;
  p.count = static_cast<uint16_t>(parse_number(a.count, "count", 1, max_count));
  if (size_t{p.address} + size_t{p.count} * p.per_value > 0x10000)
    throw Failure{kUsage, "address + count passes 0xFFFF"};
  return p;
}

std::string read_context(const ReadPlan& p, const Master& master) {
  const uint8_t function = p.table == Space::holding ? 0x03
                           : p.table == Space::input ? 0x04
                           : p.table == Space::coil  ? 0x01
                                                     : 0x02;
  return fmt::format("FC{:02X} {} at {} x{} from unit {} on {}", function, function_name(function),
                     p.notation.where(p.address), p.bits ? p.count : p.count * p.per_value, p.unit.value,
                     master.describe());
}

// One read; the values decoded as the arguments ask (JSON numbers).
Error read_values(Master& master, const ReadPlan& p, const ReadArgs& a, nlohmann::json& values) {
  std::vector<uint16_t> regs(p.bits ? 0 : size_t{p.count} * p.per_value);
  std::vector<uint8_t> flags(p.bits ? p.count : 0);
  Error e;
  switch (p.table) {
    case Space::holding:
      e = master.read_holding_registers(p.unit, p.address, regs);
      break;
    case Space::input:
      e = master.read_input_registers(p.unit, p.address, regs);
      break;
    case Space::coil:
      e = master.read_coils(p.unit, p.address, flags);
      break;
    case Space::discrete:
      e = master.read_discrete_inputs(p.unit, p.address, flags);
      break;
  }
  values = nlohmann::json::array();
  if (e) return e;
  for (size_t i = 0; i < p.count; ++i) {
    values.push_back(p.bits ? nlohmann::json(flags[i])
                            : profile::decode_typed(value_type_of(a.type),
                                                    std::span(regs).subspan(i * p.per_value, p.per_value),
                                                    word_order_of(a.order)));
  }
  return e;
}

std::string value_text(const nlohmann::json& v, const ReadArgs& a, const ReadPlan& p) {
  if (a.format == "hex" && !p.bits && a.type != "f32") {
    const uint64_t raw = v.is_number_unsigned() ? v.get<uint64_t>() : static_cast<uint64_t>(v.get<int64_t>());
    const uint64_t mask = p.per_value == 1 ? 0xFFFF : 0xFFFFFFFF;
    return fmt::format("0x{:0{}X}", raw & mask, p.per_value == 1 ? 4 : 8);
  }
  return v.dump();
}

int run_read(ReadArgs a) {
  if (!a.map.empty()) return run_map_read(a.link, a.unit_given ? a.unit : "", a.map, a.operands, a.json);
  const ReadPlan p = plan_read(a);
  auto master = a.link.make_master();
  nlohmann::json values;
  const Error e = read_values(*master, p, a, values);
  if (a.link.stats) print_stats(*master);
  if (e) fail(e, read_context(p, *master));
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
  const std::string context = read_context(p, *master);
  if (args.output == "csv") {
    std::string header = "time";
    for (size_t i = 0; i < p.count; ++i) header += "," + p.notation.text(p.address + i * p.per_value);
    fmt::print("{},error\n", header);
  }
  Error last;
  unsigned failures = 0, polls = 0;
  watch_loop(args.watch, [&](unsigned) {
    nlohmann::json values;
    last = read_values(*master, p, a, values);
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

// The values of a write as the confirmation names them: "5, 6"; past 8,
// "1, 2, 3, 4, ..., 10 (10 values)".
std::string values_text(const std::vector<std::string>& values) {
  if (values.size() <= 8) return fmt::format("{}", fmt::join(values, ", "));
  return fmt::format("{}, {}, {}, {}, ..., {} ({} values)", values[0], values[1], values[2], values[3],
                     values.back(), values.size());
}

int run_write(const WriteArgs& a) {
  if (!a.mask.empty() && (a.coils || a.multiple || !a.values.empty()))
    throw Failure{kUsage, "--mask AND OR writes one register: no values, --coils or --multiple with it"};
  if (a.mask.empty() && a.values.empty()) throw Failure{kUsage, "write needs values (or --mask AND OR)"};
  const bool tcp = a.link.spec(false).kind == io::PortSpec::Kind::tcp;
  const UnitId unit = parse_unit(a.unit, tcp);
  const Address where = parse_address(a.address, a.one_based);
  const Space table = a.coils ? Space::coil : Space::holding;
  if (where.space == Space::coil && !a.coils)
    throw Failure{kUsage, fmt::format("address {} names a coil: add --coils to write coils", a.address)};
  if (where.space && *where.space != table)
    throw Failure{kUsage,
                  fmt::format("address {} names the {} registers, which cannot be written{}", a.address,
                              table_name(*where.space), a.coils ? "" : " (holding registers are 4xxxx)")};
  const uint16_t address = where.address;
  // Every value is checked and encoded before the port is opened: a value
  // the type cannot hold is a usage error, whatever the link.
  uint16_t and_mask = 0, or_mask = 0;
  std::vector<uint8_t> bits;
  std::vector<uint16_t> regs;
  size_t count = 1;  // registers or coils written
  if (!a.mask.empty()) {
    and_mask = static_cast<uint16_t>(parse_number(a.mask[0], "AND mask", 0, 0xFFFF));
    or_mask = static_cast<uint16_t>(parse_number(a.mask[1], "OR mask", 0, 0xFFFF));
  } else if (a.coils) {
    for (const auto& v : a.values) bits.push_back(static_cast<uint8_t>(parse_number(v, "coil value", 0, 1)));
    if (bits.size() > kMaxWriteBits)
      throw Failure{kUsage, fmt::format("at most {} coils per write", kMaxWriteBits)};
    if (size_t{address} + bits.size() > 0x10000) throw Failure{kUsage, "address + count passes 0xFFFF"};
    count = bits.size();
  } else {
    for (const auto& v : a.values) {
      const Status e = profile::encode_typed(value_type_of(a.type), v, word_order_of(a.order), regs);
      if (!e.ok()) throw Failure{kUsage, std::string(e.reason())};
    }
    if (regs.size() > kMaxWriteRegisters)
      throw Failure{kUsage, fmt::format("at most {} registers per write", kMaxWriteRegisters)};
    if (size_t{address} + regs.size() > 0x10000) throw Failure{kUsage, "address + count passes 0xFFFF"};
    count = regs.size();
  }
  auto master = a.link.make_master();
  // Which request went out, named as the read errors name theirs: "FC10 write multiple registers at 2
  // (0x0002) x3".
  const auto context_of = [&](uint8_t function) {
    return fmt::format("FC{:02X} {} at {} x{} to unit {} on {}", function, function_name(function),
                       where.notation.where(address), count, unit.value, master->describe());
  };
  std::string context;
  Error e;
  if (!a.mask.empty()) {
    context = context_of(0x16);
    e = master->mask_write_register(unit, address, and_mask, or_mask);
  } else if (a.coils) {
    const bool single = bits.size() == 1 && !a.multiple;
    context = context_of(single ? 0x05 : 0x0F);
    e = single ? master->write_single_coil(unit, address, bits[0] != 0)
               : master->write_multiple_coils(unit, address, bits);
  } else {
    const bool single = regs.size() == 1 && !a.multiple;
    context = context_of(single ? 0x06 : 0x10);
    e = single ? master->write_single_register(unit, address, regs[0])
               : master->write_multiple_registers(unit, address, regs);
  }
  if (a.link.stats) print_stats(*master);
  if (e) fail(e, context);
  // What was written, in one line: "wrote 1234 to holding register 40001 (0x0000) of unit 1".
  const std::string target =
      fmt::format("{} {}", profile::space_noun(table, count > 1), where.notation.span(address, count));
  const bool broadcast = unit == kBroadcast && !tcp;
  const std::string to_whom =
      broadcast ? "of every unit (a broadcast: no unit answers it)" : fmt::format("of unit {}", unit.value);
  std::string text;
  if (!a.mask.empty())
    text = fmt::format("masked {} {} with AND {} OR {}", target, to_whom, a.mask[0], a.mask[1]);
  else
    text = fmt::format("wrote {}{} to {} {}", values_text(a.values),
                       a.coils || a.type == "u16" ? "" : " (" + a.type + ")", target, to_whom);
  if (a.json) {
    Json out = json_document({}, unit.value);
    out["table"] = a.coils ? "coils" : "holding";
    put_address(out, where.notation, address);
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
  if (unit == kBroadcast) throw Failure{kUsage, "FC17 reads: it cannot be broadcast (unit 0)"};
  // Both addresses as any address is typed (0-based, --one-based, 40001); FC17 is for holding registers.
  const auto holding = [&](const std::string& text) {
    const Address at = parse_address(text, a.one_based);
    if (at.space && *at.space != Space::holding)
      throw Failure{kUsage, fmt::format("{} names the {} registers: FC17 reads and writes holding registers",
                                        text, table_name(*at.space))};
    return at;
  };
  const Address read_where = holding(a.read_address);
  const Address write_where = holding(a.write_address);
  const uint16_t read_at = read_where.address;
  const uint16_t write_at = write_where.address;
  std::vector<uint16_t> values;
  for (const auto& v : a.values) values.push_back(static_cast<uint16_t>(parse_number(v, "value", 0, 0xFFFF)));
  if (values.size() > kMaxReadWriteWriteRegisters)
    throw Failure{kUsage,
                  fmt::format("at most {} registers to write with FC17", kMaxReadWriteWriteRegisters)};
  if (size_t{read_at} + a.count > 0x10000 || size_t{write_at} + values.size() > 0x10000)
    throw Failure{kUsage, "address + count passes 0xFFFF"};
  auto master = a.link.make_master();
  std::vector<uint16_t> out(a.count);
  const Error e = master->read_write_multiple_registers(unit, read_at, out, write_at, values);
  if (a.link.stats) print_stats(*master);
  if (e)
    fail(e,
         fmt::format("FC17 read/write multiple registers: write {} at {}, read {} at {} from unit {} on {}",
                     values.size(), write_where.notation.where(write_at), a.count,
                     read_where.notation.where(read_at), unit.value, master->describe()));
  if (a.json) {
    Json doc = json_document({}, unit.value);
    doc["table"] = "holding";
    Json written;
    put_address(written, write_where.notation, write_at);
    written["count"] = values.size();
    doc["written"] = written;
    put_address(doc, read_where.notation, read_at);
    doc["values"] = out;
    print_json(doc);
    return kOk;
  }
  for (size_t i = 0; i < out.size(); ++i)
    fmt::print("{}: {}\n", read_where.notation.where(read_at + i), out[i]);
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
      const Status e = profile::load_bank_file(a.init, *banks.back());
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
  RequestLog log;
  if (a.verbose) {
    log = [](std::span<const uint8_t> rx, std::span<const uint8_t> tx) {
      fmt::print("rx {} -> {}\n", hex(rx), tx.empty() ? std::string("(silence)") : "tx " + hex(tx));
      std::fflush(stdout);
    };
  }
  auto listener = SlaveListener::start(ctx, engine, spec, log, a.server.options());
  if (!listener.ok())
    throw Failure{exit_code(listener.error().error()), std::string(listener.error().reason())};
  fmt::print("listening on {} (units", (*listener)->where());
  for (const auto& u : a.units) fmt::print(" {}", parse_unit(u, true).value);
  fmt::print(")\n");
  std::fflush(stdout);
  asio::signal_set signals(ctx);
  stop_on_signals(signals, ctx);
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
