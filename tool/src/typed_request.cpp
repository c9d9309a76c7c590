#include "rtukit/tool/typed_request.hpp"

#include <fmt/format.h>

#include <vector>

namespace rtukit::tool {

using profile::decode_typed;
using profile::encode_typed;
using profile::parse_number;
using profile::words_of;

const char* table_name(Space t) noexcept {
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

void put_address(nlohmann::ordered_json& doc, const AddressNotation& notation, size_t pdu) {
  const bool zero_based = notation.kind == AddressNotation::Kind::zero_based;
  doc["address"] = zero_based ? pdu : pdu + 1;
  if (!zero_based) doc["pdu_address"] = pdu;
}

Outcome<ReadPlan> plan_read(const ReadRequest& a, std::string* note) {
  const auto usage = [](std::string reason) { return Status(Errc::invalid_argument, std::move(reason)); };
  ReadPlan p;
  p.unit = a.unit;
  p.type = a.type;
  p.order = a.order;
  if (a.tables_named > 1) return usage("choose one of --holding, --input, --coils, --discrete");
  p.table = a.table;
  // Nobody answers a broadcast: a read of one would only wait for the timeout.
  if (p.unit.value == 0 && !a.tcp)
    return usage(
        fmt::format("unit 0 is the broadcast address: nobody answers a broadcast, so it cannot be read (name "
                    "a unit 1..{})",
                    kMaxSerialUnit));
  Outcome<TypedAddress> where = parse_address(a.address, a.one_based);
  if (!where.ok()) return where.error();
  // The front-end shows the note even when a later check refuses the read.
  if (note) *note = where->note;
  if (where->space && *where->space != p.table) {
    if (a.tables_named > 0)
      return usage(fmt::format("address {} names the {} registers; drop the table option or the prefix",
                               a.address, table_name(*where->space)));
    p.table = *where->space;
  }
  p.address = where->address;
  p.notation = where->notation;
  p.bits = p.table == Space::coil || p.table == Space::discrete;
  p.per_value = p.bits ? 1 : words_of(a.type);
  const auto max_count = p.bits ? kMaxReadBits : kMaxReadRegisters / p.per_value;
  const Outcome<int64_t> count = parse_number(a.count, "count", 1, max_count);
  if (!count.ok()) return count.error();
  p.count = static_cast<uint16_t>(*count);
  if (size_t{p.address} + size_t{p.count} * p.per_value > 0x10000)
    return usage("address + count passes 0xFFFF");
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

Error read_values(Master& master, const ReadPlan& p, nlohmann::json& values) {
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
    values.push_back(
        p.bits ? nlohmann::json(flags[i])
               : decode_typed(p.type, std::span(regs).subspan(i * p.per_value, p.per_value), p.order));
  }
  return e;
}

std::string value_text(const nlohmann::json& v, const ReadPlan& p, bool hex) {
  // A float's bits say nothing to a reader: f32 stays decimal.
  if (hex && !p.bits && p.type != ValueType::f32) {
    const uint64_t raw = v.is_number_unsigned() ? v.get<uint64_t>() : static_cast<uint64_t>(v.get<int64_t>());
    const uint64_t mask = p.per_value == 1 ? 0xFFFF : 0xFFFFFFFF;
    return fmt::format("0x{:0{}X}", raw & mask, p.per_value == 1 ? 4 : 8);
  }
  return v.dump();
}

Outcome<WritePlan> plan_write(const WriteRequest& a, std::string* note) {
  const auto usage = [](std::string reason) { return Status(Errc::invalid_argument, std::move(reason)); };
  const bool masked = !a.mask.empty();
  if (masked && (a.mask.size() != 2 || a.coils || a.multiple || !a.values.empty()))
    return usage("a mask write takes an AND and an OR mask, and no values");
  if (!masked && a.values.empty()) return usage("a write needs values");
  WritePlan p;
  p.unit = a.unit;
  Outcome<TypedAddress> where = parse_address(a.address, a.one_based);
  if (!where.ok()) return where.error();
  if (note) *note = where->note;
  p.table = a.coils ? Space::coil : Space::holding;
  if (where->space == Space::coil && !a.coils)
    return usage(fmt::format("address {} names a coil: add --coils to write coils", a.address));
  if (where->space && *where->space != p.table)
    return usage(fmt::format("address {} names the {} registers, which cannot be written{}", a.address,
                             table_name(*where->space), a.coils ? "" : " (holding registers are 4xxxx)"));
  p.address = where->address;
  p.notation = where->notation;
  // Every value is checked and encoded before the port is opened: a value
  // the type cannot hold is a usage error, whatever the link.
  if (masked) {
    const Outcome<int64_t> and_mask = parse_number(a.mask[0], "AND mask", 0, 0xFFFF);
    if (!and_mask.ok()) return and_mask.error();
    const Outcome<int64_t> or_mask = parse_number(a.mask[1], "OR mask", 0, 0xFFFF);
    if (!or_mask.ok()) return or_mask.error();
    p.and_mask = static_cast<uint16_t>(*and_mask);
    p.or_mask = static_cast<uint16_t>(*or_mask);
    p.function = 0x16;
    p.count = 1;
  } else if (a.coils) {
    for (const std::string& v : a.values) {
      const Outcome<int64_t> bit = parse_number(v, "coil value", 0, 1);
      if (!bit.ok()) return bit.error();
      p.bits.push_back(static_cast<uint8_t>(*bit));
    }
    if (p.bits.size() > kMaxWriteBits) return usage(fmt::format("at most {} coils per write", kMaxWriteBits));
    if (size_t{p.address} + p.bits.size() > 0x10000) return usage("address + count passes 0xFFFF");
    p.count = p.bits.size();
    p.function = p.count == 1 && !a.multiple ? 0x05 : 0x0F;
  } else {
    for (const std::string& v : a.values) {
      const Status e = encode_typed(a.type, v, a.order, p.regs);
      if (!e.ok()) return e;
    }
    if (p.regs.size() > kMaxWriteRegisters)
      return usage(fmt::format("at most {} registers per write", kMaxWriteRegisters));
    if (size_t{p.address} + p.regs.size() > 0x10000) return usage("address + count passes 0xFFFF");
    p.count = p.regs.size();
    p.function = p.count == 1 && !a.multiple ? 0x06 : 0x10;
  }
  return p;
}

std::string write_context(const WritePlan& p, const Master& master) {
  return fmt::format("FC{:02X} {} at {} x{} to unit {} on {}", p.function, function_name(p.function),
                     p.notation.where(p.address), p.count, p.unit.value, master.describe());
}

std::string write_text(const WriteRequest& request, const WritePlan& p, bool tcp) {
  const std::span<const std::string> v = request.values;
  const std::string values = v.size() <= 8 ? fmt::format("{}", fmt::join(v, ", "))
                                           : fmt::format("{}, {}, {}, {}, ..., {} ({} values)", v[0], v[1],
                                                         v[2], v[3], v.back(), v.size());
  const std::string target =
      fmt::format("{} {}", space_noun(p.table, p.count > 1), p.notation.span(p.address, p.count));
  const std::string to_whom = p.unit == kBroadcast && !tcp ? "of every unit (a broadcast: no unit answers it)"
                                                           : fmt::format("of unit {}", p.unit.value);
  if (!request.mask.empty())
    return fmt::format("masked {} {} with AND {} OR {}", target, to_whom, request.mask[0], request.mask[1]);
  constexpr const char* kTypes[] = {"u16", "i16", "u32", "i32", "f32"};
  return fmt::format("wrote {}{} to {} {}", values,
                     request.coils || request.type == ValueType::u16
                         ? ""
                         : fmt::format(" ({})", kTypes[static_cast<unsigned>(request.type)]),
                     target, to_whom);
}

Error send_write(Master& master, const WritePlan& p) {
  switch (p.function) {
    case 0x16:
      return master.mask_write_register(p.unit, p.address, p.and_mask, p.or_mask);
    case 0x05:
      return master.write_single_coil(p.unit, p.address, p.bits[0] != 0);
    case 0x0F:
      return master.write_multiple_coils(p.unit, p.address, p.bits);
    case 0x06:
      return master.write_single_register(p.unit, p.address, p.regs[0]);
    case 0x10:
      return master.write_multiple_registers(p.unit, p.address, p.regs);
  }
  return Errc::invalid_argument;
}

Outcome<ReadWritePlan> plan_readwrite(const ReadWriteRequest& a, std::vector<std::string>* notes) {
  const auto usage = [](std::string reason) { return Status(Errc::invalid_argument, std::move(reason)); };
  // Nobody answers a broadcast, and FC17 is a read: on TCP too, unit 0 is refused.
  if (a.unit == kBroadcast) return usage("FC17 reads: it cannot be broadcast (unit 0)");
  // Both addresses as any address is typed (0-based, --one-based, 40001); FC17 is for holding registers.
  const auto holding = [&](std::string_view text) -> Outcome<TypedAddress> {
    Outcome<TypedAddress> at = parse_address(text, a.one_based);
    if (!at.ok()) return at.error();
    if (notes && !at->note.empty()) notes->push_back(at->note);
    if (at->space && *at->space != Space::holding)
      return usage(fmt::format("{} names the {} registers: FC17 reads and writes holding registers", text,
                               table_name(*at->space)));
    return at;
  };
  const Outcome<TypedAddress> read_where = holding(a.read_address);
  if (!read_where.ok()) return read_where.error();
  const Outcome<TypedAddress> write_where = holding(a.write_address);
  if (!write_where.ok()) return write_where.error();
  ReadWritePlan p;
  p.unit = a.unit;
  p.read_at = read_where->address;
  p.read_notation = read_where->notation;
  p.count = a.count;
  p.write_at = write_where->address;
  p.write_notation = write_where->notation;
  for (const std::string& v : a.values) {
    const Outcome<int64_t> n = parse_number(v, "value", 0, 0xFFFF);
    if (!n.ok()) return n.error();
    p.values.push_back(static_cast<uint16_t>(*n));
  }
  if (p.values.size() > kMaxReadWriteWriteRegisters)
    return usage(fmt::format("at most {} registers to write with FC17", kMaxReadWriteWriteRegisters));
  if (size_t{p.read_at} + p.count > 0x10000 || size_t{p.write_at} + p.values.size() > 0x10000)
    return usage("address + count passes 0xFFFF");
  return p;
}

std::string readwrite_context(const ReadWritePlan& p, const Master& master) {
  return fmt::format("FC17 read/write multiple registers: write {} at {}, read {} at {} from unit {} on {}",
                     p.values.size(), p.write_notation.where(p.write_at), p.count,
                     p.read_notation.where(p.read_at), p.unit.value, master.describe());
}

}  // namespace rtukit::tool
