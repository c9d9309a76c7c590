// The master's response validation (MasterTransaction, sans-IO): a request a
// master can send, then arbitrary answers, received as rtukit::Master
// receives them (RTU: through an RtuFramer prepared by the transaction, in
// chunks; Modbus TCP: ADUs cut with mbap_adu_size).
// Properties: never crashes; an accepted response always answers the request:
// same unit, same function, the quantity asked for (reads: 2 bytes per
// register or one bit each; writes: the echoed address and value or
// quantity; FC16 the echoed address), and its data and body lie inside the
// frame they came from; an exception is exactly fc|0x80 + a non-zero code; a
// frame set aside (nullopt) is another unit's (RTU) or another transaction's
// (TCP); a failure is malformed or unexpected_response (over TCP also an
// answer from another unit), nothing else.
//
// Input: flags, unit, request length n, n bytes of request PDU (kept only if
// decode_request takes it), then answers: RTU, [length, unit, PDU...] each
// with its CRC appended (flag 0x08 flips a CRC bit); TCP, [length,
// transaction, unit, PDU...] each behind an MBAP header (flag 0x08: the raw
// bytes instead, headers and all).
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

#include "fuzz_support.hpp"
#include "rtukit/core.hpp"

namespace {

using namespace rtukit;
using fuzz::within;

constexpr uint16_t kTransaction = 0x0102;

// An outcome of accept_rtu/accept_tcp for a frame whose PDU is `pdu`.
void check_outcome(const MasterTransaction& tx, uint8_t unit, std::span<const uint8_t> pdu,
                   const Result<Response>& outcome) {
  const Request& q = tx.request();
  if (!outcome.ok()) {
    const Error e = outcome.error();
    if (e.is_exception()) {
      if (pdu.size() != 2 || pdu[0] != (q.function | kExceptionBit) || pdu[1] == 0 ||
          e.exception_code() != pdu[1])
        std::abort();
    } else if (e.code() != Errc::malformed && e.code() != Errc::unexpected_response) {
      std::abort();
    }
    return;
  }
  const Response& r = *outcome;
  if (unit != tx.unit()) std::abort();  // another unit's answer taken as ours
  if (r.function != q.function || pdu.empty() || pdu[0] != q.function) std::abort();
  if (!within(r.data, pdu) || !within(r.body, pdu)) std::abort();
  switch (static_cast<Function>(q.function)) {
    case Function::read_coils:
    case Function::read_discrete_inputs:
      if (r.data.size() != packed_size(q.quantity)) std::abort();
      break;
    case Function::read_holding_registers:
    case Function::read_input_registers:
    case Function::read_write_multiple_registers:
      if (r.data.size() != size_t{2} * q.quantity) std::abort();
      break;
    case Function::write_single_coil:
    case Function::write_single_register:
      if (r.address != q.address || r.value != q.value) std::abort();
      break;
    case Function::write_multiple_coils:
    case Function::write_multiple_registers:
      if (r.address != q.address || r.value != q.quantity) std::abort();
      break;
    case Function::mask_write_register:
      if (r.address != q.address) std::abort();
      break;
    default:
      if (r.body.empty()) std::abort();  // FC07, 08, 0B, 0C, 11, 2B: the data after the function
      break;
  }
}

void receive_rtu(const MasterTransaction& tx, bool discard_echo, FrameQuirks quirks,
                 std::span<const uint8_t> stream, std::span<const uint8_t> chunks) {
  RtuFramer framer(FrameShape::response, RtuTiming{});
  tx.prepare(framer, discard_echo);
  uint64_t now = 0;
  size_t at = 0;
  for (size_t k = 0; at < stream.size(); ++k) {
    size_t n = chunks.empty() ? stream.size() : 1 + chunks[k % chunks.size()] % 64;
    if (n > stream.size() - at) n = stream.size() - at;
    size_t fed = 0;
    while (fed < n) {  // as Master::receive_rtu: feed what fits, take every frame
      fed += framer.feed(stream.subspan(at + fed, n - fed), now);
      while (auto frame = framer.next(now)) {
        const std::optional<Result<Response>> outcome = tx.accept_rtu(*frame, quirks);
        if (!outcome) {
          if (frame->unit() == tx.unit()) std::abort();  // our unit's answer ignored
          continue;
        }
        check_outcome(tx, frame->unit(), frame->pdu(), *outcome);
        return;  // the transaction ends at its outcome
      }
    }
    at += n;
    now += 500;
  }
}

void receive_tcp(const MasterTransaction& tx, std::span<const uint8_t> stream) {
  size_t at = 0;
  for (;;) {
    const Result<size_t> size = mbap_adu_size(stream.subspan(at));
    if (!size.ok() || *size == 0 || *size > stream.size() - at) return;  // out of step, or a timeout
    const std::span<const uint8_t> adu = stream.subspan(at, *size);
    const std::optional<Result<Response>> outcome = tx.accept_tcp(adu);
    if (!outcome) {
      if (mbap_header(adu).transaction == kTransaction) std::abort();  // our answer ignored
      at += *size;
      continue;
    }
    check_outcome(tx, mbap_header(adu).unit, mbap_pdu(adu), *outcome);
    return;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 4) return 0;
  const uint8_t flags = data[0];
  const uint8_t unit = data[1];
  const size_t n = data[2];
  if (n == 0 || size < 3 + n) return 0;
  const bool tcp = flags & 0x01;
  const Result<Request> request = decode_request({data + 3, n});
  if (!request.ok()) return 0;
  MasterTransaction tx;
  if (tx.begin(tcp ? Framing::tcp : Framing::rtu, UnitId{unit}, *request, kTransaction)) return 0;
  if (!tx.expects_response()) return 0;

  std::span<const uint8_t> rest(data + 3 + n, size - 3 - n);
  const bool discard_echo = flags & 0x02;
  const FrameQuirks quirks{.fc03_two_byte_count = (flags & 0x04) != 0};
  const bool raw = flags & 0x08;
  // Chunk sizes for the RTU receiver come from the flags' high bits.
  const std::array<uint8_t, 3> chunk_sizes{static_cast<uint8_t>(flags >> 4), static_cast<uint8_t>(flags >> 2),
                                           static_cast<uint8_t>(flags >> 5)};
  std::vector<uint8_t> stream;
  if (discard_echo && !tcp) {
    const auto echo = tx.request_bytes();  // a half-duplex adapter's echo first
    stream.insert(stream.end(), echo.begin(), echo.end());
  }
  if (tcp && raw) {
    stream.assign(rest.begin(), rest.end());
  } else {
    // Answers, each framed as its link frames it (so the fuzzer need not
    // find CRCs or consistent MBAP lengths to reach the decoder).
    while (rest.size() >= 2 + (tcp ? 1 : 0)) {
      const size_t len = rest[0] % (kMaxPduSize + 1);
      const uint16_t transaction = tcp ? (rest[1] & 1 ? kTransaction : rest[1]) : 0;
      const uint8_t to = tcp ? rest[2] : rest[1];
      rest = rest.subspan(tcp ? 3 : 2);
      const std::span<const uint8_t> pdu = rest.first(len < rest.size() ? len : rest.size());
      rest = rest.subspan(pdu.size());
      std::array<uint8_t, kMaxMbapAduSize> adu{};
      const Result<size_t> m = tcp ? mbap_encode(transaction, to, pdu, adu) : rtu_encode(to, pdu, adu);
      if (!m.ok()) continue;
      if (raw && !tcp) adu[*m - 1] ^= 0x01;  // a CRC error: the framer must drop it
      stream.insert(stream.end(), adu.begin(), adu.begin() + static_cast<std::ptrdiff_t>(*m));
    }
  }
  if (tcp) {
    receive_tcp(tx, stream);
  } else {
    receive_rtu(tx, discard_echo, quirks, stream, chunk_sizes);
  }
  return 0;
}
