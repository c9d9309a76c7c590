#include "rtukit/core/master.hpp"

#if RTUKIT_CORE_MASTER
namespace rtukit {

Error MasterTransaction::begin(Framing framing, UnitId unit, const Request& request,
                               uint16_t transaction_id) noexcept {
  framing_ = framing;
  unit_ = unit.value;
  transaction_id_ = transaction_id;
  broadcast_ = framing == Framing::rtu && unit == kBroadcast;
  unanswered_ = RTUKIT_CORE_DIAGNOSTICS && request.function == fc(Function::diagnostics) &&
                request.sub_function == static_cast<uint16_t>(Diagnostic::force_listen_only);
  tx_len_ = 0;
  // Only writes can be broadcast: nothing else runs without its answer.
  if (broadcast_ && !is_broadcastable(request.function)) return Errc::invalid_argument;
  std::array<uint8_t, kMaxPduSize> pdu{};
  const Result<size_t> n = encode_request(request, pdu);
  if (!n.ok()) return n.error();
  const std::span<const uint8_t> pdu_view(pdu.data(), *n);
#if RTUKIT_CORE_TCP
  const Result<size_t> adu = framing == Framing::rtu ? rtu_encode(unit.value, pdu_view, tx_)
                                                     : mbap_encode(transaction_id, unit.value, pdu_view, tx_);
#else
  if (framing != Framing::rtu) return Errc::invalid_argument;  // Modbus TCP is not compiled in
  const Result<size_t> adu = rtu_encode(unit.value, pdu_view, tx_);
#endif
  if (!adu.ok()) return adu.error();
  tx_len_ = *adu;
  request_ = request;
  // FC08: the framer predicts an echo from the data's length.
  if (RTUKIT_CORE_DIAGNOSTICS && request.function == fc(Function::diagnostics))
    request_.quantity = static_cast<uint16_t>(request.data.empty() ? 2 : request.data.size());
  request_.data = {};  // the caller's data need not outlive begin()
  return {};
}

void MasterTransaction::prepare(RtuFramer& framer, bool discard_echo) const noexcept {
  framer.reset();
  framer.expect_response(request_.function, request_.quantity);
  if (discard_echo) framer.expect_echo(request_bytes());
}

std::optional<Result<Response>> MasterTransaction::accept_rtu(const RtuFrame& frame,
                                                              FrameQuirks quirks) const noexcept {
  if (frame.unit() != unit_) return std::nullopt;
  return decode_response(request_, frame.pdu(), quirks);
}

#if RTUKIT_CORE_TCP
std::optional<Result<Response>> MasterTransaction::accept_tcp(std::span<const uint8_t> adu) const noexcept {
  if (adu.size() < kMbapHeaderSize + 1) return Result<Response>(Errc::malformed);
  const MbapHeader h = mbap_header(adu);
  if (h.transaction != transaction_id_) return std::nullopt;
  if (h.unit != unit_) return Result<Response>(Errc::unexpected_response);
  return decode_response(request_, mbap_pdu(adu));
}
#endif


}  // namespace rtukit
#endif  // RTUKIT_CORE_MASTER
