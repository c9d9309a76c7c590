// rtukit driver: listen-only Modbus RTU analysis, sans-IO. Bytes seen on a
// line, each with its time, become frames; frames become transactions
// (a request paired with its response, or with none), each with timing
// forensics. `rtukit sniff` prints them in device terms
// (profile/transaction_text.hpp); tests feed it recorded sessions.
//
// Frames are cut at silences of t3.5 (the Modbus serial line rule). A piece
// whose CRC fails is tried glued to the next piece (a frame split by a gap
// longer than t3.5) and split where a valid frame ends inside it (two frames
// glued without the required gap); both are reported. A frame is a response
// when it answers the request before it (same unit, same function or its
// exception), else a request.
//
//   rtukit::Sniffer s({.baud = 9600, .bits_per_char = 10});
//   s.feed(byte, t_us); ... s.flush(t_us);
//   for (const auto& t : s.take()) ...
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace rtukit {

struct SnifferConfig {
  uint32_t baud = 9600;
  uint32_t bits_per_char = 10;
  /// A request with no response after this long is "no response".
  uint32_t response_timeout_us = 1'000'000;
};

struct SniffedFrame {
  std::vector<uint8_t> bytes;  ///< the whole ADU, CRC included
  uint64_t start_us = 0;       ///< first byte's end time (when it was received)
  uint64_t end_us = 0;         ///< last byte's
  bool crc_ok = false;
  bool glued = false;            ///< it followed the previous frame without t3.5 of silence
  bool split = false;            ///< a silence longer than t3.5 cut it in two
  uint32_t max_char_gap_us = 0;  ///< the longest silence between two of its characters
  bool t15_violation = false;    ///< a silence over t1.5 inside the frame
  uint64_t gap_before_us = 0;    ///< silence since the previous frame (0 for the first)

  uint8_t unit() const { return bytes.empty() ? 0 : bytes[0]; }
  uint8_t function() const { return bytes.size() < 2 ? 0 : bytes[1]; }
  /// The PDU (without unit and CRC); empty when too short.
  std::span<const uint8_t> pdu() const {
    return bytes.size() < 4 ? std::span<const uint8_t>()
                            : std::span<const uint8_t>(bytes).subspan(1, bytes.size() - 3);
  }
};

struct SniffedTransaction {
  std::optional<SniffedFrame> request;
  std::optional<SniffedFrame> response;  ///< none: no answer (or a broadcast)
  /// End of the request to the start of the response (the slave's turnaround).
  std::optional<uint64_t> turnaround_us;
  bool broadcast() const { return request && request->unit() == 0; }
  /// A response with no request before it, or garbage (CRC failed).
  bool orphan() const { return !request; }
};

struct SnifferSummary {
  uint64_t transactions = 0;
  uint64_t answered = 0;
  uint64_t exceptions = 0;
  uint64_t no_response = 0;
  uint64_t crc_errors = 0;
  uint64_t glued = 0;
  uint64_t split = 0;
  uint64_t t15_violations = 0;
  uint64_t short_gaps = 0;  ///< frames that followed another with less than t3.5 of silence
  std::vector<uint64_t> turnarounds_us;
  uint64_t busy_us = 0;  ///< line time carrying characters
  uint64_t first_us = 0, last_us = 0;
  /// p-th percentile (0..100) of the turnarounds; 0 when none.
  uint64_t turnaround_percentile(double p) const;
  /// Share of the observed time the line carried characters.
  double utilisation() const;
};

class Sniffer {
 public:
  explicit Sniffer(SnifferConfig config);

  /// A byte received at `t_us` (the end of its character). Times never go back.
  void feed(uint8_t byte, uint64_t t_us);
  /// Time passes with no byte: closes a frame after t3.5 and a transaction
  /// whose response did not come in time. A time before the last byte (a
  /// clock estimated from another process) counts as no silence.
  void flush(uint64_t now_us);
  /// Transactions completed since the last call.
  std::vector<SniffedTransaction> take();
  const SnifferSummary& summary() const noexcept { return summary_; }

  uint32_t t15_us() const noexcept { return t15_us_; }
  uint32_t t35_us() const noexcept { return t35_us_; }

  /// What the timing of `t` broke, in words, request first: "request glued
  /// to the frame before", "response after 1.20 ms of silence (< t3.5 4.01
  /// ms)", "request split by a silence > t3.5", "response gap 2.10 ms inside
  /// (> t1.5 1.72 ms)". Empty when the frames kept the rules.
  std::vector<std::string> forensics(const SniffedTransaction& t) const;

 private:
  struct Piece {
    std::vector<uint8_t> bytes;
    std::vector<uint64_t> times;
  };
  void close_piece();
  void on_frame(SniffedFrame f);
  void finish_pending(std::optional<SniffedFrame> response);
  void count(const SniffedTransaction& t);

  SnifferConfig config_;
  uint32_t char_us_, t15_us_, t35_us_;
  Piece piece_;
  std::optional<Piece> held_;  ///< a piece with a bad CRC, kept to try with the next one
  uint64_t last_frame_end_ = 0;
  bool any_frame_ = false;
  std::optional<SniffedFrame> pending_request_;
  std::vector<SniffedTransaction> done_;
  SnifferSummary summary_;
};

}  // namespace rtukit
