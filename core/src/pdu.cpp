#include "rtukit/core/pdu.hpp"

#include <cstring>

namespace rtukit {

bool is_supported_function(uint8_t function) noexcept {
  switch (function) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
    case 0x05:
    case 0x06:
    case 0x0F:
    case 0x10:
      return true;
    default:
      return false;
  }
}

bool is_read_function(uint8_t function) noexcept {
  return function >= 0x01 && function <= 0x04;
}

const char* function_name(uint8_t function) noexcept {
  switch (function) {
    case 0x01:
      return "read coils";
    case 0x02:
      return "read discrete inputs";
    case 0x03:
      return "read holding registers";
    case 0x04:
      return "read input registers";
    case 0x05:
      return "write single coil";
    case 0x06:
      return "write single register";
    case 0x0F:
      return "write multiple coils";
    case 0x10:
      return "write multiple registers";
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
    case 0x01:
    case 0x02:
      return kMaxReadBits;
    case 0x03:
    case 0x04:
      return kMaxReadRegisters;
    case 0x0F:
      return kMaxWriteBits;
    case 0x10:
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

}  // namespace

Result<Request> decode_request(std::span<const uint8_t> pdu, FrameQuirks quirks) noexcept {
  if (pdu.empty()) return Errc::malformed;
  Request r;
  r.function = pdu[0];
  if (!is_supported_function(r.function)) return Errc::illegal_function;
  if (pdu.size() < 5) return Errc::malformed;
  r.address = load_be16(&pdu[1]);
  switch (r.function) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04: {
      if (pdu.size() != 5) return Errc::illegal_data_value;
      r.quantity = load_be16(&pdu[3]);
      if (Errc e = check_range(r.function, r.address, r.quantity); e != Errc::ok) return e;
      return r;
    }
    case 0x05:
    case 0x06: {
      if (pdu.size() != 5) return Errc::illegal_data_value;
      r.quantity = 1;
      r.value = load_be16(&pdu[3]);
      if (r.function == 0x05 && r.value != 0xFF00 && r.value != 0x0000) return Errc::illegal_data_value;
      return r;
    }
    case 0x0F:
    case 0x10: {
      r.quantity = load_be16(&pdu[3]);
      const size_t expected_bytes = r.function == 0x10 ? size_t{2} * r.quantity : packed_size(r.quantity);
      if (pdu.size() >= 6 && pdu[5] == expected_bytes && pdu.size() == 6 + expected_bytes) {
        r.data = pdu.subspan(6);
      } else if (quirks.fc10_without_byte_count && r.function == 0x10 && pdu.size() == 5 + expected_bytes &&
                 r.quantity > 0) {
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
      if (Errc e = check_range(r.function, r.address, r.quantity); e != Errc::ok) return e;
      return r;
    }
    default:
      return Errc::illegal_function;
  }
}

Result<size_t> encode_request(const Request& r, std::span<uint8_t> out) noexcept {
  if (!is_supported_function(r.function)) return Errc::invalid_argument;
  size_t n = 0;
  switch (r.function) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04:
      if (check_range(r.function, r.address, r.quantity) != Errc::ok) return Errc::invalid_argument;
      n = 5;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.quantity);
      break;
    case 0x05:
    case 0x06:
      if (r.function == 0x05 && r.value != 0xFF00 && r.value != 0) return Errc::invalid_argument;
      n = 5;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.value);
      break;
    case 0x0F:
    case 0x10: {
      if (check_range(r.function, r.address, r.quantity) != Errc::ok) return Errc::invalid_argument;
      const size_t bytes = r.function == 0x10 ? size_t{2} * r.quantity : packed_size(r.quantity);
      if (r.data.size() != bytes) return Errc::invalid_argument;
      const bool short_form = r.function == 0x10 && r.without_byte_count;
      const size_t header = short_form ? 5 : 6;
      n = header + bytes;
      if (out.size() < n) return Errc::buffer_too_small;
      store_be16(&out[3], r.quantity);
      if (!short_form) out[5] = static_cast<uint8_t>(bytes);
      std::memcpy(&out[header], r.data.data(), bytes);
      break;
    }
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

Result<size_t> encode_write_single_coil(uint16_t address, bool on, std::span<uint8_t> out) noexcept {
  Request r;
  r.function = fc(Function::write_single_coil);
  r.address = address;
  r.quantity = 1;
  r.value = on ? 0xFF00 : 0x0000;
  return encode_request(r, out);
}

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
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04: {
      const bool registers = request.function >= 0x03;
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
    case 0x05:
    case 0x06:
    case 0x0F:
    case 0x10: {
      if (pdu.size() != 5) return Errc::malformed;
      r.address = load_be16(&pdu[1]);
      r.value = load_be16(&pdu[3]);
      const uint16_t expected = request.function <= 0x06 ? request.value : request.quantity;
      if (r.address != request.address || r.value != expected) return Errc::unexpected_response;
      return r;
    }
    default:
      return Errc::invalid_argument;
  }
}

size_t encode_exception_response(uint8_t function, Errc exception, std::span<uint8_t> out) noexcept {
  if (out.size() < 2) return 0;
  out[0] = static_cast<uint8_t>(function | kExceptionBit);
  out[1] = static_cast<uint8_t>(exception);
  return 2;
}

}  // namespace rtukit
