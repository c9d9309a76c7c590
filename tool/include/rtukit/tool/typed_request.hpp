// rtukit device profiles, host side: reads and writes of registers with no
// row behind them (the generic `read`, `poll` and `write`): an address as
// typed, a count or the values, and a value type (typed_value.hpp) checked
// into one request, the request sent, and a read's values decoded and shown.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/tool/address_notation.hpp"

namespace rtukit::tool {

// The profile kit's value types, which the generic commands share with the devices.
using profile::Space;
using profile::ValueType;
using profile::WordOrder;

/// A table as output and JSON name it ("table": "coils"): "holding",
/// "input", "coils", "discrete".
const char* table_name(Space t) noexcept;

/// JSON: doc["address"] counted as typed (1-based for a reference, whose
/// prefix is the "table" key), and doc["pdu_address"], the address on the
/// wire, when that count is not 0-based.
void put_address(nlohmann::ordered_json& doc, const AddressNotation& notation, size_t pdu);

/// A read as asked for: what plan_read checks.
struct ReadRequest {
  UnitId unit{1};
  bool tcp = false;              ///< the link is Modbus TCP (unit 0 is then a unit, not the broadcast)
  unsigned tables_named = 0;     ///< how many table options were given (--holding, --input, ...)
  Space table = Space::holding;  ///< the one named, or holding
  std::string_view address;      ///< as typed: "33", "0x21", "40034" (parse_address)
  std::string_view count = "1";  ///< as typed
  ValueType type = ValueType::u16;
  WordOrder order = WordOrder::high_first;
  bool one_based = false;
};

/// One checked read.
struct ReadPlan {
  UnitId unit{1};
  Space table = Space::holding;
  uint16_t address = 0;
  uint16_t count = 1;      ///< values (each per_value registers) or bits
  unsigned per_value = 1;  ///< registers per value; 1 for bits
  bool bits = false;       ///< coils or discrete inputs
  ValueType type = ValueType::u16;
  WordOrder order = WordOrder::high_first;
  AddressNotation notation;  ///< how the address was typed: how to print addresses
};

/// The request checked, in this order: one table at most, no broadcast on a
/// serial link, the address (parse_address; a reference's prefix names the
/// table, and may not contradict a table option), the count (1..2000 bits,
/// or 125 registers / per_value values) and address + registers <= 0x10000.
/// `note`, when not null, gets the address's note (parse_address) as soon
/// as the address parsed, also when a later check fails.
/// Errors: invalid_argument, the reason is the user's message: "choose one
/// of --holding, --input, --coils, --discrete", "unit 0 is the broadcast
/// address: ...", parse_address's, "address 30001 names the input
/// registers; drop the table option or the prefix", parse_number's for
/// "count", "address + count passes 0xFFFF".
Outcome<ReadPlan> plan_read(const ReadRequest& request, std::string* note = nullptr);

/// The request in words, for an error: "FC03 read holding registers at 33
/// (0x0021) x4 from unit 21 on /dev/ttyUSB0 9600 8N1".
std::string read_context(const ReadPlan& p, const Master& master);

/// Sends the read; `values` becomes a JSON array of p.count numbers (bits
/// 0/1, or decode_typed by the plan's type and word order), empty when the
/// read failed. Errors: the Master's.
Error read_values(Master& master, const ReadPlan& p, nlohmann::json& values);

/// One value as shown: its JSON text, or with `hex` (16- and 32-bit integer
/// types; bits and f32 stay decimal) the raw bits "0xFFFF", "0x0001E240".
std::string value_text(const nlohmann::json& v, const ReadPlan& p, bool hex);

/// A write as asked for: what plan_write checks.
struct WriteRequest {
  UnitId unit{1};
  std::string_view address;  ///< as typed (parse_address)
  bool one_based = false;
  bool coils = false;                   ///< coils (values 0 or 1), else holding registers
  bool multiple = false;                ///< FC0F / FC10 even for one value
  std::span<const std::string> values;  ///< as typed: "80", "-1", "0x1F", "1.5"
  std::span<const std::string> mask;    ///< FC16: {AND, OR} as typed, or empty
  ValueType type = ValueType::u16;      ///< of the register values
  WordOrder order = WordOrder::high_first;
};

/// One checked write, its values encoded.
struct WritePlan {
  UnitId unit{1};
  Space table = Space::holding;  ///< coil or holding
  uint16_t address = 0;
  AddressNotation notation;
  uint8_t function = 0x06;             ///< 0x05, 0x06, 0x0F, 0x10 or 0x16 (mask write)
  size_t count = 1;                    ///< coils or registers written (1 for a mask write)
  std::vector<uint8_t> bits;           ///< FC05, FC0F: one element per coil, 0 or 1
  std::vector<uint16_t> regs;          ///< FC06, FC10
  uint16_t and_mask = 0, or_mask = 0;  ///< FC16
};

/// The request checked and encoded before any port is opened, in this
/// order: the address (parse_address; a coil reference needs `coils`, and an
/// input or discrete reference is refused), then the mask, or each value
/// (coils 0 or 1; registers encode_typed) and the limits (1968 coils, 123
/// registers, address + count <= 0x10000). FC05/FC06 for one value unless
/// `multiple`. Preconditions: a mask is two texts, and comes without values,
/// `coils` or `multiple`; without one there is at least one value (else
/// invalid_argument). `note` as plan_read's.
/// Errors: invalid_argument, the reason is the user's message: "address
/// 00001 names a coil: add --coils to write coils", "address 30001 names
/// the input registers, which cannot be written (holding registers are
/// 4xxxx)", parse_number's ("AND mask", "OR mask", "coil value"),
/// encode_typed's, "at most 123 registers per write", "at most 1968 coils
/// per write", "address + count passes 0xFFFF".
Outcome<WritePlan> plan_write(const WriteRequest& request, std::string* note = nullptr);

/// The request in words, for an error: "FC10 write multiple registers at 2
/// (0x0002) x3 to unit 5 on /dev/ttyUSB0 9600 8N1".
std::string write_context(const WritePlan& p, const Master& master);

/// What the write did, in one line: "wrote 1234 to holding register 40001
/// (0x0000) of unit 1", "wrote 1.5 (f32) to ...", "masked holding register
/// ... with AND 0xFFF7 OR 0 of unit 5"; past 8 values "1, 2, 3, 4, ..., 10
/// (10 values)"; unit 0 on a serial line (not `tcp`): "of every unit (a
/// broadcast: no unit answers it)". `request`: what plan_write was given.
std::string write_text(const WriteRequest& request, const WritePlan& p, bool tcp);

/// Sends the write. Errors: the Master's.
Error send_write(Master& master, const WritePlan& p);

/// FC17 as asked for: what plan_readwrite checks.
struct ReadWriteRequest {
  UnitId unit{1};
  std::string_view read_address;  ///< as typed (parse_address)
  uint16_t count = 1;             ///< registers to read; precondition 1..125
  std::string_view write_address;
  std::span<const std::string> values;  ///< registers to write, as typed (0..0xFFFF)
  bool one_based = false;
};

/// One checked FC17 request: the write goes before the read.
struct ReadWritePlan {
  UnitId unit{1};
  uint16_t read_at = 0, count = 1;
  uint16_t write_at = 0;
  std::vector<uint16_t> values;
  AddressNotation read_notation, write_notation;
};

/// The request checked, in this order: not the broadcast (unit 0, on any
/// link: FC17 reads), the read address, the write address (holding
/// registers only), each value, at most 121 values, address + count <=
/// 0x10000 for both. `notes`, when not null, gets each address's note
/// (parse_address) as that address parses, also when a later check fails.
/// Errors: invalid_argument, the reason is the user's message: "FC17 reads:
/// it cannot be broadcast (unit 0)", parse_address's, "30001 names the input
/// registers: FC17 reads and writes holding registers", parse_number's for
/// "value", "at most 121 registers to write with FC17", "address + count
/// passes 0xFFFF".
Outcome<ReadWritePlan> plan_readwrite(const ReadWriteRequest& request,
                                      std::vector<std::string>* notes = nullptr);

/// The request in words, for an error: "FC17 read/write multiple registers:
/// write 2 at 100 (0x0064), read 2 at 100 (0x0064) from unit 5 on ...".
std::string readwrite_context(const ReadWritePlan& p, const Master& master);

}  // namespace rtukit::tool
