#include "rtukit/core/slave.hpp"

#include <cstring>

#include "rtukit/core/crc.hpp"
#include "rtukit/core/mbap.hpp"
#include "rtukit/core/rtu.hpp"

namespace rtukit {

Error SlaveEngine::add_unit(UnitId unit, RegisterBank& bank) noexcept {
  if (unit == kBroadcast || find(unit) != nullptr) return Errc::invalid_argument;
  if (count_ == units_.size()) return Errc::buffer_too_small;
  units_[count_++] = Unit{unit.value, &bank};
  return {};
}

Error SlaveEngine::change_unit_address(UnitId from, UnitId to) noexcept {
  if (to == kBroadcast || (from != to && find(to) != nullptr)) return Errc::invalid_argument;
  for (size_t i = 0; i < count_; ++i) {
    if (units_[i].address == from.value) {
      units_[i].address = to.value;
      return {};
    }
  }
  return Errc::invalid_argument;
}

bool SlaveEngine::remove_unit(UnitId unit) noexcept {
  for (size_t i = 0; i < count_; ++i) {
    if (units_[i].address == unit.value) {
      units_[i] = units_[count_ - 1];
      units_[--count_] = Unit{};
      return true;
    }
  }
  return false;
}

FrameQuirks SlaveEngine::quirks() const noexcept {
  FrameQuirks q;
  for (size_t i = 0; i < count_; ++i) {
    const FrameQuirks b = units_[i].bank->quirks();
    q.fc10_without_byte_count = q.fc10_without_byte_count || b.fc10_without_byte_count;
    q.fc03_two_byte_count = q.fc03_two_byte_count || b.fc03_two_byte_count;
  }
  return q;
}

RegisterBank* SlaveEngine::find(UnitId unit) const noexcept {
  for (size_t i = 0; i < count_; ++i)
    if (units_[i].address == unit.value) return units_[i].bank;
  return nullptr;
}

// Runs a validated request on `bank`; on success writes the response PDU.
Errc SlaveEngine::execute(RegisterBank& bank, const Request& r, std::span<uint8_t> out,
                          size_t* length) noexcept {
  out[0] = r.function;
  switch (r.function) {
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs): {
      const size_t bytes = packed_size(r.quantity);
      std::memset(&out[2], 0, bytes);
      const Errc e = r.function == fc(Function::read_coils)
                         ? bank.read_coils(r.address, r.quantity, out.subspan(2, bytes))
                         : bank.read_discrete_inputs(r.address, r.quantity, out.subspan(2, bytes));
      if (e != Errc::ok) return e;
      out[1] = static_cast<uint8_t>(bytes);
      *length = 2 + bytes;
      return Errc::ok;
    }
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers): {
      std::array<uint16_t, kMaxReadRegisters> regs{};
      const std::span<uint16_t> view(regs.data(), r.quantity);
      const Errc e = r.function == fc(Function::read_holding_registers)
                         ? bank.read_holding_registers(r.address, view)
                         : bank.read_input_registers(r.address, view);
      if (e != Errc::ok) return e;
      out[1] = static_cast<uint8_t>(2 * r.quantity);
      for (size_t i = 0; i < r.quantity; ++i) store_be16(&out[2 + 2 * i], regs[i]);
      *length = 2 + 2 * size_t{r.quantity};
      return Errc::ok;
    }
    case fc(Function::write_single_coil): {
      const uint8_t bit = r.value == 0xFF00 ? 1 : 0;
      const Errc e = bank.write_coils(r.address, 1, {&bit, 1});
      if (e != Errc::ok) return e;
      break;
    }
    case fc(Function::write_single_register): {
      const uint16_t value = r.value;
      const Errc e = bank.write_holding_registers(r.address, {&value, 1});
      if (e != Errc::ok) return e;
      break;
    }
    case fc(Function::write_multiple_coils): {
      const Errc e = bank.write_coils(r.address, r.quantity, r.data);
      if (e != Errc::ok) return e;
      break;
    }
    case fc(Function::write_multiple_registers): {
      std::array<uint16_t, kMaxWriteRegisters> regs{};
      load_registers(r.data, {regs.data(), r.quantity});
      const Errc e = bank.write_holding_registers(r.address, {regs.data(), r.quantity});
      if (e != Errc::ok) return e;
      break;
    }
    case fc(Function::mask_write_register): {
      // Read, modify, write: one register, so the bank's write is the commit.
      uint16_t current = 0;
      if (Errc e = bank.read_holding_registers(r.address, {&current, 1}); e != Errc::ok) return e;
      const auto value = static_cast<uint16_t>((current & r.and_mask) | (r.or_mask & ~r.and_mask));
      if (Errc e = bank.write_holding_registers(r.address, {&value, 1}); e != Errc::ok) return e;
      store_be16(&out[1], r.address);
      store_be16(&out[3], r.and_mask);
      store_be16(&out[5], r.or_mask);
      *length = 7;
      return Errc::ok;
    }
    case fc(Function::read_write_multiple_registers): {
      // The write comes first (the specification's order), all or nothing.
      // The read range is tried before it, so that a read that must fail
      // (02) answers without the write having been applied.
      std::array<uint16_t, kMaxReadRegisters> regs{};
      const std::span<uint16_t> view(regs.data(), r.quantity);
      if (Errc e = bank.read_holding_registers(r.address, view); e != Errc::ok) return e;
      std::array<uint16_t, kMaxReadWriteWriteRegisters> values{};
      load_registers(r.data, {values.data(), r.write_quantity});
      if (Errc e = bank.write_holding_registers(r.write_address, {values.data(), r.write_quantity});
          e != Errc::ok)
        return e;
      if (Errc e = bank.read_holding_registers(r.address, view); e != Errc::ok) return e;
      out[1] = static_cast<uint8_t>(2 * r.quantity);
      for (size_t i = 0; i < r.quantity; ++i) store_be16(&out[2 + 2 * i], regs[i]);
      *length = 2 + 2 * size_t{r.quantity};
      return Errc::ok;
    }
    default:
      return Errc::illegal_function;
  }
  // Write responses echo address and value (single) or quantity (multiple).
  store_be16(&out[1], r.address);
  store_be16(&out[3], r.function == fc(Function::write_single_coil) ||
                              r.function == fc(Function::write_single_register)
                          ? r.value
                          : r.quantity);
  *length = 5;
  return Errc::ok;
}

SlaveEngine::Handled SlaveEngine::handle_pdu(UnitId unit, std::span<const uint8_t> pdu,
                                             std::span<uint8_t> out, Framing framing) noexcept {
  if (pdu.empty() || out.size() < kMaxPduSize) return {};
  const bool broadcast = framing == Framing::rtu && unit == kBroadcast;
  RegisterBank* bank = nullptr;
  if (!broadcast) {
    bank = find(unit);
    if (bank == nullptr && framing == Framing::tcp && (unit == kBroadcast || unit == UnitId{0xFF}) &&
        count_ > 0) {
      bank = units_[0].bank;
    }
    if (bank == nullptr) {
      ++counters_.ignored;
      return {};
    }
  }
  ++counters_.requests;
  // Quirks apply on RTU links only; a broadcast is decoded with every hosted unit's.
  const FrameQuirks quirks = framing != Framing::rtu ? FrameQuirks{}
                             : broadcast             ? this->quirks()
                                                     : bank->quirks();
  const Result<Request> request = decode_request(pdu, quirks);

  if (broadcast) {
    // Only writes are executed; nobody answers, whatever the outcome.
    ++counters_.broadcasts;
    // FC17 reads too: a broadcast cannot carry its answer, so it is not run.
    if (!request.ok() || is_read_function(request->function) ||
        request->function == fc(Function::read_write_multiple_registers))
      return {};
    std::array<uint8_t, kMaxPduSize> scratch{};
    size_t len = 0;
    for (size_t i = 0; i < count_; ++i) {
      if (!(units_[i].bank->functions() & function_bit(request->function))) continue;
      if (request->without_byte_count && !units_[i].bank->quirks().fc10_without_byte_count) continue;
      (void)execute(*units_[i].bank, *request, scratch, &len);
      units_[i].bank->after_response();
    }
    return {};
  }

  // The function first: a function the bank does not implement is 01 even
  // when its quantity or value is also wrong.
  if (!(bank->functions() & function_bit(pdu[0]))) {
    ++counters_.exceptions;
    return {encode_exception_response(pdu[0], Errc::illegal_function, out), bank};
  }
  if (!request.ok()) {
    if (!request.error().is_exception()) {
      ++counters_.malformed;
      return {0, bank};
    }
    ++counters_.exceptions;
    return {encode_exception_response(pdu[0], request.error().code(), out), bank};
  }
  size_t len = 0;
  const Errc e = execute(*bank, *request, out, &len);
  if (e != Errc::ok) {
    ++counters_.exceptions;
    return {encode_exception_response(pdu[0], e, out), bank};
  }
  ++counters_.responses;
  return {len, bank};
}

SlaveEngine::Handled SlaveEngine::handle_rtu(std::span<const uint8_t> adu, std::span<uint8_t> out) noexcept {
  if (adu.size() < 4 || out.size() < kMaxRtuAduSize) return {};
  Handled h = handle_pdu(UnitId{adu[0]}, adu.subspan(1, adu.size() - 3), out.subspan(1), Framing::rtu);
  if (h.length == 0) return h;
  const size_t n = h.length;
  out[0] = adu[0];
  const uint16_t crc = crc16(out.first(n + 1));
  out[n + 1] = static_cast<uint8_t>(crc & 0xFF);
  out[n + 2] = static_cast<uint8_t>(crc >> 8);
  h.length = n + 3;
  return h;
}

SlaveEngine::Handled SlaveEngine::handle_tcp(std::span<const uint8_t> adu, std::span<uint8_t> out) noexcept {
  if (adu.size() < kMbapHeaderSize + 1 || out.size() < kMaxMbapAduSize) return {};
  Handled h = handle_pdu(UnitId{adu[6]}, mbap_pdu(adu), out.subspan(kMbapHeaderSize), Framing::tcp);
  if (h.length == 0) return h;
  const size_t n = h.length;
  std::memcpy(out.data(), adu.data(), 4);  // transaction and protocol id echoed
  store_be16(&out[4], static_cast<uint16_t>(n + 1));
  out[6] = adu[6];
  h.length = kMbapHeaderSize + n;
  return h;
}

}  // namespace rtukit
