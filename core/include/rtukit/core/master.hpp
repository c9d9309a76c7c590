// rtukit core: the master's side of one transaction, sans-IO.
//
// A driver (rtukit::Master in the driver layer) owns the transport and the
// clock; this class owns the bytes: it encodes the request (RTU or Modbus TCP),
// tells the driver whether a response is expected, and checks what comes back
// (unit, function, length, CRC, transaction id, echo) until the response is
// complete or proven wrong. Outcomes are values: a Response, a Modbus
// exception, or a local failure. No heap; one object per transaction in flight.
// Compiled in with RTUKIT_CORE_MASTER (config.hpp); Modbus TCP with RTUKIT_CORE_TCP.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "rtukit/core/config.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/core/mbap.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/core/rtu.hpp"

#if RTUKIT_CORE_MASTER
namespace rtukit {

class MasterTransaction {
 public:
  /// Encodes `request` for `unit`. RTU unit 0 is a broadcast: only writes may
  /// be broadcast, and no response is expected. `transaction_id` is used by
  /// Modbus TCP only. With `fc10_without_byte_count` FC10 is sent in the
  /// Inverjet document's short form (for devices that need it; never default).
  /// Errors: invalid_argument (a read broadcast, a request the codec refuses,
  /// Framing::tcp without RTUKIT_CORE_TCP).
  Error begin(Framing framing, UnitId unit, const Request& request, uint16_t transaction_id = 0) noexcept;

  /// The ADU to send. Valid until the next begin().
  std::span<const uint8_t> request_bytes() const noexcept { return {tx_.data(), tx_len_}; }
  /// False for a broadcast and for FC08 "force listen only mode", which the
  /// slave never answers.
  bool expects_response() const noexcept { return !broadcast_ && !unanswered_; }
  const Request& request() const noexcept { return request_; }
  uint8_t unit() const noexcept { return unit_; }

  /// Prepares an RTU framer to receive this transaction's response: clears it
  /// and sets the expected function/quantity (and the echo, when asked to).
  void prepare(RtuFramer& framer, bool discard_echo) const noexcept;

  /// Checks an RTU frame received while waiting. nullopt: the frame is not an
  /// answer to us (another unit's traffic), keep waiting. Otherwise the
  /// outcome: the decoded response (data views the frame), the exception the
  /// slave answered, or unexpected_response. `quirks`: the documented
  /// response forms the device is known to use (off by default).
  std::optional<Result<Response>> accept_rtu(const RtuFrame& frame, FrameQuirks quirks = {}) const noexcept;

  /// Checks a complete MBAP ADU. nullopt: another transaction id (a late
  /// answer to an earlier request that timed out), keep waiting.
#if RTUKIT_CORE_TCP
  std::optional<Result<Response>> accept_tcp(std::span<const uint8_t> adu) const noexcept;
#endif

 private:
  std::array<uint8_t, kMaxMbapAduSize> tx_{};
  size_t tx_len_ = 0;
  Request request_{};
  Framing framing_ = Framing::rtu;
  uint8_t unit_ = 0;
  uint16_t transaction_id_ = 0;
  bool broadcast_ = false;
  bool unanswered_ = false;
};

}  // namespace rtukit
#endif  // RTUKIT_CORE_MASTER
