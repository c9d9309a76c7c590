#include "rtukit/core/pdu.hpp"

#include <cstring>

namespace rtukit {

bool is_supported_function(uint8_t function) noexcept {
  switch (function) {
#if RTUKIT_CORE_COILS
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs):
    case fc(Function::write_single_coil):
    case fc(Function::write_multiple_coils):
#endif
#if RTUKIT_CORE_MASK_WRITE
    case fc(Function::mask_write_register):
#endif
#if RTUKIT_CORE_READ_WRITE
    case fc(Function::read_write_multiple_registers):
#endif
#if RTUKIT_CORE_DIAGNOSTICS
    case fc(Function::read_exception_status):
    case fc(Function::diagnostics):
    case fc(Function::get_comm_event_counter):
    case fc(Function::get_comm_event_log):
#endif
#if RTUKIT_CORE_IDENTIFICATION
    case fc(Function::report_server_id):
    case fc(Function::encapsulated_interface):
#endif
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers):
    case fc(Function::write_single_register):
    case fc(Function::write_multiple_registers):
      return true;
    default:
      return false;
  }
}

bool is_read_function(uint8_t function) noexcept {
  return function >= fc(Function::read_coils) && function <= fc(Function::read_input_registers);
}

bool is_broadcastable(uint8_t function) noexcept {
  switch (function) {
#if RTUKIT_CORE_COILS
    case fc(Function::write_single_coil):
    case fc(Function::write_multiple_coils):
#endif
#if RTUKIT_CORE_MASK_WRITE
    case fc(Function::mask_write_register):
#endif
    case fc(Function::write_single_register):
    case fc(Function::write_multiple_registers):
      return true;
    default:
      return false;
  }
}

const char* function_name(uint8_t function) noexcept {
  switch (function) {
    case fc(Function::read_coils):
      return "read coils";
    case fc(Function::read_discrete_inputs):
      return "read discrete inputs";
    case fc(Function::read_holding_registers):
      return "read holding registers";
    case fc(Function::read_input_registers):
      return "read input registers";
    case fc(Function::write_single_coil):
      return "write single coil";
    case fc(Function::write_single_register):
      return "write single register";
    case fc(Function::write_multiple_coils):
      return "write multiple coils";
    case fc(Function::write_multiple_registers):
      return "write multiple registers";
    case fc(Function::mask_write_register):
      return "mask write register";
    case fc(Function::read_write_multiple_registers):
      return "read/write multiple registers";
    case fc(Function::read_exception_status):
      return "read exception status";
    case fc(Function::diagnostics):
      return "diagnostics";
    case fc(Function::get_comm_event_counter):
      return "get comm event counter";
    case fc(Function::get_comm_event_log):
      return "get comm event log";
    case fc(Function::report_server_id):
      return "report server id";
    case fc(Function::encapsulated_interface):
      return "read device identification";
    default:
      return "unknown function";
  }
}

void load_registers(std::span<const uint8_t> bytes, std::span<uint16_t> out) noexcept {
  for (size_t i = 0; i < out.size(); ++i) out[i] = load_be16(&bytes[2 * i]);
}

namespace {

uint16_t max_quantity(uint8_t function) noexcept {
  switch (function) {
#if RTUKIT_CORE_COILS
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs):
      return kMaxReadBits;
    case fc(Function::write_multiple_coils):
      return kMaxWriteBits;
#endif
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers):
      return kMaxReadRegisters;
    case fc(Function::write_multiple_registers):
      return kMaxWriteRegisters;
    default:
      return 1;
  }
}

// The Modbus specification checks the quantity (exception 03) before the
// address range (exception 02); we keep that order so our answers match
// other implementations byte for byte.
Errc check_range(uint8_t function, uint16_t address, uint16_t quantity) noexcept {
  if (quantity < 1 || quantity > max_quantity(function)) return Errc::illegal_data_value;
  if (static_cast<uint32_t>(address) + quantity > 0x10000U) return Errc::illegal_data_address;
  return Errc::ok;
}

// FC17: both quantities first (03), then both ranges (02).
[[maybe_unused]] Errc check_read_write(const Request& r) noexcept {
  if (r.quantity < 1 || r.quantity > kMaxReadRegisters || r.write_quantity < 1 ||
      r.write_quantity > kMaxReadWriteWriteRegisters)
    return Errc::illegal_data_value;
  if (static_cast<uint32_t>(r.address) + r.quantity > 0x10000U ||
      static_cast<uint32_t>(r.write_address) + r.write_quantity > 0x10000U)
    return Errc::illegal_data_address;
  return Errc::ok;
}

// One reader per request layout, each given the PDU and the request with
// its function (and, after the first five, its address) already read; it
// fills in the rest and says whether the request is well-formed. The
// families compiled out (config.hpp) never get here: decode_request refuses
// them first, and `if constexpr` leaves their readers out of the code.

// 07, 0B, 0C, 11: the function code alone.
[[maybe_unused]] Errc decode_bare(std::span<const uint8_t> pdu) noexcept {
  if (pdu.size() != 1) return Errc::illegal_data_value;
  return Errc::ok;
}

// 08: a sub-function and its data (any data for return query data).
[[maybe_unused]] Errc decode_diagnostics(std::span<const uint8_t> pdu, Request& r) noexcept {
  if (pdu.size() < 3) return Errc::malformed;
  r.sub_function = load_be16(&pdu[1]);
  r.data = pdu.subspan(3);
  if (r.sub_function == static_cast<uint16_t>(Diagnostic::return_query_data)) return Errc::ok;  // any data
  if (pdu.size() != 5) return Errc::illegal_data_value;
  r.value = load_be16(&pdu[3]);
  return Errc::ok;
}

// 2B/0E: read device identification (other MEI types are not implemented).
[[maybe_unused]] Errc decode_identification(std::span<const uint8_t> pdu, Request& r) noexcept {
  if (pdu.size() < 2) return Errc::malformed;
  r.mei_type = pdu[1];
  if (r.mei_type != kMeiDeviceIdentification) return Errc::illegal_function;  // other MEI types
  if (pdu.size() != 4) return pdu.size() < 4 ? Errc::malformed : Errc::illegal_data_value;
  r.read_code = pdu[2];
  r.object_id = pdu[3];
  if (r.read_code < 1 || r.read_code > 4) return Errc::illegal_data_value;
  return Errc::ok;
}

// 01, 02, 03, 04: a quantity.
Errc decode_read(std::span<const uint8_t> pdu, Request& r) noexcept {
  if (pdu.size() != 5) return Errc::illegal_data_value;
  r.quantity = load_be16(&pdu[3]);
  return check_range(r.function, r.address, r.quantity);
}

// 05, 06: one value (a coil's is FF00 or 0000).
Errc decode_write_single(std::span<const uint8_t> pdu, Request& r) noexcept {
  if (pdu.size() != 5) return Errc::illegal_data_value;
  r.quantity = 1;
  r.value = load_be16(&pdu[3]);
  if (kHasCoils && r.function == fc(Function::write_single_coil) && r.value != 0xFF00 && r.value != 0x0000)
    return Errc::illegal_data_value;
  return Errc::ok;
}

// 0F, 10: a quantity, a byte count and the data (or FC10 without the count).
Errc decode_write_multiple(std::span<const uint8_t> pdu, Request& r, FrameQuirks quirks) noexcept {
  r.quantity = load_be16(&pdu[3]);
  const size_t expected_bytes = !kHasCoils || r.function == fc(Function::write_multiple_registers)
                                    ? size_t{2} * r.quantity
                                    : packed_size(r.quantity);
  if (pdu.size() >= 6 && pdu[5] == expected_bytes && pdu.size() == 6 + expected_bytes) {
    r.data = pdu.subspan(6);
  } else if (quirks.fc10_without_byte_count && r.function == fc(Function::write_multiple_registers) &&
             pdu.size() == 5 + expected_bytes && r.quantity > 0) {
    // The Inverjet document prints FC10 requests without the byte count;
    // the length (already CRC-checked by the framer) tells the two apart.
    // Only for a device that opts in, and only on RTU links: over Modbus
    // TCP a truncated standard request would be taken for it.
    r.data = pdu.subspan(5);
    r.without_byte_count = true;
  } else if (pdu.size() < 6) {
    return Errc::malformed;
  } else {
    return Errc::illegal_data_value;  // byte count or length disagrees with quantity
  }
  return check_range(r.function, r.address, r.quantity);
}

// 16: an AND and an OR mask.
[[maybe_unused]] Errc decode_mask_write(std::span<const uint8_t> pdu, Request& r) noexcept {
  if (pdu.size() != 7) return pdu.size() < 7 ? Errc::malformed : Errc::illegal_data_value;
  r.quantity = 1;
  r.and_mask = load_be16(&pdu[3]);
  r.or_mask = load_be16(&pdu[5]);
  return Errc::ok;
}

// 17: a read quantity, a write address, quantity and byte count, the data.
[[maybe_unused]] Errc decode_read_write(std::span<const uint8_t> pdu, Request& r) noexcept {
  if (pdu.size() < 10) return Errc::malformed;
  r.quantity = load_be16(&pdu[3]);
  r.write_address = load_be16(&pdu[5]);
  r.write_quantity = load_be16(&pdu[7]);
  if (Errc e = check_read_write(r); e != Errc::ok) return e;
  if (pdu[9] != 2 * size_t{r.write_quantity} || pdu.size() != 10 + size_t{pdu[9]})
    return Errc::illegal_data_value;
  r.data = pdu.subspan(10);
  return Errc::ok;
}

// The request's fields after its function code, by its layout.
Errc decode_fields(std::span<const uint8_t> pdu, Request& r, FrameQuirks quirks) noexcept {
  if constexpr (kHasDiagnostics || kHasIdentification) {
    switch (r.function) {
      case fc(Function::read_exception_status):
      case fc(Function::get_comm_event_counter):
      case fc(Function::get_comm_event_log):
      case fc(Function::report_server_id):
        return decode_bare(pdu);
      case fc(Function::diagnostics):
        if constexpr (kHasDiagnostics) return decode_diagnostics(pdu, r);
        break;
      case fc(Function::encapsulated_interface):
        if constexpr (kHasIdentification) return decode_identification(pdu, r);
        break;
      default:
        break;
    }
  }
  // The rest start with an address.
  if (pdu.size() < 5) return Errc::malformed;
  r.address = load_be16(&pdu[1]);
  switch (r.function) {
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs):
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers):
      return decode_read(pdu, r);
    case fc(Function::write_single_coil):
    case fc(Function::write_single_register):
      return decode_write_single(pdu, r);
    case fc(Function::write_multiple_coils):
    case fc(Function::write_multiple_registers):
      return decode_write_multiple(pdu, r, quirks);
    case fc(Function::mask_write_register):
      if constexpr (kHasMaskWrite) return decode_mask_write(pdu, r);
      break;
    case fc(Function::read_write_multiple_registers):
      if constexpr (kHasReadWrite) return decode_read_write(pdu, r);
      break;
    default:
      break;
  }
  return Errc::illegal_function;
}

}  // namespace

Result<Request> decode_request(std::span<const uint8_t> pdu, FrameQuirks quirks) noexcept {
  if (pdu.empty()) return Errc::malformed;
  Request r;
  r.function = pdu[0];
  if (!is_supported_function(r.function)) return Errc::illegal_function;
  if (Errc e = decode_fields(pdu, r, quirks); e != Errc::ok) return e;
  return r;
}

#if RTUKIT_CORE_MASTER

Result<size_t> encode_request(const Request& r, std::span<uint8_t> out) noexcept {
  if (!is_supported_function(r.function)) return Errc::invalid_argument;
  if (out.empty()) return Errc::buffer_too_small;
#if RTUKIT_CORE_DIAGNOSTICS || RTUKIT_CORE_IDENTIFICATION
  switch (r.function) {
#if RTUKIT_CORE_DIAGNOSTICS
    case fc(Function::read_exception_status):
    case fc(Function::get_comm_event_counter):
    case fc(Function::get_comm_event_log):
#endif
#if RTUKIT_CORE_IDENTIFICATION
    case fc(Function::report_server_id):
#endif
      out[0] = r.function;
      return size_t{1};
#if RTUKIT_CORE_DIAGNOSTICS
    case fc(Function::diagnostics): {
      // The data field: return query data (00) carries `data`, any length;
      // every other sub-function its 2-byte `value`.
      const bool query = r.sub_function == static_cast<uint16_t>(Diagnostic::return_query_data);
      const size_t bytes = query ? r.data.size() : 2;
      if (3 + bytes > kMaxPduSize) return Errc::invalid_argument;
      if (out.size() < 3 + bytes) return Errc::buffer_too_small;
      out[0] = r.function;
      store_be16(&out[1], r.sub_function);
      if (query)
        std::memcpy(&out[3], r.data.data(), bytes);
      else
        store_be16(&out[3], r.value);
      return 3 + bytes;
    }
#endif
#if RTUKIT_CORE_IDENTIFICATION
    case fc(Function::encapsulated_interface):
      if (r.read_code < 1 || r.read_code > 4) return Errc::invalid_argument;
      if (out.size() < 4) return Errc::buffer_too_small;
      out[0] = r.function;
      out[1] = kMeiDeviceIdentification;
      out[2] = r.read_code;
      out[3] = r.object_id;
      return size_t{4};
#endif
    default:
      break;
  }
#endif
  size_t n = 0;
  switch (r.function) {
#if RTUKIT_CORE_COILS
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs):
#endif
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers):
      if (check_range(r.function, r.address, r.quantity) != Errc::ok) return Errc::invalid_argument;
      n = 5;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.quantity);
      break;
#if RTUKIT_CORE_COILS
    case fc(Function::write_single_coil):
#endif
    case fc(Function::write_single_register):
      if (RTUKIT_CORE_COILS && r.function == fc(Function::write_single_coil) && r.value != 0xFF00 &&
          r.value != 0)
        return Errc::invalid_argument;
      n = 5;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.value);
      break;
#if RTUKIT_CORE_COILS
    case fc(Function::write_multiple_coils):
#endif
    case fc(Function::write_multiple_registers): {
      if (check_range(r.function, r.address, r.quantity) != Errc::ok) return Errc::invalid_argument;
      const size_t bytes = !RTUKIT_CORE_COILS || r.function == fc(Function::write_multiple_registers)
                               ? size_t{2} * r.quantity
                               : packed_size(r.quantity);
      if (r.data.size() != bytes) return Errc::invalid_argument;
      const bool short_form = r.function == fc(Function::write_multiple_registers) && r.without_byte_count;
      const size_t header = short_form ? 5 : 6;
      n = header + bytes;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.quantity);
      if (!short_form) out[5] = static_cast<uint8_t>(bytes);
      std::memcpy(&out[header], r.data.data(), bytes);
      break;
    }
#if RTUKIT_CORE_MASK_WRITE
    case fc(Function::mask_write_register):
      n = 7;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.and_mask);
      store_be16(&out[5], r.or_mask);
      break;
#endif
#if RTUKIT_CORE_READ_WRITE
    case fc(Function::read_write_multiple_registers): {
      if (check_read_write(r) != Errc::ok) return Errc::invalid_argument;
      const size_t bytes = size_t{2} * r.write_quantity;
      if (r.data.size() != bytes) return Errc::invalid_argument;
      n = 10 + bytes;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.quantity);
      store_be16(&out[5], r.write_address);
      store_be16(&out[7], r.write_quantity);
      out[9] = static_cast<uint8_t>(bytes);
      std::memcpy(&out[10], r.data.data(), bytes);
      break;
    }
#endif
    default:
      return Errc::invalid_argument;
  }
  out[0] = r.function;
  store_be16(&out[1], r.address);
  return n;
}

Result<size_t> encode_read_request(Function function, uint16_t address, uint16_t quantity,
                                   std::span<uint8_t> out) noexcept {
  if (!is_read_function(fc(function))) return Errc::invalid_argument;
  Request r;
  r.function = fc(function);
  r.address = address;
  r.quantity = quantity;
  return encode_request(r, out);
}

Result<size_t> encode_write_single_register(uint16_t address, uint16_t value,
                                            std::span<uint8_t> out) noexcept {
  Request r;
  r.function = fc(Function::write_single_register);
  r.address = address;
  r.quantity = 1;
  r.value = value;
  return encode_request(r, out);
}

#if RTUKIT_CORE_COILS
Result<size_t> encode_write_single_coil(uint16_t address, bool on, std::span<uint8_t> out) noexcept {
  Request r;
  r.function = fc(Function::write_single_coil);
  r.address = address;
  r.quantity = 1;
  r.value = on ? 0xFF00 : 0x0000;
  return encode_request(r, out);
}
#endif

Result<size_t> encode_write_multiple_registers(uint16_t address, std::span<const uint16_t> values,
                                               std::span<uint8_t> out, bool with_byte_count) noexcept {
  if (values.empty() || values.size() > kMaxWriteRegisters) return Errc::invalid_argument;
  const size_t header = with_byte_count ? 6 : 5;
  if (out.size() < header + 2 * values.size()) return Errc::buffer_too_small;
  if (static_cast<uint32_t>(address) + values.size() > 0x10000U) return Errc::invalid_argument;
  out[0] = fc(Function::write_multiple_registers);
  store_be16(&out[1], address);
  store_be16(&out[3], static_cast<uint16_t>(values.size()));
  if (with_byte_count) out[5] = static_cast<uint8_t>(2 * values.size());
  for (size_t i = 0; i < values.size(); ++i) store_be16(&out[header + 2 * i], values[i]);
  return header + 2 * values.size();
}

#if RTUKIT_CORE_COILS
Result<size_t> encode_write_multiple_coils(uint16_t address, std::span<const uint8_t> bits,
                                           std::span<uint8_t> out) noexcept {
  if (bits.empty() || bits.size() > kMaxWriteBits) return Errc::invalid_argument;
  const size_t bytes = packed_size(bits.size());
  if (out.size() < 6 + bytes) return Errc::buffer_too_small;
  if (static_cast<uint32_t>(address) + bits.size() > 0x10000U) return Errc::invalid_argument;
  out[0] = fc(Function::write_multiple_coils);
  store_be16(&out[1], address);
  store_be16(&out[3], static_cast<uint16_t>(bits.size()));
  out[5] = static_cast<uint8_t>(bytes);
  std::memset(&out[6], 0, bytes);
  for (size_t i = 0; i < bits.size(); ++i) set_bit(out.subspan(6), i, bits[i] != 0);
  return 6 + bytes;
}
#endif

#if RTUKIT_CORE_MASK_WRITE
Result<size_t> encode_mask_write_register(uint16_t address, uint16_t and_mask, uint16_t or_mask,
                                          std::span<uint8_t> out) noexcept {
  Request r;
  r.function = fc(Function::mask_write_register);
  r.address = address;
  r.quantity = 1;
  r.and_mask = and_mask;
  r.or_mask = or_mask;
  return encode_request(r, out);
}
#endif

#if RTUKIT_CORE_READ_WRITE
Result<size_t> encode_read_write_multiple_registers(uint16_t read_address, uint16_t read_quantity,
                                                    uint16_t write_address,
                                                    std::span<const uint8_t> write_data,
                                                    std::span<uint8_t> out) noexcept {
  Request r;
  r.function = fc(Function::read_write_multiple_registers);
  r.address = read_address;
  r.quantity = read_quantity;
  r.write_address = write_address;
  r.write_quantity = static_cast<uint16_t>(write_data.size() / 2);
  r.data = write_data;
  if (write_data.size() % 2 != 0) return Errc::invalid_argument;
  return encode_request(r, out);
}
#endif

Result<Response> decode_response(const Request& request, std::span<const uint8_t> pdu,
                                 FrameQuirks quirks) noexcept {
  if (pdu.empty()) return Errc::malformed;
  if (pdu[0] == (request.function | kExceptionBit)) {
    if (pdu.size() != 2) return Errc::malformed;
    if (pdu[1] == 0) return Errc::unexpected_response;  // 0 is not an exception code
    return Error::exception(pdu[1]);
  }
  if (pdu[0] != request.function) return Errc::unexpected_response;
  Response r;
  r.function = pdu[0];
  switch (request.function) {
#if RTUKIT_CORE_DIAGNOSTICS
    case fc(Function::read_exception_status):
      if (pdu.size() != 2) return Errc::malformed;
      r.body = pdu.subspan(1);
      return r;
    case fc(Function::get_comm_event_counter):
      if (pdu.size() != 5) return Errc::malformed;
      r.body = pdu.subspan(1);
      return r;
#endif
#if RTUKIT_CORE_DIAGNOSTICS || RTUKIT_CORE_IDENTIFICATION
#if RTUKIT_CORE_DIAGNOSTICS
    case fc(Function::get_comm_event_log):
#endif
#if RTUKIT_CORE_IDENTIFICATION
    case fc(Function::report_server_id):
#endif
      // A byte count, then that many bytes (FC0C: at least status, event
      // count and message count).
      if (pdu.size() < 2 || pdu[1] != pdu.size() - 2) return Errc::malformed;
      if (request.function == fc(Function::get_comm_event_log) && pdu[1] < 6) return Errc::malformed;
      r.body = pdu.subspan(1);
      return r;
#endif
#if RTUKIT_CORE_DIAGNOSTICS
    case fc(Function::diagnostics):
      if (pdu.size() < 3) return Errc::malformed;
      if (load_be16(&pdu[1]) != request.sub_function) return Errc::unexpected_response;
      if (request.sub_function != static_cast<uint16_t>(Diagnostic::return_query_data) && pdu.size() != 5)
        return Errc::malformed;
      r.body = pdu.subspan(1);
      return r;
#endif
#if RTUKIT_CORE_IDENTIFICATION
    case fc(Function::encapsulated_interface): {
      // 2B 0E code conformity more-follows next-id count, then count objects
      // of id, length, value.
      if (pdu.size() < 7) return Errc::malformed;
      if (pdu[1] != kMeiDeviceIdentification || pdu[2] != request.read_code) return Errc::unexpected_response;
      size_t at = 7;
      for (unsigned i = 0; i < pdu[6]; ++i) {
        if (at + 2 > pdu.size() || at + 2 + pdu[at + 1] > pdu.size()) return Errc::malformed;
        at += 2 + size_t{pdu[at + 1]};
      }
      if (at != pdu.size()) return Errc::malformed;
      r.body = pdu.subspan(1);
      return r;
    }
#endif
#if RTUKIT_CORE_MASK_WRITE
    case fc(Function::mask_write_register): {
      // The answer echoes the request.
      if (pdu.size() != 7) return Errc::malformed;
      r.address = load_be16(&pdu[1]);
      if (r.address != request.address || load_be16(&pdu[3]) != request.and_mask ||
          load_be16(&pdu[5]) != request.or_mask)
        return Errc::unexpected_response;
      return r;
    }
#endif
#if RTUKIT_CORE_READ_WRITE
    case fc(Function::read_write_multiple_registers): {
      const size_t expected = size_t{2} * request.quantity;
      if (pdu.size() < 2) return Errc::malformed;
      if (pdu[1] != expected || pdu.size() != 2 + expected) return Errc::unexpected_response;
      r.data = pdu.subspan(2);
      return r;
    }
#endif
#if RTUKIT_CORE_COILS
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs):
#endif
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers): {
      const bool registers = !RTUKIT_CORE_COILS || request.function >= fc(Function::read_holding_registers);
      const size_t expected = registers ? size_t{2} * request.quantity : packed_size(request.quantity);
      if (pdu.size() >= 2 && pdu[1] == expected && pdu.size() == 2 + expected) {
        r.data = pdu.subspan(2);
      } else if (quirks.fc03_two_byte_count && registers && pdu.size() == 3 + expected &&
                 load_be16(&pdu[1]) == expected) {
        // The Rehand 6600 document prints a 2-byte byte count; accepted from a
        // device that opts in.
        r.data = pdu.subspan(3);
        r.long_byte_count = true;
      } else if (pdu.size() < 2) {
        return Errc::malformed;
      } else {
        return Errc::unexpected_response;
      }
      return r;
    }
#if RTUKIT_CORE_COILS
    case fc(Function::write_single_coil):
    case fc(Function::write_multiple_coils):
#endif
    case fc(Function::write_single_register):
    case fc(Function::write_multiple_registers): {
      if (pdu.size() != 5) return Errc::malformed;
      r.address = load_be16(&pdu[1]);
      r.value = load_be16(&pdu[3]);
      const uint16_t expected =
          request.function <= fc(Function::write_single_register) ? request.value : request.quantity;
      if (r.address != request.address || r.value != expected) return Errc::unexpected_response;
      return r;
    }
    default:
      return Errc::invalid_argument;
  }
}
#endif  // RTUKIT_CORE_MASTER

size_t encode_exception_response(uint8_t function, Errc exception, std::span<uint8_t> out) noexcept {
  if (out.size() < 2) return 0;
  out[0] = static_cast<uint8_t>(function | kExceptionBit);
  out[1] = static_cast<uint8_t>(exception);
  return 2;
}

}  // namespace rtukit
