// rtukit core: the Modbus PDU (function code + data), both directions.
//
// A PDU is what RTU and TCP have in common: RTU wraps it in address + CRC,
// Modbus TCP in an MBAP header. Everything here works on caller-owned spans:
// decoders return views into the bytes they were given (valid as long as
// those bytes are), encoders write into `out` and return the length written.
//
// Function codes: 01 read coils, 02 read discrete inputs, 03 read holding
// registers, 04 read input registers, 05 write single coil, 06 write single
// register, 0F write multiple coils, 10 write multiple registers, 16 mask
// write register, 17 read/write multiple registers; serial line diagnostics
// 07 read exception status, 08 diagnostics, 0B get comm event counter, 0C
// get comm event log; 11 report server ID, 2B/0E read device identification.
// Limits (Modbus Application Protocol v1.1b3): reads 1..125 registers or
// 1..2000 bits; multiple writes 1..123 registers or 1..1968 bits; FC17 reads
// 1..125 and writes 1..121 registers. Which of them are compiled in is
// config.hpp's choice (all, unless a switch turns a family off).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "rtukit/core/config.hpp"
#include "rtukit/core/error.hpp"

namespace rtukit {

inline constexpr size_t kMaxPduSize = 253;     ///< function code + data
inline constexpr size_t kMaxRtuAduSize = 256;  ///< address + PDU + CRC
inline constexpr uint16_t kMaxReadRegisters = 125;
inline constexpr uint16_t kMaxWriteRegisters = 123;
inline constexpr uint16_t kMaxReadBits = 2000;
inline constexpr uint16_t kMaxWriteBits = 1968;
inline constexpr uint16_t kMaxReadWriteWriteRegisters = 121;  ///< FC17's write part
inline constexpr uint8_t kExceptionBit = 0x80;

/// A slave's unit address. A distinct type so it cannot be swapped with a
/// register address: `master.read_holding_registers(UnitId{21}, 0x0021, regs)`.
struct UnitId {
  uint8_t value = 0;
  constexpr explicit UnitId(uint8_t v) noexcept : value(v) {}
  friend constexpr bool operator==(UnitId, UnitId) noexcept = default;
};
inline constexpr UnitId kBroadcast{0};
/// The highest unit address on a serial line (Modbus over serial line, 2.2:
/// 1..247; 248..255 are reserved). A device's own range is its table's.
inline constexpr uint8_t kMaxSerialUnit = 247;

/// The function codes this stack implements.
enum class Function : uint8_t {
  read_coils = 0x01,
  read_discrete_inputs = 0x02,
  read_holding_registers = 0x03,
  read_input_registers = 0x04,
  write_single_coil = 0x05,
  write_single_register = 0x06,
  write_multiple_coils = 0x0F,
  write_multiple_registers = 0x10,
  mask_write_register = 0x16,
  read_write_multiple_registers = 0x17,
  read_exception_status = 0x07,
  diagnostics = 0x08,
  get_comm_event_counter = 0x0B,
  get_comm_event_log = 0x0C,
  report_server_id = 0x11,
  encapsulated_interface = 0x2B,  ///< MEI type 0x0E: read device identification
};

/// FC08 sub-functions (Modbus over serial line, 6.8).
enum class Diagnostic : uint16_t {
  return_query_data = 0x00,
  restart_communications = 0x01,
  return_diagnostic_register = 0x02,
  force_listen_only = 0x04,
  clear_counters = 0x0A,
  bus_message_count = 0x0B,
  bus_communication_error_count = 0x0C,
  bus_exception_error_count = 0x0D,
  server_message_count = 0x0E,
  server_no_response_count = 0x0F,
  server_nak_count = 0x10,
  server_busy_count = 0x11,
  bus_character_overrun_count = 0x12,
  clear_overrun_counter = 0x14,
};
inline constexpr uint8_t kMeiDeviceIdentification = 0x0E;
/// FC2B/0E read device id codes.
enum class DeviceIdAccess : uint8_t { basic = 1, regular = 2, extended = 3, individual = 4 };

/// FC0C comm event bytes (Modbus over serial line, 6.4), as the slave engine
/// logs them and a master reads them back (in words on the host side:
/// tool::comm_event_text in tool/protocol_text.hpp).
namespace comm_event {
inline constexpr uint8_t kRestart = 0x00;             ///< communications restart (FC08 01)
inline constexpr uint8_t kEnteredListenOnly = 0x04;   ///< entered listen-only mode (FC08 04)
inline constexpr uint8_t kReceive = 0x80;             ///< a receive event, with:
inline constexpr uint8_t kReceiveCommError = 0x02;    ///<   communication error (a CRC error)
inline constexpr uint8_t kReceiveOverrun = 0x10;      ///<   character overrun
inline constexpr uint8_t kReceiveBroadcast = 0x40;    ///<   the request was a broadcast
inline constexpr uint8_t kSend = 0x40;                ///< a send event (bit 7 clear), with:
inline constexpr uint8_t kSendReadException = 0x01;   ///<   exception 01..03
inline constexpr uint8_t kSendAbortException = 0x02;  ///<   exception 04 (server abort)
inline constexpr uint8_t kSendBusyException = 0x04;   ///<   exception 05..06 (busy)
inline constexpr uint8_t kSendNakException = 0x08;    ///<   exception 07 (NAK)
inline constexpr uint8_t kSendWriteTimeout = 0x10;    ///<   write timeout
inline constexpr uint8_t kListenOnly = 0x20;          ///< receive or send: in listen-only mode
}  // namespace comm_event

constexpr uint8_t fc(Function f) noexcept {
  return static_cast<uint8_t>(f);
}

/// Documented deviations from the standard frames (spec modbus-rtu.md) that
/// a device is known to use. Off unless a profile or an option turns them on;
/// they only ever apply on RTU links (Modbus TCP frames carry a length).
struct FrameQuirks {
  bool fc10_without_byte_count = false;  ///< the Inverjet's short FC10 request
  bool fc03_two_byte_count = false;      ///< the Rehand 6600's FC03 response with a 2-byte count
};

/// How a PDU travels, for master and slave alike.
enum class Framing : uint8_t {
  rtu,  ///< address + PDU + CRC (serial, pty, RTU-over-TCP); unit 0 is a broadcast
  tcp,  ///< MBAP header + PDU (Modbus TCP); units 0 and 0xFF address a TCP device directly
};

/// A set of function codes: bit n stands for function code n (0..63).
using FunctionSet = uint64_t;
constexpr FunctionSet function_bit(uint8_t function) noexcept {
  return function < 64 ? FunctionSet{1} << function : 0;
}
constexpr FunctionSet function_bit(Function f) noexcept {
  return function_bit(fc(f));
}
/// The eight classic data functions (01..06, 0F, 10).
inline constexpr FunctionSet kDataFunctions =
    function_bit(Function::read_coils) | function_bit(Function::read_discrete_inputs) |
    function_bit(Function::read_holding_registers) | function_bit(Function::read_input_registers) |
    function_bit(Function::write_single_coil) | function_bit(Function::write_single_register) |
    function_bit(Function::write_multiple_coils) | function_bit(Function::write_multiple_registers);
/// Mask write (16) and read/write multiple (17): what a bank of holding
/// registers can serve through its read and write methods. Not in a bank's
/// functions() unless it declares them (a device that does not know them answers 01).
inline constexpr FunctionSet kRegisterCombinedFunctions =
    function_bit(Function::mask_write_register) | function_bit(Function::read_write_multiple_registers);
/// 07, 08, 0B, 0C: the serial line diagnostics the slave engine keeps.
inline constexpr FunctionSet kDiagnosticFunctions =
    function_bit(Function::read_exception_status) | function_bit(Function::diagnostics) |
    function_bit(Function::get_comm_event_counter) | function_bit(Function::get_comm_event_log);
/// 11 and 2B/0E: who the device is (RegisterBank::device_object).
inline constexpr FunctionSet kIdentificationFunctions =
    function_bit(Function::report_server_id) | function_bit(Function::encapsulated_interface);
/// True for the function codes of `Function` whose family is compiled in (config.hpp).
bool is_supported_function(uint8_t function) noexcept;
/// True for 01..04.
bool is_read_function(uint8_t function) noexcept;
/// True for the writes a broadcast may carry: 05, 06, 0F, 10, 16 (the
/// Modbus serial line rule: a broadcast is a write nobody answers).
bool is_broadcastable(uint8_t function) noexcept;
/// "read holding registers", ..., or "unknown function".
const char* function_name(uint8_t function) noexcept;

// ---- byte order helpers: Modbus data is big-endian ----
constexpr uint16_t load_be16(const uint8_t* p) noexcept {
  return static_cast<uint16_t>((p[0] << 8) | p[1]);
}
constexpr void store_be16(uint8_t* p, uint16_t v) noexcept {
  p[0] = static_cast<uint8_t>(v >> 8);
  p[1] = static_cast<uint8_t>(v & 0xFF);
}
/// Bit `i` of a packed bit field (LSB of byte 0 is bit 0, as Modbus packs coils).
constexpr bool get_bit(std::span<const uint8_t> packed, size_t i) noexcept {
  return (packed[i / 8] >> (i % 8)) & 1U;
}
constexpr void set_bit(std::span<uint8_t> packed, size_t i, bool on) noexcept {
  const auto mask = static_cast<uint8_t>(1U << (i % 8));
  packed[i / 8] =
      on ? static_cast<uint8_t>(packed[i / 8] | mask) : static_cast<uint8_t>(packed[i / 8] & ~mask);
}
constexpr size_t packed_size(size_t bits) noexcept {
  return (bits + 7) / 8;
}

/// Copies `count` big-endian registers from `bytes` into `out`.
/// Preconditions: bytes.size() >= 2 * count, out.size() >= count.
void load_registers(std::span<const uint8_t> bytes, std::span<uint16_t> out) noexcept;

/// A request PDU, decoded. `data` views the buffer that was decoded.
struct Request {
  uint8_t function = 0;
  uint16_t address = 0;
  uint16_t quantity = 0;  ///< registers or bits; 1 for single writes
  uint16_t value = 0;     ///< FC05 (0xFF00 on / 0x0000 off) and FC06
  /// FC0F: packed bits; FC10 and FC17: big-endian register values. Empty otherwise.
  std::span<const uint8_t> data{};
  /// FC16: the register becomes (current AND and_mask) OR (or_mask AND NOT and_mask).
  uint16_t and_mask = 0, or_mask = 0;
  /// FC17: the write part (`address` and `quantity` are the read part; the
  /// write happens first).
  uint16_t write_address = 0, write_quantity = 0;
  /// FC08: the sub-function (`value` is its 2-byte data field when it has
  /// one; `data` holds the whole data field).
  uint16_t sub_function = 0;
  /// FC2B: MEI type (0x0E), read device id code (1..4) and object id.
  uint8_t mei_type = 0, read_code = 0, object_id = 0;
  /// FC10 sent without its byte-count byte (the Inverjet document's form).
  bool without_byte_count = false;
};

/// Decodes a request PDU, as a slave does.
/// Errors: illegal_function (function not implemented), illegal_data_value
/// (quantity out of range, byte count or length disagreeing with the quantity,
/// FC05 value other than 0xFF00/0x0000), illegal_data_address (address +
/// quantity past 0xFFFF), malformed (too short to hold the fixed fields: a
/// slave drops it without answering).
Result<Request> decode_request(std::span<const uint8_t> pdu, FrameQuirks quirks = {}) noexcept;

#if RTUKIT_CORE_MASTER
/// Encodes `request` into `out` (FC10 without byte count if
/// `request.without_byte_count`). The same validation as decode_request,
/// returned as invalid_argument for local mistakes; buffer_too_small if `out` is short.
Result<size_t> encode_request(const Request& request, std::span<uint8_t> out) noexcept;

// Convenience encoders for a master. Each returns the PDU length.
Result<size_t> encode_read_request(Function function, uint16_t address, uint16_t quantity,
                                   std::span<uint8_t> out) noexcept;
Result<size_t> encode_write_single_register(uint16_t address, uint16_t value,
                                            std::span<uint8_t> out) noexcept;
#if RTUKIT_CORE_COILS
Result<size_t> encode_write_single_coil(uint16_t address, bool on, std::span<uint8_t> out) noexcept;
#endif
Result<size_t> encode_write_multiple_registers(uint16_t address, std::span<const uint16_t> values,
                                               std::span<uint8_t> out, bool with_byte_count = true) noexcept;
#if RTUKIT_CORE_COILS
/// `bits` holds one coil per element (0 = off, anything else = on).
Result<size_t> encode_write_multiple_coils(uint16_t address, std::span<const uint8_t> bits,
                                           std::span<uint8_t> out) noexcept;
#endif

#if RTUKIT_CORE_MASK_WRITE
/// FC16: the register at `address` becomes (current AND and_mask) OR (or_mask AND NOT and_mask).
Result<size_t> encode_mask_write_register(uint16_t address, uint16_t and_mask, uint16_t or_mask,
                                          std::span<uint8_t> out) noexcept;
#endif
#if RTUKIT_CORE_READ_WRITE
/// FC17: writes `write_data` (big-endian registers, 1..121) at `write_address`,
/// then reads `read_quantity` (1..125) registers from `read_address`.
Result<size_t> encode_read_write_multiple_registers(uint16_t read_address, uint16_t read_quantity,
                                                    uint16_t write_address,
                                                    std::span<const uint8_t> write_data,
                                                    std::span<uint8_t> out) noexcept;
#endif

/// A response PDU, decoded and checked against the request it answers.
struct Response {
  uint8_t function = 0;
  uint16_t address = 0;  ///< writes: the echoed address
  uint16_t value = 0;    ///< FC05/06: echoed value; FC0F/10: echoed quantity
  /// Reads: big-endian register bytes (FC03/04/17) or packed bits (FC01/02).
  std::span<const uint8_t> data{};
  /// FC07, 08, 0B, 0C, 11, 2B: the response's data after the function code,
  /// checked for its length and echoes (FC08's sub-function, FC2B's MEI type
  /// and code); the driver's Master reads the fields.
  std::span<const uint8_t> body{};
  /// FC03/04 answered with a 2-byte byte count (the Rehand 6600 document's form).
  bool long_byte_count = false;
};

/// Decodes the response PDU that answers `request`, as a master does.
/// An exception response returns its exception code as the Error.
/// Errors: malformed (length wrong for the function), unexpected_response
/// (other function, byte count or echo that does not match the request).
Result<Response> decode_response(const Request& request, std::span<const uint8_t> pdu,
                                 FrameQuirks quirks = {}) noexcept;
#endif  // RTUKIT_CORE_MASTER

// Response encoders for a slave. Each returns the PDU length written to `out`.
size_t encode_exception_response(uint8_t function, Errc exception, std::span<uint8_t> out) noexcept;

}  // namespace rtukit
