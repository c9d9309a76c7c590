// rtukit core: RTU framing (address + PDU + CRC) and the receive-side framer.
//
// The framer turns a byte stream into frames, sans-IO: the caller feeds the
// bytes it received together with the time it received them, and asks for
// frames. Time is passed in (microseconds on any monotonic clock), never read.
//
// How a frame is found (Modbus over Serial Line v1.02 section 2.5.1, adapted
// to hosts that lose byte timing, as ../../docs/architecture.md explains):
//  1. Length prediction: from the function code (and quantity / byte count)
//     the framer knows how long a request (slave side) or a response (master
//     side) must be, and checks the CRC at exactly that length.
//  2. Resynchronisation: when the CRC fails, the first byte is dropped and the
//     search starts again one byte later ("sliding"), so garbage before a frame
//     costs nothing but the garbage. When the head of the buffer predicts a
//     frame longer than what has arrived, a complete valid frame ending at the
//     newest byte wins over it (the head was garbage).
//  3. Silence: with timing configured, a gap of t1.5 (if set) or t3.5 between
//     received chunks closes the bytes before it: a frame found there is kept,
//     anything else is dropped as truncated. A frame whose length cannot be
//     predicted (unknown function code) ends at t3.5 of silence, so a slave can
//     still answer it with exception 01.
//  4. Both documented quirks: an FC10 request without its byte count, and an
//     FC03/04 response with a 2-byte byte count, are recognised by length + CRC.
//  5. Echo: on half-duplex adapters that echo what we send, `expect_echo`
//     drops the next bytes if they repeat the frame just sent.
// A frame returned has a valid CRC; nothing else is checked (the unit address
// belongs to the slave engine, the function's semantics to the PDU codec).
//
// Not thread-safe; one framer per receive stream. No heap: 2 x 256-byte buffers.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "rtukit/core/error.hpp"
#include "rtukit/core/pdu.hpp"

namespace rtukit {

/// Wraps `pdu` for unit `unit` into `out` (address + PDU + CRC, low byte first).
/// Errors: buffer_too_small, invalid_argument (PDU empty or over 253 bytes).
Result<size_t> rtu_encode(uint8_t unit, std::span<const uint8_t> pdu, std::span<uint8_t> out) noexcept;

/// Inter-character (t1.5) and inter-frame (t3.5) silences in microseconds.
/// 0 disables the rule (no timing available: prediction and CRC alone).
struct RtuTiming {
  uint32_t t15_us = 0;
  uint32_t t35_us = 0;

  /// The standard values for a serial line: 1.5 and 3.5 character times, where
  /// one character is `bits_per_char` bits (start + data + parity + stop), and
  /// the fixed 750 us / 1750 us above 19200 baud.
  static constexpr RtuTiming for_serial(uint32_t baud, uint32_t bits_per_char = 11) noexcept {
    if (baud == 0) return {};
    if (baud > 19200) return {750, 1750};
    const uint64_t char_us = uint64_t{bits_per_char} * 1000000U / baud;
    return {static_cast<uint32_t>(char_us * 3 / 2), static_cast<uint32_t>(char_us * 7 / 2)};
  }
};

/// What the framer parses: requests (a slave or a sniffer's master side) or
/// responses (a master).
enum class FrameShape : uint8_t { request, response };

/// A complete, CRC-valid frame. Views the framer's buffer: valid until the next
/// call to the framer.
struct RtuFrame {
  std::span<const uint8_t> adu;  ///< address + PDU + CRC
  uint64_t time_us = 0;          ///< receive time of its last chunk

  uint8_t unit() const noexcept { return adu[0]; }
  std::span<const uint8_t> pdu() const noexcept { return adu.subspan(1, adu.size() - 3); }
};

class RtuFramer {
 public:
  static constexpr size_t kBufferSize = 2 * kMaxRtuAduSize;

  struct Counters {
    uint32_t frames = 0;           ///< frames returned
    uint32_t crc_errors = 0;       ///< predicted frames whose CRC failed
    uint32_t discarded_bytes = 0;  ///< garbage, truncated frames, unpredictable leftovers
    uint32_t echoes = 0;           ///< echoes of our own frames dropped
  };

  explicit RtuFramer(FrameShape shape, RtuTiming timing = {}) noexcept : shape_(shape), timing_(timing) {}

  /// Appends `bytes` received at `now_us`. Returns how many were taken: all of
  /// them unless the buffer is full, in which case take frames out with next()
  /// and feed the rest.
  size_t feed(std::span<const uint8_t> bytes, uint64_t now_us) noexcept;

  /// The next complete frame, if any. `now_us` is the current time; with timing
  /// configured, silence since the last chunk closes what is buffered.
  std::optional<RtuFrame> next(uint64_t now_us) noexcept;

  /// When bytes are buffered and timing is configured: the time at which
  /// silence will close them (call next() then). nullopt otherwise.
  std::optional<uint64_t> silence_deadline() const noexcept;

  /// Master side: the response expected next is for `function` and `quantity`.
  /// Which documented frame quirks to recognise (off by default). Kept by reset().
  void set_quirks(FrameQuirks quirks) noexcept { quirks_ = quirks; }
  FrameQuirks quirks() const noexcept { return quirks_; }
  /// Makes the 2-byte-byte-count form of FC03/04 predictable. Cleared by reset().
  void expect_response(uint8_t function, uint16_t quantity) noexcept;

  /// Half-duplex adapters: the next bytes, if they equal `sent`, are our own
  /// echo and are dropped. `sent` is copied (at most 256 bytes).
  void expect_echo(std::span<const uint8_t> sent) noexcept;

  /// Drops everything buffered and any expectation (before a new transaction).
  void reset() noexcept;

  void set_timing(RtuTiming timing) noexcept { timing_ = timing; }
  RtuTiming timing() const noexcept { return timing_; }
  size_t buffered() const noexcept { return tail_ - head_ - pending_; }
  const Counters& counters() const noexcept { return counters_; }

 private:
  // Result of looking at the bytes at the head of the buffer.
  enum class Verdict : uint8_t { frame, need_more, not_a_frame };
  Verdict check_at(size_t pos, size_t avail, size_t* frame_len) const noexcept;
  bool lookahead_resync(size_t avail) noexcept;
  static size_t crc_valid_prefix(const uint8_t* p, size_t max) noexcept;
  void drop(size_t n) noexcept;
  void consume_pending() noexcept;

  FrameShape shape_;
  FrameQuirks quirks_{};
  RtuTiming timing_;
  std::array<uint8_t, kBufferSize> buf_{};
  size_t head_ = 0;
  size_t tail_ = 0;
  size_t pending_ = 0;   // bytes of the frame last returned, consumed on the next call
  size_t boundary_ = 0;  // > head_: bytes before it were closed by silence
  uint64_t last_time_us_ = 0;
  bool have_time_ = false;
  bool sliding_ = false;  // dropping a corrupted frame byte by byte
  uint8_t expected_function_ = 0;
  uint16_t expected_quantity_ = 0;
  std::array<uint8_t, kMaxRtuAduSize> echo_{};
  size_t echo_len_ = 0;
  Counters counters_{};
};

}  // namespace rtukit
