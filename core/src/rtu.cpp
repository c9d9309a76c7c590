#include "rtukit/core/rtu.hpp"

#include <cstring>

#include "rtukit/core/crc.hpp"

namespace rtukit {

Result<size_t> rtu_encode(uint8_t unit, std::span<const uint8_t> pdu, std::span<uint8_t> out) noexcept {
  if (pdu.empty() || pdu.size() > kMaxPduSize) return Errc::invalid_argument;
  const size_t n = pdu.size() + 3;
  if (out.size() < n) return Errc::buffer_too_small;
  out[0] = unit;
  std::memcpy(&out[1], pdu.data(), pdu.size());
  const uint16_t crc = crc16(out.first(n - 2));
  out[n - 2] = static_cast<uint8_t>(crc & 0xFF);
  out[n - 1] = static_cast<uint8_t>(crc >> 8);
  return n;
}

size_t RtuFramer::feed(std::span<const uint8_t> bytes, uint64_t now_us) noexcept {
  consume_pending();
  if (bytes.empty()) return 0;
  // A gap long enough between chunks closes what was buffered before it.
  const uint32_t gap = timing_.t15_us ? timing_.t15_us : timing_.t35_us;
  if (gap && have_time_ && tail_ > head_ && now_us >= last_time_us_ + gap) boundary_ = tail_;
  if (tail_ + bytes.size() > buf_.size() && head_ > 0) {
    // Compact: move the unparsed bytes to the front.
    std::memmove(buf_.data(), buf_.data() + head_, tail_ - head_);
    tail_ -= head_;
    boundary_ = boundary_ > head_ ? boundary_ - head_ : 0;
    head_ = 0;
  }
  const size_t n = bytes.size() < buf_.size() - tail_ ? bytes.size() : buf_.size() - tail_;
  std::memcpy(buf_.data() + tail_, bytes.data(), n);
  tail_ += n;
  last_time_us_ = now_us;
  have_time_ = true;
  return n;
}

std::optional<uint64_t> RtuFramer::silence_deadline() const noexcept {
  if (!timing_.t35_us || tail_ - head_ - pending_ == 0 || !have_time_) return std::nullopt;
  return last_time_us_ + timing_.t35_us;
}

void RtuFramer::expect_response(uint8_t function, uint16_t quantity) noexcept {
  expected_function_ = function;
  expected_quantity_ = quantity;
}

void RtuFramer::expect_echo(std::span<const uint8_t> sent) noexcept {
  echo_len_ = sent.size() < echo_.size() ? sent.size() : echo_.size();
  std::memcpy(echo_.data(), sent.data(), echo_len_);
}

void RtuFramer::reset() noexcept {
  head_ = tail_ = pending_ = boundary_ = 0;
  sliding_ = false;
  expected_function_ = 0;
  expected_quantity_ = 0;
  echo_len_ = 0;
}

void RtuFramer::consume_pending() noexcept {
  head_ += pending_;
  pending_ = 0;
  if (boundary_ <= head_) boundary_ = 0;
  if (head_ == tail_) head_ = tail_ = 0;
}

void RtuFramer::drop(size_t n) noexcept {
  head_ += n;
  counters_.discarded_bytes += static_cast<uint32_t>(n);
  if (boundary_ <= head_) boundary_ = 0;
  if (head_ == tail_) {
    head_ = tail_ = 0;
    sliding_ = false;  // nothing left: the next byte starts afresh
  }
}

// Length of the shortest prefix of p[0..max) (at least 4 bytes) that ends in
// its own CRC, or 0. One pass: the CRC of each prefix extends the previous one.
size_t RtuFramer::crc_valid_prefix(const uint8_t* p, size_t max) noexcept {
  uint16_t crc = crc16({p, 2});
  for (size_t len = 4; len <= max; ++len) {
    if (p[len - 2] == (crc & 0xFF) && p[len - 1] == (crc >> 8)) return len;
    crc = crc16({p + len - 2, 1}, crc);
  }
  return 0;
}

namespace {

// The frame lengths the bytes at the head of the buffer can have.
struct Candidates {
  size_t len[2] = {0, 0};
  size_t count = 0;  // 0 = length cannot be predicted (yet or at all)
  size_t need = 7;   // bytes it takes to predict (FC0F/10: the byte count is the 7th)
  bool predictable = true;
  // Adds a possible length (kept sorted, no duplicates, 4..kMaxRtuAduSize).
  void add(size_t length) noexcept {
    if (length > kMaxRtuAduSize || length < 4) return;
    for (size_t i = 0; i < count; ++i)
      if (len[i] == length) return;
    len[count++] = length;
    if (count == 2 && len[0] > len[1]) {
      const size_t t = len[0];
      len[0] = len[1];
      len[1] = t;
    }
  }
  // The length is not known from the bytes: silence ends the frame.
  // (Each predictor returns its one `c` by name, so it is built in place:
  // a copy of it, returned as a reference's, cost a store-forwarding stall
  // per frame, 10 ns of 60 on x86.)
  void unpredictable() noexcept { predictable = false; }
};

// What a master's framer knows of the response it waits for.
struct Expected {
  FrameQuirks quirks;
  uint8_t function;
  uint16_t quantity;
};

// The lengths a request at `p` can have, from what is known so far (count
// == 0 with predictable == true: not enough bytes yet to tell). A function
// whose family is compiled out is not supported: it ends at silence, and
// `if constexpr` leaves its case out.
Candidates predict_request(const uint8_t* p, size_t avail, FrameQuirks quirks) noexcept {
  Candidates c;
  if (avail < 2) return c;
  const uint8_t function = p[1];
  if (!is_supported_function(function)) {
    c.unpredictable();
    return c;
  }
  if constexpr (kHasDiagnostics || kHasIdentification) {
    switch (function) {
      case fc(Function::read_exception_status):
      case fc(Function::get_comm_event_counter):
      case fc(Function::get_comm_event_log):
      case fc(Function::report_server_id):
        c.add(4);  // address, function, CRC
        return c;
      case fc(Function::diagnostics):
        // Return query data (sub-function 0) echoes any data: its end is silence.
        c.need = 4;
        if (avail < 4) return c;
        if (load_be16(p + 2) == static_cast<uint16_t>(Diagnostic::return_query_data)) {
          c.unpredictable();
          return c;
        }
        c.add(8);
        return c;
      case fc(Function::encapsulated_interface):
        c.need = 3;
        if (avail < 3) return c;
        if (p[2] != kMeiDeviceIdentification) {  // another MEI type: 01 at silence
          c.unpredictable();
          return c;
        }
        c.add(7);
        return c;
      default:
        break;
    }
  }
  if constexpr (kHasMaskWrite) {
    if (function == fc(Function::mask_write_register)) {
      c.add(10);  // address, function, address, AND mask, OR mask, CRC
      return c;
    }
  }
  if constexpr (kHasReadWrite) {
    if (function == fc(Function::read_write_multiple_registers)) {
      c.need = 11;
      if (avail < 11) return c;
      c.add(13 + size_t{p[10]});  // 9 bytes of fields, the byte count, the data, CRC
      return c;
    }
  }
  if (function != fc(Function::write_multiple_coils) && function != fc(Function::write_multiple_registers)) {
    c.add(8);  // reads and single writes: address, function, 4 bytes, CRC
    return c;
  }
  if (avail < 7) return c;
  c.add(9 + size_t{p[6]});
  // Short form (no byte count), FC10 only: length from the quantity.
  if (function == fc(Function::write_multiple_registers) && quirks.fc10_without_byte_count) {
    const uint16_t q = load_be16(p + 4);
    if (q >= 1 && q <= kMaxWriteRegisters) c.add(8 + 2 * size_t{q});
  }
  return c;
}

// The lengths a response at `p` can have. A response of a function this
// master cannot send (its family compiled out) is someone else's: it ends
// at silence, as an unknown function's (the whole core needs no such check).
[[maybe_unused]] Candidates predict_response(const uint8_t* p, size_t avail, const Expected& e) noexcept {
  Candidates c;
  if (avail < 2) return c;
  const uint8_t function = p[1];
  if (function & kExceptionBit) {
    c.add(5);
    return c;
  }
  if constexpr (!kCoreComplete) {
    if (!is_supported_function(function)) {
      c.unpredictable();
      return c;
    }
  }
  switch (function) {
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs):
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers):
      if (avail < 3) return c;
      c.add(5 + size_t{p[2]});
      if (function >= fc(Function::read_holding_registers) && e.quirks.fc03_two_byte_count) {
        // 2-byte byte count (Rehand 6600 document). With an expectation the
        // length is known; without one, read it from the frame.
        if (e.function == function && e.quantity > 0) {
          c.add(6 + 2 * size_t{e.quantity});
        } else if (avail >= 4 && p[2] == 0) {
          c.add(6 + size_t{load_be16(p + 2)});
        }
      }
      return c;
    case fc(Function::write_single_coil):
    case fc(Function::write_multiple_coils):
    case fc(Function::write_single_register):
    case fc(Function::write_multiple_registers):
      c.add(8);
      return c;
    case fc(Function::mask_write_register):
      c.add(10);  // the request echoed
      return c;
    case fc(Function::read_exception_status):
      c.add(5);
      return c;
    case fc(Function::get_comm_event_counter):
      c.add(8);  // status and event count
      return c;
    case fc(Function::get_comm_event_log):
    case fc(Function::report_server_id):
      if (avail < 3) return c;
      c.add(5 + size_t{p[2]});  // byte count
      return c;
    case fc(Function::diagnostics):
      c.need = 4;
      if (avail < 4) return c;
      if (load_be16(p + 2) != static_cast<uint16_t>(Diagnostic::return_query_data))
        c.add(8);
      else if (e.function == function && e.quantity > 0)
        c.add(6 + size_t{e.quantity});  // the echo of what we sent
      else
        c.unpredictable();
      return c;
    case fc(Function::encapsulated_interface): {
      // No byte count: walk the objects (id, length, value) as they arrive.
      if (avail >= 3 && p[2] != kMeiDeviceIdentification) {
        c.unpredictable();
        return c;
      }
      size_t at = 8;  // address, 2B, 0E, code, conformity, more follows, next id, count
      c.need = at;
      if (avail < at) return c;
      for (unsigned i = 0; i < p[7]; ++i) {
        if (avail < at + 2) {
          c.need = at + 2;
          return c;
        }
        at += 2 + size_t{p[at + 1]};
        if (at + 2 > kMaxRtuAduSize) {
          c.unpredictable();
          return c;
        }
      }
      c.add(at + 2);
      return c;
    }
    case fc(Function::read_write_multiple_registers):
      if (avail < 3) return c;
      c.add(5 + size_t{p[2]});
      return c;
    default:
      c.unpredictable();
      return c;
  }
}

}  // namespace

// Without a master compiled in, responses are framed by silence and CRC only.
static Candidates predict(const uint8_t* p, size_t avail, FrameShape shape, const Expected& e) noexcept {
  if (shape == FrameShape::request) return predict_request(p, avail, e.quirks);
  if constexpr (kHasMaster)
    return predict_response(p, avail, e);
  else {
    Candidates c;
    c.unpredictable();
    return c;
  }
}

// Looks for a frame at buf_[pos], with `avail` bytes available from pos.
RtuFramer::Verdict RtuFramer::check_at(size_t pos, size_t avail, size_t* frame_len) const noexcept {
  const uint8_t* p = buf_.data() + pos;
  const Candidates c = predict(p, avail, shape_, {quirks_, expected_function_, expected_quantity_});
  if (!c.predictable) return Verdict::not_a_frame;
  if (c.count == 0) return avail >= c.need ? Verdict::not_a_frame : Verdict::need_more;
  bool waiting = false;
  for (size_t i = 0; i < c.count; ++i) {
    if (c.len[i] > avail) {
      waiting = true;
      continue;
    }
    if (rtu_crc_ok({p, c.len[i]})) {
      *frame_len = c.len[i];
      return Verdict::frame;
    }
  }
  return waiting ? Verdict::need_more : Verdict::not_a_frame;
}

// The head predicts a frame that has not fully arrived. If a complete valid
// frame ends exactly at the newest byte, the head was garbage: drop up to it.
bool RtuFramer::lookahead_resync(size_t avail) noexcept {
  for (size_t k = 1; k + 4 <= avail; ++k) {
    size_t len = 0;
    if (check_at(head_ + k, avail - k, &len) == Verdict::frame && len == avail - k) {
      drop(k);
      return true;
    }
  }
  return false;
}

std::optional<RtuFrame> RtuFramer::next(uint64_t now_us) noexcept {
  consume_pending();
  if (timing_.t35_us && have_time_ && tail_ > head_ && now_us >= last_time_us_ + timing_.t35_us) {
    boundary_ = tail_;  // silence: everything buffered is closed
  }
  while (tail_ > head_) {
    const bool closed = boundary_ > head_;
    const size_t avail = (closed ? boundary_ : tail_) - head_;

    // Our own echo (half duplex): drop it if the bytes repeat what we sent.
    if (echo_len_) {
      const size_t n = avail < echo_len_ ? avail : echo_len_;
      if (std::memcmp(buf_.data() + head_, echo_.data(), n) != 0) {
        echo_len_ = 0;  // not an echo after all
      } else if (n == echo_len_) {
        head_ += echo_len_;
        if (boundary_ <= head_) boundary_ = 0;
        echo_len_ = 0;
        ++counters_.echoes;
        continue;
      } else if (!closed) {
        return std::nullopt;  // partial echo: wait for the rest
      } else {
        echo_len_ = 0;
      }
    }

    size_t len = 0;
    const Candidates c =
        predict(buf_.data() + head_, avail, shape_, {quirks_, expected_function_, expected_quantity_});
    const Verdict v = check_at(head_, avail, &len);
    if (v == Verdict::frame) {
      sliding_ = false;
      pending_ = len;
      ++counters_.frames;
      return RtuFrame{{buf_.data() + head_, len}, last_time_us_};
    }
    if (!c.predictable) {
      // Unknown function: the frame ends at silence. Until then, a complete
      // known frame ending at the newest byte shows the head was garbage.
      if (closed) {
        if (avail >= 4 && rtu_crc_ok({buf_.data() + head_, avail})) {
          sliding_ = false;
          pending_ = avail;
          ++counters_.frames;
          return RtuFrame{{buf_.data() + head_, avail}, last_time_us_};
        }
        drop(avail);
        continue;
      }
      if (avail >= kMaxRtuAduSize) {
        // More bytes than any frame and still no silence (or no timing at
        // all): waiting longer cannot help. Take the shortest CRC-valid
        // prefix as the frame, else the head is garbage.
        if (const size_t n = crc_valid_prefix(buf_.data() + head_, kMaxRtuAduSize)) {
          sliding_ = false;
          pending_ = n;
          ++counters_.frames;
          return RtuFrame{{buf_.data() + head_, n}, last_time_us_};
        }
        drop(1);
        continue;
      }
      if (lookahead_resync(avail)) continue;
      return std::nullopt;
    }
    // The predicted lengths failed (or are not all here). A frame whose own
    // fields disagree with its length (a write-multiple request whose byte
    // count is not its quantity's) is still a frame when its CRC holds over
    // all its bytes: once silence closes it, take it whole, so that the
    // slave answers 03 as it would over Modbus TCP. A CRC that fails
    // everywhere stays silent. Only where the closed bytes begin: a suffix
    // of a corrupted frame is not tried (each would be a 1-in-65536 chance
    // of taking noise for a frame).
    if (closed && !sliding_ && avail >= 4 && rtu_crc_ok({buf_.data() + head_, avail})) {
      sliding_ = false;
      pending_ = avail;
      ++counters_.frames;
      return RtuFrame{{buf_.data() + head_, avail}, last_time_us_};
    }
    if (v == Verdict::need_more) {
      if (closed) {
        sliding_ = true;
        drop(1);  // truncated at silence: slide, a frame may start later in it
        continue;
      }
      if (lookahead_resync(avail)) continue;
      return std::nullopt;
    }
    if (timing_.t35_us && have_time_ && !closed && avail < kMaxRtuAduSize) {
      // With timing, wait for the silence that ends this frame before giving
      // up on it, unless a whole frame ends at the newest byte (then the
      // head was garbage).
      if (lookahead_resync(avail)) continue;
      return std::nullopt;
    }
    // Not a frame at the head: slide one byte. A run of slides counts as one
    // CRC error (a corrupted frame is dropped byte by byte).
    if (!sliding_) ++counters_.crc_errors;
    sliding_ = true;
    drop(1);
  }
  return std::nullopt;
}

}  // namespace rtukit
