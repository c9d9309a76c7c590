#include "rtukit/driver/master.hpp"

#include <cstring>
#include <thread>

namespace rtukit {

Master::Master(std::unique_ptr<io::Link> link, MasterOptions options)
    : link_(std::move(link)),
      options_(options),
      clock_(options.clock ? *options.clock : static_cast<DriverClock&>(SteadyClock::instance())) {
  framer_.set_timing(link_->timing());
  framer_.set_quirks(options_.quirks);
}

Master::~Master() = default;

Error Master::open() {
  std::lock_guard lock(mutex_);
  if (link_->is_open()) return {};
  Error e = link_->open();
  if (e) {
    ++stats_.io_errors;
  } else {
    ++stats_.reopens;
  }
  return e;
}

MasterStats Master::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

std::string Master::describe() const {
  return link_->describe();
}

Error Master::transact(UnitId unit, const Request& request,
                       const std::function<void(const Response&)>& on_response) {
  std::lock_guard lock(mutex_);
  return transact_locked(unit, request, on_response);
}

Error Master::transact_locked(UnitId unit, const Request& request,
                              const std::function<void(const Response&)>& on_response) {
  Request req = request;
  if (req.function == fc(Function::write_multiple_registers))
    req.without_byte_count = options_.fc10_without_byte_count;

  // At least t3.5 of silence on a serial line after the last frame (the
  // Modbus serial line rule), or the inter-request delay when longer.
  const auto gap = std::max<std::chrono::microseconds>(options_.inter_request_delay, link_->frame_gap());
  if (gap.count() > 0 && last_end_ != Clock::time_point{}) {
    const auto ready = last_end_ + gap;
    if (clock_.now() < ready) clock_.sleep_until(ready);
  }
  struct EndMark {
    Clock::time_point& t;
    DriverClock& clock;
    ~EndMark() { t = clock.now(); }
  } end_mark{last_end_, clock_};

  MasterTransaction tx;
  Error last;
  for (unsigned attempt = 0; attempt <= options_.retries; ++attempt) {
    if (!link_->is_open()) {
      if (Error e = link_->open()) {
        ++stats_.io_errors;
        return e;
      }
      ++stats_.reopens;
    }
    if (Error e = tx.begin(link_->framing(), unit, req, ++transaction_id_)) return e;
    if (attempt > 0) ++stats_.retries;
    link_->discard_input();  // a late answer to an earlier request must not match this one
    const auto deadline = clock_.now() + options_.response_timeout;
    if (options_.trace) {
      const std::string note = attempt > 0 ? "attempt " + std::to_string(attempt + 1) : std::string();
      options_.trace(TraceEvent{TraceEvent::Direction::sent, tx.request_bytes(), note});
    }
    if (Error e = link_->write(tx.request_bytes(), deadline)) {
      ++stats_.io_errors;
      return e;
    }
    ++stats_.requests;
    if (!tx.expects_response()) {
      clock_.sleep_for(options_.turnaround_delay);
      return {};
    }
    const auto sent_at = clock_.now();
    traced_rx_.clear();
    Result<Response> r =
        link_->framing() == Framing::rtu ? receive_rtu(tx, deadline) : receive_tcp(tx, deadline);
    if (options_.trace) trace_received(r, sent_at);
    if (r.ok()) {
      ++stats_.responses;
      if (on_response) on_response(*r);
      return {};
    }
    last = r.error();
    switch (last.code()) {
      case Errc::timeout:
        ++stats_.timeouts;
        drain_late_answer();
        continue;  // retry
      case Errc::io_error:
      case Errc::not_connected:
        ++stats_.io_errors;
        return last;
      case Errc::unexpected_response:
      case Errc::malformed:
        ++stats_.unexpected;
        drain_late_answer();
        return last;
      default:
        if (last.is_exception()) ++stats_.exceptions;
        return last;
    }
  }
  return last;
}

void Master::trace_received(const Result<Response>& r, Clock::time_point sent_at) {
  std::string outcome = "ok";
  if (!r.ok()) {
    const Error e = r.error();
    if (e.is_exception())
      outcome = "exception " + std::string(1, "0123456789ABCDEF"[e.exception_code() >> 4]) +
                "0123456789ABCDEF"[e.exception_code() & 0xF];
    else
      outcome = std::string(e.name());
  }
  options_.trace(TraceEvent{TraceEvent::Direction::received, traced_rx_, outcome,
                            std::chrono::duration_cast<std::chrono::microseconds>(clock_.now() - sent_at)});
}

// After a failed attempt the device may still answer: late (a slow or busy
// device), or again after noise hid part of its answer. An RTU answer names
// no request, so an answer that came after the next request was sent would
// be taken for that request's when it has the same shape: registers of one
// read reported as another's (the fault soak saw it twice in 100 000
// transactions on a loaded machine). So the line must fall quiet first:
// what arrives is dropped until nothing came for the frame gap (20 ms at
// least), for one response timeout at most. libmodbus's error recovery does
// the same (it sleeps for the response timeout, then flushes).
void Master::drain_late_answer() {
  if (link_->framing() != Framing::rtu || !link_->is_open()) return;
  constexpr std::chrono::microseconds kQuietAtLeast{20000};
  const auto quiet = std::max(link_->frame_gap(), kQuietAtLeast);
  const auto until = clock_.now() + options_.response_timeout;
  std::array<uint8_t, 256> chunk{};
  for (;;) {
    const auto now = clock_.now();
    if (now >= until) return;
    const Result<size_t> n =
        link_->read_some(chunk, std::min(until, now + std::chrono::duration_cast<Clock::duration>(quiet)));
    if (!n.ok() || *n == 0) return;  // quiet (or the link failed: the next request reopens it)
    if (options_.trace) traced_rx_.insert(traced_rx_.end(), chunk.data(), chunk.data() + *n);
  }
}

Result<Response> Master::receive_rtu(MasterTransaction& tx, Clock::time_point deadline) {
  tx.prepare(framer_, options_.discard_echo);
  const uint32_t crc_before = framer_.counters().crc_errors;
  std::array<uint8_t, 256> chunk{};
  for (;;) {
    const Result<size_t> n = link_->read_some(chunk, deadline);
    if (!n.ok()) return n.error();
    if (options_.trace) traced_rx_.insert(traced_rx_.end(), chunk.data(), chunk.data() + *n);
    const uint64_t now = static_cast<uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(clock_.now().time_since_epoch()).count());
    if (*n == 0 && clock_.now() >= deadline) {
      stats_.crc_errors += framer_.counters().crc_errors - crc_before;
      return Errc::timeout;
    }
    size_t fed = 0;
    do {
      fed += framer_.feed(std::span<const uint8_t>(chunk.data() + fed, *n - fed), now);
      while (auto frame = framer_.next(now)) {
        if (auto outcome = tx.accept_rtu(*frame, options_.quirks)) {
          stats_.crc_errors += framer_.counters().crc_errors - crc_before;
          return *outcome;
        }
      }
    } while (fed < *n);
  }
}

Result<Response> Master::receive_tcp(MasterTransaction& tx, Clock::time_point deadline) {
  rx_len_ = 0;
  for (;;) {
    // Complete ADUs already buffered first.
    for (;;) {
      const Result<size_t> size = mbap_adu_size({rx_.data(), rx_len_});
      if (!size.ok()) {
        link_->close();  // out of step: a fresh connection is the only cure
        return size.error();
      }
      if (*size == 0 || *size > rx_len_) break;
      const auto outcome = tx.accept_tcp({rx_.data(), *size});
      if (outcome) {
        // The response views rx_; consumed bytes are dropped by the next call.
        return *outcome;
      }
      std::memmove(rx_.data(), rx_.data() + *size, rx_len_ - *size);
      rx_len_ -= *size;
    }
    const Result<size_t> n = link_->read_some({rx_.data() + rx_len_, rx_.size() - rx_len_}, deadline);
    if (!n.ok()) return n.error();
    if (*n == 0) return Errc::timeout;
    if (options_.trace) traced_rx_.insert(traced_rx_.end(), rx_.data() + rx_len_, rx_.data() + rx_len_ + *n);
    rx_len_ += *n;
  }
}

namespace {

Request make_request(Function function, uint16_t address, uint16_t quantity) {
  Request r;
  r.function = fc(function);
  r.address = address;
  r.quantity = quantity;
  return r;
}

}  // namespace

Error Master::read_holding_registers(UnitId unit, uint16_t address, std::span<uint16_t> out) {
  if (out.size() > kMaxReadRegisters) return Errc::invalid_argument;
  return transact(unit,
                  make_request(Function::read_holding_registers, address, static_cast<uint16_t>(out.size())),
                  [&](const Response& r) { load_registers(r.data, out); });
}

Error Master::read_input_registers(UnitId unit, uint16_t address, std::span<uint16_t> out) {
  if (out.size() > kMaxReadRegisters) return Errc::invalid_argument;
  return transact(unit,
                  make_request(Function::read_input_registers, address, static_cast<uint16_t>(out.size())),
                  [&](const Response& r) { load_registers(r.data, out); });
}

Error Master::read_coils(UnitId unit, uint16_t address, std::span<uint8_t> out) {
  if (out.size() > kMaxReadBits) return Errc::invalid_argument;
  return transact(unit, make_request(Function::read_coils, address, static_cast<uint16_t>(out.size())),
                  [&](const Response& r) {
                    for (size_t i = 0; i < out.size(); ++i) out[i] = get_bit(r.data, i) ? 1 : 0;
                  });
}

Error Master::read_discrete_inputs(UnitId unit, uint16_t address, std::span<uint8_t> out) {
  if (out.size() > kMaxReadBits) return Errc::invalid_argument;
  return transact(unit,
                  make_request(Function::read_discrete_inputs, address, static_cast<uint16_t>(out.size())),
                  [&](const Response& r) {
                    for (size_t i = 0; i < out.size(); ++i) out[i] = get_bit(r.data, i) ? 1 : 0;
                  });
}

Error Master::write_single_register(UnitId unit, uint16_t address, uint16_t value) {
  Request r = make_request(Function::write_single_register, address, 1);
  r.value = value;
  return transact(unit, r);
}

Error Master::write_single_coil(UnitId unit, uint16_t address, bool on) {
  Request r = make_request(Function::write_single_coil, address, 1);
  r.value = on ? 0xFF00 : 0x0000;
  return transact(unit, r);
}

Error Master::write_multiple_registers(UnitId unit, uint16_t address, std::span<const uint16_t> values) {
  if (values.empty() || values.size() > kMaxWriteRegisters) return Errc::invalid_argument;
  std::array<uint8_t, 2 * kMaxWriteRegisters> data{};
  for (size_t i = 0; i < values.size(); ++i) store_be16(&data[2 * i], values[i]);
  Request r = make_request(Function::write_multiple_registers, address, static_cast<uint16_t>(values.size()));
  r.data = {data.data(), 2 * values.size()};
  return transact(unit, r);
}

Error Master::write_multiple_coils(UnitId unit, uint16_t address, std::span<const uint8_t> bits) {
  if (bits.empty() || bits.size() > kMaxWriteBits) return Errc::invalid_argument;
  std::array<uint8_t, packed_size(kMaxWriteBits)> data{};
  for (size_t i = 0; i < bits.size(); ++i) set_bit(data, i, bits[i] != 0);
  Request r = make_request(Function::write_multiple_coils, address, static_cast<uint16_t>(bits.size()));
  r.data = {data.data(), packed_size(bits.size())};
  return transact(unit, r);
}

Error Master::mask_write_register(UnitId unit, uint16_t address, uint16_t and_mask, uint16_t or_mask) {
  Request r = make_request(Function::mask_write_register, address, 1);
  r.and_mask = and_mask;
  r.or_mask = or_mask;
  return transact(unit, r);
}

Error Master::read_write_multiple_registers(UnitId unit, uint16_t read_address, std::span<uint16_t> out,
                                            uint16_t write_address, std::span<const uint16_t> values) {
  if (out.empty() || out.size() > kMaxReadRegisters || values.empty() ||
      values.size() > kMaxReadWriteWriteRegisters)
    return Errc::invalid_argument;
  std::array<uint8_t, 2 * kMaxReadWriteWriteRegisters> data{};
  for (size_t i = 0; i < values.size(); ++i) store_be16(&data[2 * i], values[i]);
  Request r =
      make_request(Function::read_write_multiple_registers, read_address, static_cast<uint16_t>(out.size()));
  r.write_address = write_address;
  r.write_quantity = static_cast<uint16_t>(values.size());
  r.data = {data.data(), 2 * values.size()};
  return transact(unit, r, [&](const Response& resp) { load_registers(resp.data, out); });
}

Error Master::read_exception_status(UnitId unit, uint8_t& status) {
  Request r;
  r.function = fc(Function::read_exception_status);
  return transact(unit, r, [&](const Response& resp) { status = resp.body[0]; });
}

Error Master::diagnostics(UnitId unit, Diagnostic sub_function, std::span<const uint8_t> data,
                          std::vector<uint8_t>& answer) {
  Request r;
  r.function = fc(Function::diagnostics);
  r.sub_function = static_cast<uint16_t>(sub_function);
  if (sub_function != Diagnostic::return_query_data && data.size() != 2) return Errc::invalid_argument;
  if (data.size() > kMaxPduSize - 3) return Errc::invalid_argument;
  if (data.size() == 2) r.value = load_be16(data.data());
  r.data = data;
  answer.clear();
  return transact(unit, r,
                  [&](const Response& resp) { answer.assign(resp.body.begin() + 2, resp.body.end()); });
}

Error Master::diagnostic_value(UnitId unit, Diagnostic sub_function, uint16_t& value) {
  const uint8_t zero[2] = {0, 0};
  std::vector<uint8_t> answer;
  if (Error e = diagnostics(unit, sub_function, zero, answer)) return e;
  if (answer.size() != 2) return Errc::unexpected_response;
  value = load_be16(answer.data());
  return {};
}

Error Master::comm_events(UnitId unit, bool log, CommEvents& out) {
  Request r;
  r.function = log ? fc(Function::get_comm_event_log) : fc(Function::get_comm_event_counter);
  return transact(unit, r, [&](const Response& resp) {
    // FC0B: status, count. FC0C: byte count, status, count, messages, events.
    const std::span<const uint8_t> b = log ? resp.body.subspan(1) : resp.body;
    out.status = load_be16(&b[0]);
    out.event_count = load_be16(&b[2]);
    if (log) {
      out.message_count = load_be16(&b[4]);
      out.events.assign(b.begin() + 6, b.end());
    }
  });
}

Error Master::report_server_id(UnitId unit, std::vector<uint8_t>& data) {
  Request r;
  r.function = fc(Function::report_server_id);
  return transact(unit, r,
                  [&](const Response& resp) { data.assign(resp.body.begin() + 1, resp.body.end()); });
}

Error Master::read_device_identification(UnitId unit, DeviceIdAccess access, DeviceIdentification& out,
                                         uint8_t object_id) {
  Request r;
  r.function = fc(Function::encapsulated_interface);
  r.mei_type = kMeiDeviceIdentification;
  r.read_code = static_cast<uint8_t>(access);
  r.object_id = object_id;
  out = {};
  // "More follows": ask again from the next object, at most 256 times (a
  // device whose next id does not move on would loop forever).
  for (int round = 0; round < 256; ++round) {
    bool more = false;
    uint8_t next = 0;
    const Error e = transact(unit, r, [&](const Response& resp) {
      // 0E code conformity more next count, then objects.
      const std::span<const uint8_t> b = resp.body;
      out.conformity = b[2];
      more = b[3] == 0xFF;
      next = b[4];
      size_t at = 6;
      for (unsigned i = 0; i < b[5]; ++i) {
        out.objects[b[at]] = std::string(reinterpret_cast<const char*>(&b[at + 2]), b[at + 1]);
        at += 2 + size_t{b[at + 1]};
      }
    });
    if (e) return e;
    if (!more || access == DeviceIdAccess::individual) return {};
    if (next <= r.object_id && round > 0) return Errc::unexpected_response;
    r.object_id = next;
  }
  return Errc::unexpected_response;
}

}  // namespace rtukit
