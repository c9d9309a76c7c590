// rtukit core: the slave engine. Turns a request into a response (or silence).
//
// A device implements `RegisterBank`; the engine does everything that is the
// same for every device: unit address filtering, broadcast, decoding and
// validating the request (function, quantity, byte count, address overflow),
// calling the bank, and encoding the response or exception. One engine can
// host several units, so one simulated bus can carry several devices.
//
// Sans-IO: a driver hands the engine complete frames (from RtuFramer or an
// MBAP stream) and sends back what the engine writes. No heap; register data
// passes through a 250-byte stack buffer. The function families it serves are
// config.hpp's choice (a family compiled out is answered with 01).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "rtukit/core/config.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/core/pdu.hpp"

namespace rtukit {

/// What a device implements. Every method returns Errc::ok or the Modbus
/// exception to answer with. A method left as is answers illegal_function,
/// so a device that has no coils simply does not override the coil methods.
///
/// Contract for writes: **all or nothing**. A bank validates the whole range
/// and every value first and changes nothing unless it returns ok; the engine
/// relies on this to promise atomic multi-register writes.
///
/// Bits are packed as on the wire: bit i of the range is bit (i % 8) of byte
/// (i / 8). The engine has checked that address + count does not pass 0xFFFF.
// All methods are inline (no key function), so a bank compiled with RTTI
// links against a core compiled without it.
class RegisterBank {
 public:
  virtual ~RegisterBank() = default;
  /// FC01. `packed_out` has packed_size(count) bytes, zeroed.
  virtual Errc read_coils(uint16_t /*address*/, uint16_t /*count*/, std::span<uint8_t> /*packed_out*/) {
    return Errc::illegal_function;
  }
  /// FC02. As read_coils.
  virtual Errc read_discrete_inputs(uint16_t /*address*/, uint16_t /*count*/,
                                    std::span<uint8_t> /*packed_out*/) {
    return Errc::illegal_function;
  }
  /// FC03. Fill `out` (out.size() registers from `address`).
  virtual Errc read_holding_registers(uint16_t /*address*/, std::span<uint16_t> /*out*/) {
    return Errc::illegal_function;
  }
  /// FC04. As read_holding_registers.
  virtual Errc read_input_registers(uint16_t /*address*/, std::span<uint16_t> /*out*/) {
    return Errc::illegal_function;
  }
  /// FC05 (count 1) and FC0F.
  virtual Errc write_coils(uint16_t /*address*/, uint16_t /*count*/, std::span<const uint8_t> /*packed*/) {
    return Errc::illegal_function;
  }
  /// FC06 (one value) and FC10.
  virtual Errc write_holding_registers(uint16_t /*address*/, std::span<const uint16_t> /*values*/) {
    return Errc::illegal_function;
  }
  /// The function codes this bank implements. A request for any other gets
  /// exception 01 before its quantity or values are looked at (Modbus checks
  /// the function first). Default: the eight data functions.
  virtual FunctionSet functions() const noexcept { return kDataFunctions; }
  /// The documented request forms this device accepts (the Inverjet's FC10
  /// without byte count). Off by default; the engine applies them on RTU
  /// links only (an MBAP frame carries its length).
  virtual FrameQuirks quirks() const noexcept { return {}; }
  /// FC07: the device's eight exception status outputs. Default 0.
  virtual uint8_t exception_status() { return 0; }
  /// FC11 and FC2B/0E: identification object `id` (0 vendor name, 1 product
  /// code, 2 major.minor revision; 3 vendor URL, 4 product name, 5 model
  /// name, 6 user application name; 0x80..0xFF the device's own), or empty
  /// when the device has no such object. The view must stay valid until the
  /// next call. A bank that declares kIdentificationFunctions has 0, 1 and 2.
  virtual std::string_view device_object(uint8_t /*id*/) { return {}; }
  /// Called by the driver once the response to the last request of this unit
  /// has been sent (or would have been: broadcast). A device applies changes
  /// that must not affect that response here, such as a new address or baud rate.
  virtual void after_response() {}
};

class SlaveEngine {
 public:
  static constexpr size_t kMaxUnits = 16;

  /// The serial line diagnostics (Modbus over serial line 6.8; FC08 0x0B..0x12
  /// return them), since start, restart or clear. 16 bits, wrapping, as on the wire.
  struct LineCounters {
    uint16_t bus_messages = 0;        ///< every frame seen on the line, any unit
    uint16_t bus_crc_errors = 0;      ///< frames dropped for their CRC (note_crc_errors)
    uint16_t bus_exceptions = 0;      ///< exception responses sent
    uint16_t server_messages = 0;     ///< requests addressed to us, broadcasts included
    uint16_t server_no_response = 0;  ///< of those, left unanswered (broadcast, listen-only, malformed)
    uint16_t server_nak = 0;          ///< always 0: we never answer NAK
    uint16_t server_busy = 0;         ///< exception 06 sent
    uint16_t bus_overruns = 0;        ///< characters lost to a full buffer (note_overrun)
  };
  /// FC0C: the last 64 events, the newest first.
  static constexpr size_t kEventLogSize = 64;

  struct Counters {
    uint32_t requests = 0;    ///< requests addressed to us (incl. broadcast)
    uint32_t responses = 0;   ///< normal responses sent
    uint32_t exceptions = 0;  ///< exception responses sent
    uint32_t broadcasts = 0;  ///< broadcast requests received
    uint32_t ignored = 0;     ///< frames for units we do not host
    uint32_t malformed = 0;   ///< requests dropped without an answer (RTU)
  };

  /// Hosts `bank` at `unit` (1..255). The bank must outlive the engine.
  /// Errors: invalid_argument (unit 0 or already hosted), buffer_too_small (full).
  Error add_unit(UnitId unit, RegisterBank& bank) noexcept;
  /// Moves a hosted unit to a new address. Errors: invalid_argument.
  Error change_unit_address(UnitId from, UnitId to) noexcept;
  bool remove_unit(UnitId unit) noexcept;
  RegisterBank* find(UnitId unit) const noexcept;
  size_t unit_count() const noexcept { return count_; }

  /// What a request came to: the length of the response written to `out`
  /// (0 = stay silent) and the bank that ran it (for after_response), or nullptr.
  struct Handled {
    size_t length = 0;
    RegisterBank* bank = nullptr;
  };

  /// Handles the request `pdu` addressed to `unit`, read as `framing` says:
  /// on RTU unit 0 is a broadcast (writes run on every unit, nobody answers);
  /// on Modbus TCP units 0 and 0xFF address the first unit (a TCP device
  /// addressed directly), and no frame quirk applies. Writes the response PDU to
  /// `out` (>= 253 bytes). Silent for a broadcast, another unit's frame, or a
  /// malformed request on RTU (too short for its function's fields: a
  /// truncated frame); over Modbus TCP such a request gets 03.
  Handled handle_pdu(UnitId unit, std::span<const uint8_t> pdu, std::span<uint8_t> out,
                     Framing framing = Framing::rtu) noexcept;

  /// RTU: `adu` is a CRC-checked frame (address + PDU + CRC). Writes the
  /// response ADU to `out` (>= 256 bytes).
  Handled handle_rtu(std::span<const uint8_t> adu, std::span<uint8_t> out) noexcept;

#if RTUKIT_CORE_TCP
  /// Modbus TCP: `adu` is a complete MBAP ADU. Writes the response ADU to
  /// `out` (>= 260 bytes).
  Handled handle_tcp(std::span<const uint8_t> adu, std::span<uint8_t> out) noexcept;
#endif

  /// Modbus TCP only: answer requests for any unit id with the first hosted
  /// unit (a gateway-less TCP device that ignores the id). Off by default:
  /// units 0 and 0xFF reach the first unit, others are ignored.
  void set_answer_any_unit_over_tcp(bool on) noexcept { any_unit_ = on; }

  const Counters& counters() const noexcept { return counters_; }
  const LineCounters& line_counters() const noexcept { return line_; }
  /// True after FC08 "force listen only mode": every request is watched
  /// (counted) but nothing runs and nothing is answered, until FC08
  /// "restart communications". Always false without RTUKIT_CORE_DIAGNOSTICS.
  bool listen_only() const noexcept { return listen_only_; }
  /// The driver saw `n` frames fail their CRC (the framer's count): bus
  /// communication errors (FC08 0x0C) and a receive event with its error bit.
  void note_crc_errors(uint32_t n) noexcept;
  /// The driver lost characters to a full buffer (FC08 0x12).
  void note_overrun() noexcept;
  /// The quirks of every hosted unit together: what an RTU framer serving
  /// this engine must recognise.
  FrameQuirks quirks() const noexcept;

 private:
  struct Unit {
    uint8_t address = 0;
    RegisterBank* bank = nullptr;
  };
  Errc execute(RegisterBank& bank, const Request& request, std::span<uint8_t> out, size_t* length) noexcept;
#if RTUKIT_CORE_DIAGNOSTICS
  Errc diagnose(const Request& request, std::span<uint8_t> out, size_t* length, bool* silent) noexcept;
  void log_event(uint8_t event) noexcept;
#else
  void log_event(uint8_t /*event*/) noexcept {}
#endif
#if RTUKIT_CORE_IDENTIFICATION
  Errc identify(RegisterBank& bank, UnitId unit, const Request& request, std::span<uint8_t> out,
                size_t* length) noexcept;
#endif

  std::array<Unit, kMaxUnits> units_{};
  size_t count_ = 0;
  Counters counters_{};
  LineCounters line_{};
#if RTUKIT_CORE_DIAGNOSTICS
  uint16_t diagnostic_register_ = 0;
  uint16_t event_count_ = 0;  // FC0B: successful completions
  bool listen_only_ = false;
#else
  static constexpr bool listen_only_ = false;
#endif
  bool any_unit_ = false;
#if RTUKIT_CORE_DIAGNOSTICS
  std::array<uint8_t, kEventLogSize> events_{};  // ring, events_[event_head_ - 1] newest
  size_t event_head_ = 0, event_len_ = 0;
#endif
};

}  // namespace rtukit
