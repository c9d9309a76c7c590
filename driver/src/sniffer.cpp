#include "rtukit/driver/sniffer.hpp"

#include <algorithm>
#include <cstdio>

#include "rtukit/core/crc.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/core/rtu.hpp"

namespace rtukit {
namespace {

bool crc_ok(std::span<const uint8_t> adu) {
  if (adu.size() < 4) return false;
  const uint16_t crc = crc16(adu.first(adu.size() - 2));
  return adu[adu.size() - 2] == (crc & 0xFF) && adu[adu.size() - 1] == (crc >> 8);
}

// Whether `frame` answers `request` (its response or its exception).
bool answers(const SniffedFrame& request, const SniffedFrame& frame) {
  if (!frame.crc_ok || frame.unit() != request.unit()) return false;
  if ((frame.function() & 0x7F) != request.function()) return false;
  if (frame.function() & 0x80) return true;
  const Result<Request> req = decode_request(request.pdu());
  if (!req.ok()) return true;  // a function we do not decode: same unit and function will do
  const Result<Response> r = decode_response(*req, frame.pdu(), FrameQuirks{.fc03_two_byte_count = true});
  return r.ok() || r.error().is_exception();
}

}  // namespace

uint64_t SnifferSummary::turnaround_percentile(double p) const {
  if (turnarounds_us.empty()) return 0;
  std::vector<uint64_t> sorted = turnarounds_us;
  std::sort(sorted.begin(), sorted.end());
  const auto index = static_cast<size_t>(p / 100.0 * static_cast<double>(sorted.size() - 1) + 0.5);
  return sorted[std::min(index, sorted.size() - 1)];
}

double SnifferSummary::utilisation() const {
  return last_us > first_us ? static_cast<double>(busy_us) / static_cast<double>(last_us - first_us) : 0.0;
}

Sniffer::Sniffer(SnifferConfig config) : config_(config) {
  const uint32_t baud = std::max(1U, config_.baud);
  char_us_ = static_cast<uint32_t>(uint64_t{config_.bits_per_char} * 1'000'000 / baud);
  const RtuTiming t = RtuTiming::for_serial(baud, config_.bits_per_char);
  t15_us_ = t.t15_us;
  t35_us_ = t.t35_us;
}

void Sniffer::feed(uint8_t byte, uint64_t t_us) {
  if (summary_.first_us == 0 && summary_.busy_us == 0)
    summary_.first_us = t_us > char_us_ ? t_us - char_us_ : 0;
  summary_.last_us = t_us;
  summary_.busy_us += char_us_;
  if (!piece_.bytes.empty() && t_us - piece_.times.back() > uint64_t{t35_us_} + char_us_) close_piece();
  piece_.bytes.push_back(byte);
  piece_.times.push_back(t_us);
}

void Sniffer::flush(uint64_t now_us) {
  // A clock a little behind the last byte (a live tap's estimate) is no silence.
  const auto since = [now_us](uint64_t t) { return now_us > t ? now_us - t : 0; };
  if (!piece_.bytes.empty() && since(piece_.times.back()) > uint64_t{t35_us_} + char_us_) close_piece();
  // A piece held for a second half that never came is what it is: garbage.
  if (held_ && piece_.bytes.empty() && since(held_->times.back()) > 10ULL * t35_us_ + char_us_) {
    Piece p = std::move(*held_);
    held_.reset();
    SniffedFrame f;
    f.bytes = p.bytes;
    f.start_us = p.times.front();
    f.end_us = p.times.back();
    on_frame(std::move(f));
  }
  if (pending_request_ && since(pending_request_->end_us) > config_.response_timeout_us)
    finish_pending(std::nullopt);
}

std::vector<SniffedTransaction> Sniffer::take() {
  std::vector<SniffedTransaction> out;
  out.swap(done_);
  return out;
}

void Sniffer::close_piece() {
  Piece p = std::move(piece_);
  piece_ = {};
  bool split = false;
  if (held_) {
    // A frame cut in two by a long silence: the halves make one valid frame.
    Piece joined = *held_;
    joined.bytes.insert(joined.bytes.end(), p.bytes.begin(), p.bytes.end());
    joined.times.insert(joined.times.end(), p.times.begin(), p.times.end());
    if (crc_ok(joined.bytes)) {
      p = std::move(joined);
      split = true;
    } else {
      Piece bad = std::move(*held_);
      SniffedFrame f;
      f.bytes = bad.bytes;
      f.start_us = bad.times.front();
      f.end_us = bad.times.back();
      on_frame(std::move(f));
    }
    held_.reset();
  }
  // Cut the piece into frames: whole if its CRC holds, else at each point
  // where a valid frame ends (frames glued without a silence).
  size_t begin = 0;
  bool glued = false;
  while (begin < p.bytes.size()) {
    const std::span<const uint8_t> rest(p.bytes.data() + begin, p.bytes.size() - begin);
    size_t length = 0;
    if (crc_ok(rest)) {
      length = rest.size();
    } else {
      for (size_t k = 4; k + 4 <= rest.size(); ++k) {
        if (crc_ok(rest.first(k))) {
          length = k;
          break;
        }
      }
    }
    if (length == 0) {
      // No valid frame here: hold it, the next piece may complete it.
      Piece h;
      h.bytes.assign(rest.begin(), rest.end());
      h.times.assign(p.times.begin() + static_cast<std::ptrdiff_t>(begin), p.times.end());
      held_ = std::move(h);
      return;
    }
    SniffedFrame f;
    f.bytes.assign(rest.begin(), rest.begin() + static_cast<std::ptrdiff_t>(length));
    f.start_us = p.times[begin];
    f.end_us = p.times[begin + length - 1];
    f.crc_ok = true;
    f.split = split;
    f.glued = glued;
    for (size_t i = begin + 1; i < begin + length; ++i) {
      const uint64_t silence =
          p.times[i] - p.times[i - 1] > char_us_ ? p.times[i] - p.times[i - 1] - char_us_ : 0;
      f.max_char_gap_us = std::max<uint32_t>(f.max_char_gap_us, static_cast<uint32_t>(silence));
    }
    f.t15_violation = f.max_char_gap_us > t15_us_ && !split;
    on_frame(std::move(f));
    begin += length;
    glued = true;
  }
}

void Sniffer::on_frame(SniffedFrame f) {
  if (any_frame_) {
    const uint64_t start_of_first_char = f.start_us > char_us_ ? f.start_us - char_us_ : 0;
    f.gap_before_us = start_of_first_char > last_frame_end_ ? start_of_first_char - last_frame_end_ : 0;
    if (f.gap_before_us < t35_us_) f.glued = true;
  }
  any_frame_ = true;
  last_frame_end_ = f.end_us;
  if (pending_request_ && answers(*pending_request_, f)) {
    finish_pending(std::move(f));
    return;
  }
  if (pending_request_) {
    // Garbage while a request waits: its damaged answer.
    if (!f.crc_ok) {
      finish_pending(std::move(f));
      return;
    }
    finish_pending(std::nullopt);  // a new request: the old one got nothing
  }
  if (!f.crc_ok) {
    SniffedTransaction t;
    t.response = std::move(f);
    count(t);
    done_.push_back(std::move(t));
    return;
  }
  pending_request_ = std::move(f);
  if (pending_request_->unit() == 0) finish_pending(std::nullopt);  // broadcast: nobody answers
}

void Sniffer::finish_pending(std::optional<SniffedFrame> response) {
  SniffedTransaction t;
  t.request = std::move(pending_request_);
  pending_request_.reset();
  if (response) {
    const uint64_t start_of_response = response->start_us > char_us_ ? response->start_us - char_us_ : 0;
    if (t.request)
      t.turnaround_us = start_of_response > t.request->end_us ? start_of_response - t.request->end_us : 0;
    t.response = std::move(response);
  }
  count(t);
  done_.push_back(std::move(t));
}

void Sniffer::count(const SniffedTransaction& t) {
  ++summary_.transactions;
  for (const auto* f : {t.request ? &*t.request : nullptr, t.response ? &*t.response : nullptr}) {
    if (!f) continue;
    if (!f->crc_ok) ++summary_.crc_errors;
    if (f->glued) ++summary_.short_gaps;
    if (f->glued && f->gap_before_us == 0) ++summary_.glued;
    if (f->split) ++summary_.split;
    if (f->t15_violation) ++summary_.t15_violations;
  }
  if (t.response && t.response->crc_ok && t.request) {
    ++summary_.answered;
    if (t.response->function() & 0x80) ++summary_.exceptions;
  }
  if (t.request && !t.response && !t.broadcast()) ++summary_.no_response;
  if (t.turnaround_us) summary_.turnarounds_us.push_back(*t.turnaround_us);
}

std::vector<std::string> Sniffer::forensics(const SniffedTransaction& t) const {
  std::vector<std::string> out;
  const auto ms = [](uint64_t us) { return static_cast<double>(us) / 1000.0; };
  const auto add = [&](const char* side, const char* format, double a = 0, double b = 0) {
    char text[160];
    const int n = std::snprintf(text, sizeof text, format, a, b);
    out.push_back(std::string(side) + " " + std::string(text, n > 0 ? static_cast<size_t>(n) : 0));
  };
  for (const auto& [frame, side] : {std::pair{&t.request, "request"}, std::pair{&t.response, "response"}}) {
    if (!*frame) continue;
    const SniffedFrame& f = **frame;
    if (f.glued && f.gap_before_us == 0)
      add(side, "glued to the frame before");
    else if (f.glued)
      add(side, "after %.2f ms of silence (< t3.5 %.2f ms)", ms(f.gap_before_us), ms(t35_us_));
    if (f.split) add(side, "split by a silence > t3.5");
    if (f.t15_violation) add(side, "gap %.2f ms inside (> t1.5 %.2f ms)", ms(f.max_char_gap_us), ms(t15_us_));
  }
  return out;
}

}  // namespace rtukit
