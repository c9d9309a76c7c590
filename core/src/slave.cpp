#include "rtukit/core/slave.hpp"

#include <cstring>

#include "rtukit/core/crc.hpp"
#include "rtukit/core/mbap.hpp"  // kMbapHeaderSize; the functions with RTUKIT_CORE_TCP
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
#if RTUKIT_CORE_COILS
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
#endif
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
#if RTUKIT_CORE_COILS
    case fc(Function::write_single_coil): {
      const uint8_t bit = r.value == 0xFF00 ? 1 : 0;
      const Errc e = bank.write_coils(r.address, 1, {&bit, 1});
      if (e != Errc::ok) return e;
      break;
    }
#endif
    case fc(Function::write_single_register): {
      const uint16_t value = r.value;
      const Errc e = bank.write_holding_registers(r.address, {&value, 1});
      if (e != Errc::ok) return e;
      break;
    }
#if RTUKIT_CORE_COILS
    case fc(Function::write_multiple_coils): {
      const Errc e = bank.write_coils(r.address, r.quantity, r.data);
      if (e != Errc::ok) return e;
      break;
    }
#endif
    case fc(Function::write_multiple_registers): {
      std::array<uint16_t, kMaxWriteRegisters> regs{};
      load_registers(r.data, {regs.data(), r.quantity});
      const Errc e = bank.write_holding_registers(r.address, {regs.data(), r.quantity});
      if (e != Errc::ok) return e;
      break;
    }
#if RTUKIT_CORE_MASK_WRITE
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
#endif
#if RTUKIT_CORE_READ_WRITE
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
#endif
    default:
      return Errc::illegal_function;
  }
  // Write responses echo address and value (single) or quantity (multiple).
  store_be16(&out[1], r.address);
  store_be16(&out[3], (RTUKIT_CORE_COILS && r.function == fc(Function::write_single_coil)) ||
                              r.function == fc(Function::write_single_register)
                          ? r.value
                          : r.quantity);
  *length = 5;
  return Errc::ok;
}

#if RTUKIT_CORE_DIAGNOSTICS
void SlaveEngine::log_event(uint8_t event) noexcept {
  events_[event_head_] = event;
  event_head_ = (event_head_ + 1) % events_.size();
  if (event_len_ < events_.size()) ++event_len_;
}
#endif

void SlaveEngine::note_crc_errors(uint32_t n) noexcept {
  for (uint32_t i = 0; i < n; ++i) {
    ++line_.bus_crc_errors;
    log_event(static_cast<uint8_t>(comm_event::kReceive | comm_event::kReceiveCommError |
                                   (listen_only_ ? comm_event::kListenOnly : 0)));
  }
}

void SlaveEngine::note_overrun() noexcept {
  ++line_.bus_overruns;
  log_event(static_cast<uint8_t>(comm_event::kReceive | comm_event::kReceiveOverrun |
                                 (listen_only_ ? comm_event::kListenOnly : 0)));
}

#if RTUKIT_CORE_DIAGNOSTICS
// FC08. `silent`: the request is done but must not be answered.
Errc SlaveEngine::diagnose(const Request& r, std::span<uint8_t> out, size_t* length, bool* silent) noexcept {
  const auto echo = [&] {
    out[0] = r.function;
    store_be16(&out[1], r.sub_function);
    std::memcpy(&out[3], r.data.data(), r.data.size());
    *length = 3 + r.data.size();
  };
  const auto answer = [&](uint16_t value) {
    out[0] = r.function;
    store_be16(&out[1], r.sub_function);
    store_be16(&out[3], value);
    *length = 5;
  };
  if (r.sub_function != static_cast<uint16_t>(Diagnostic::return_query_data) &&
      r.sub_function != static_cast<uint16_t>(Diagnostic::restart_communications) && r.value != 0) {
    // Every other sub-function we serve takes 0x0000 as its data; but an
    // unknown sub-function is 01 whatever its data.
    const bool known = r.sub_function == 0x02 || r.sub_function == 0x04 ||
                       (r.sub_function >= 0x0A && r.sub_function <= 0x12) || r.sub_function == 0x14;
    return known ? Errc::illegal_data_value : Errc::illegal_function;
  }
  switch (static_cast<Diagnostic>(r.sub_function)) {
    case Diagnostic::return_query_data:
      echo();
      return Errc::ok;
    case Diagnostic::restart_communications: {
      if (r.value != 0x0000 && r.value != 0xFF00) return Errc::illegal_data_value;
      const bool was_listening = listen_only_;
      listen_only_ = false;
      line_ = {};
      diagnostic_register_ = 0;
      event_count_ = 0;
      if (r.value == 0xFF00) event_head_ = event_len_ = 0;  // FF00 also clears the event log
      log_event(comm_event::kRestart);
      if (was_listening)
        *silent = true;  // the specification: no answer when it leaves listen-only mode
      else
        echo();
      return Errc::ok;
    }
    case Diagnostic::return_diagnostic_register:
      answer(diagnostic_register_);
      return Errc::ok;
    case Diagnostic::force_listen_only:
      listen_only_ = true;
      log_event(comm_event::kEnteredListenOnly);
      *silent = true;
      return Errc::ok;
    case Diagnostic::clear_counters:
      line_ = {};
      diagnostic_register_ = 0;
      echo();
      return Errc::ok;
    case Diagnostic::bus_message_count:
      answer(line_.bus_messages);
      return Errc::ok;
    case Diagnostic::bus_communication_error_count:
      answer(line_.bus_crc_errors);
      return Errc::ok;
    case Diagnostic::bus_exception_error_count:
      answer(line_.bus_exceptions);
      return Errc::ok;
    case Diagnostic::server_message_count:
      answer(line_.server_messages);
      return Errc::ok;
    case Diagnostic::server_no_response_count:
      answer(line_.server_no_response);
      return Errc::ok;
    case Diagnostic::server_nak_count:
      answer(line_.server_nak);
      return Errc::ok;
    case Diagnostic::server_busy_count:
      answer(line_.server_busy);
      return Errc::ok;
    case Diagnostic::bus_character_overrun_count:
      answer(line_.bus_overruns);
      return Errc::ok;
    case Diagnostic::clear_overrun_counter:
      line_.bus_overruns = 0;
      echo();
      return Errc::ok;
  }
  return Errc::illegal_function;  // 03 (ASCII delimiter) and anything else
}
#endif

#if RTUKIT_CORE_IDENTIFICATION
// FC11 and FC2B/0E, from the bank's identification objects.
Errc SlaveEngine::identify(RegisterBank& bank, UnitId unit, const Request& r, std::span<uint8_t> out,
                           size_t* length) noexcept {
  if (bank.device_object(0).empty()) return Errc::server_device_failure;  // declared, but no vendor
  if (r.function == fc(Function::report_server_id)) {
    // Byte count, server id (our address), run indicator (on), then
    // "vendor product revision" as the additional data.
    size_t at = 2;
    out[at++] = unit.value;
    out[at++] = 0xFF;
    for (uint8_t id = 0; id <= 2; ++id) {
      const std::string_view v = bank.device_object(id);
      if (id > 0 && at < kMaxPduSize) out[at++] = ' ';
      const size_t n = v.size() < kMaxPduSize - at ? v.size() : kMaxPduSize - at;
      std::memcpy(&out[at], v.data(), n);
      at += n;
    }
    out[0] = r.function;
    out[1] = static_cast<uint8_t>(at - 2);
    *length = at;
    return Errc::ok;
  }
  // Conformity: the highest category the device has objects in; individual
  // access is always supported (0x80).
  uint8_t level = 1;
  for (unsigned id = 0x03; id <= 0xFF && level < 3; ++id)
    if (!bank.device_object(static_cast<uint8_t>(id)).empty()) level = id >= 0x80 ? 3 : 2;
  constexpr size_t kHeader = 7;  // 2B 0E code conformity more-follows next-id count
  out[0] = r.function;
  out[1] = kMeiDeviceIdentification;
  out[2] = r.read_code;
  out[3] = static_cast<uint8_t>(0x80 | level);
  out[4] = 0x00;
  out[5] = 0x00;
  size_t at = kHeader, count = 0;
  const auto put = [&](uint8_t id, std::string_view v) {
    const size_t n = v.size() < kMaxPduSize - kHeader - 2 ? v.size() : kMaxPduSize - kHeader - 2;
    if (at + 2 + n > kMaxPduSize) return false;
    out[at] = id;
    out[at + 1] = static_cast<uint8_t>(n);
    std::memcpy(&out[at + 2], v.data(), n);
    at += 2 + n;
    ++count;
    return true;
  };
  if (r.read_code == static_cast<uint8_t>(DeviceIdAccess::individual)) {
    const std::string_view v = bank.device_object(r.object_id);
    if (v.empty()) return Errc::illegal_data_address;
    put(r.object_id, v);
  } else {
    // A stream: from the object asked for to the top of the category asked
    // for (never above the device's own level); an object it does not have
    // restarts at 0, as the specification says.
    const unsigned asked = r.read_code == 1 ? 0x02 : r.read_code == 2 ? 0x7F : 0xFF;
    const unsigned own = level == 1 ? 0x02 : level == 2 ? 0x7F : 0xFF;
    const unsigned top = asked < own ? asked : own;
    unsigned first = r.object_id;
    if (first > top || bank.device_object(static_cast<uint8_t>(first)).empty()) first = 0;
    for (unsigned id = first; id <= top; ++id) {
      const std::string_view v = bank.device_object(static_cast<uint8_t>(id));
      if (v.empty()) continue;
      if (!put(static_cast<uint8_t>(id), v)) {
        out[4] = 0xFF;  // more follows, from this object
        out[5] = static_cast<uint8_t>(id);
        break;
      }
    }
  }
  out[6] = static_cast<uint8_t>(count);
  *length = at;
  return Errc::ok;
}
#endif

SlaveEngine::Handled SlaveEngine::handle_pdu(UnitId unit, std::span<const uint8_t> pdu,
                                             std::span<uint8_t> out, Framing framing) noexcept {
  if (pdu.empty() || out.size() < kMaxPduSize) return {};
  ++line_.bus_messages;
  const bool broadcast = framing == Framing::rtu && unit == kBroadcast;
  RegisterBank* bank = nullptr;
  UnitId self = unit;
  if (!broadcast) {
    bank = find(unit);
    if (bank == nullptr && framing == Framing::tcp &&
        (any_unit_ || unit == kBroadcast || unit == UnitId{0xFF}) && count_ > 0) {
      bank = units_[0].bank;
      self = UnitId{units_[0].address};
    }
#if !RTUKIT_CORE_IDENTIFICATION
    (void)self;  // only identification answers with its own address
#endif
    if (bank == nullptr) {
      ++counters_.ignored;
      return {};
    }
  }
  ++counters_.requests;
  ++line_.server_messages;
  log_event(static_cast<uint8_t>(comm_event::kReceive | (listen_only_ ? comm_event::kListenOnly : 0) |
                                 (broadcast ? comm_event::kReceiveBroadcast : 0)));
  // Quirks apply on RTU links only; a broadcast is decoded with every hosted unit's.
  const FrameQuirks quirks = framing != Framing::rtu ? FrameQuirks{}
                             : broadcast             ? this->quirks()
                                                     : bank->quirks();
  const Result<Request> request = decode_request(pdu, quirks);

#if RTUKIT_CORE_DIAGNOSTICS
  if (listen_only_) {
    // Watch, never act: only "restart communications" addressed to us ends
    // it (and is not answered either).
    if (!broadcast && request.ok() && request->function == fc(Function::diagnostics) &&
        request->sub_function == static_cast<uint16_t>(Diagnostic::restart_communications) &&
        (bank->functions() & function_bit(Function::diagnostics))) {
      size_t len = 0;
      bool silent = false;
      (void)diagnose(*request, out, &len, &silent);
    }
    ++line_.server_no_response;
    return {0, bank};
  }
#endif

  if (broadcast) {
    // Only writes are executed; nobody answers, whatever the outcome.
    ++counters_.broadcasts;
    ++line_.server_no_response;
    if (!request.ok() || !is_broadcastable(request->function)) return {};
    std::array<uint8_t, kMaxPduSize> scratch{};
    size_t len = 0;
    for (size_t i = 0; i < count_; ++i) {
      if (!(units_[i].bank->functions() & function_bit(request->function))) continue;
      if (request->without_byte_count && !units_[i].bank->quirks().fc10_without_byte_count) continue;
      (void)execute(*units_[i].bank, *request, scratch, &len);
      units_[i].bank->after_response();
    }
#if RTUKIT_CORE_DIAGNOSTICS
    ++event_count_;
#endif
    return {};
  }

  const auto exception = [&](Errc e) -> Handled {
    ++counters_.exceptions;
    ++line_.bus_exceptions;
    if (e == Errc::server_device_busy) ++line_.server_busy;
    const auto code = static_cast<uint8_t>(e);
    // Send event: read exception (01-03), server abort (04), busy (05-06), NAK (07).
    log_event(static_cast<uint8_t>(comm_event::kSend | (code <= 3   ? comm_event::kSendReadException
                                                        : code == 4 ? comm_event::kSendAbortException
                                                        : code <= 6 ? comm_event::kSendBusyException
                                                                    : comm_event::kSendNakException)));
    return {encode_exception_response(pdu[0], e, out), bank};
  };
  // The function first: a function the bank does not implement is 01 even
  // when its quantity or value is also wrong.
  if (!(bank->functions() & function_bit(pdu[0]))) return exception(Errc::illegal_function);
  if (!request.ok()) {
    // Too short for its function's fields. On an RTU link that is a
    // truncated frame, dropped as the serial line drops one. Over Modbus TCP
    // the MBAP length says the PDU is whole, so its length disagrees with its
    // function: 03, as for a PDU too long (before, the client was left
    // waiting for an answer that never came).
    if (!request.error().is_exception() && framing == Framing::tcp)
      return exception(Errc::illegal_data_value);
    if (!request.error().is_exception()) {
      ++counters_.malformed;
      ++line_.server_no_response;
      return {0, bank};
    }
    return exception(request.error().code());
  }
  size_t len = 0;
  bool silent = false;
  Errc e = Errc::ok;
  switch (request->function) {
#if RTUKIT_CORE_DIAGNOSTICS
    case fc(Function::read_exception_status):
      out[0] = request->function;
      out[1] = bank->exception_status();
      len = 2;
      break;
    case fc(Function::diagnostics):
      e = diagnose(*request, out, &len, &silent);
      break;
    case fc(Function::get_comm_event_counter):
      out[0] = request->function;
      store_be16(&out[1], 0x0000);  // status: not busy (we finish each request before the next)
      store_be16(&out[3], event_count_);
      len = 5;
      break;
    case fc(Function::get_comm_event_log): {
      out[0] = request->function;
      out[1] = static_cast<uint8_t>(6 + event_len_);
      store_be16(&out[2], 0x0000);
      store_be16(&out[4], event_count_);
      store_be16(&out[6], line_.bus_messages);
      for (size_t i = 0; i < event_len_; ++i)  // the newest first
        out[8 + i] = events_[(event_head_ + events_.size() - 1 - i) % events_.size()];
      len = 8 + event_len_;
      break;
    }
#endif
#if RTUKIT_CORE_IDENTIFICATION
    case fc(Function::report_server_id):
    case fc(Function::encapsulated_interface):
      e = identify(*bank, self, *request, out, &len);
      break;
#endif
    default:
      e = execute(*bank, *request, out, &len);
      break;
  }
  if (e != Errc::ok) return exception(e);
  if (silent) {
    ++line_.server_no_response;
    return {0, bank};
  }
  ++counters_.responses;
  log_event(comm_event::kSend);  // no exception
#if RTUKIT_CORE_DIAGNOSTICS
  // The comm event counter counts completed requests, not the polls of it.
  if (request->function != fc(Function::get_comm_event_counter) &&
      request->function != fc(Function::get_comm_event_log))
    ++event_count_;
#endif
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

#if RTUKIT_CORE_TCP
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
#endif

}  // namespace rtukit
