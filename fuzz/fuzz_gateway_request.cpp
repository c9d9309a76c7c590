// The gateway's request path: admit_gateway_request, the checks every client
// request passes on arrival (codec, unit allow-list, read-only), with options
// from the input. Properties:
//   - relayed: the request decodes, re-encodes to exactly the client's PDU
//     (what goes on the bus is what the client sent), its unit is allowed,
//     and a read-only gateway relays only what its allow-list names
//     (relays_when_read_only, the one list the gateway itself uses: FC01..04,
//     FC08 sub-functions 00, 02, 0B..12, FC0B, FC0C, FC11, FC2B/0E; pinned
//     entry by entry in tests/gateway_test.cpp, GatewayReadOnly*);
//   - refused: one exception (01, 02, 03, 04, 0A) and only for a reason: 0A
//     only for a unit not allowed (unit 0, the broadcast address, is allowed
//     only without a list and only for 05, 06, 0F, 10, 16), 01 on a read-only gateway only for a
//     request outside the allow-list or a function the codec refuses;
//   - dropped: only an RTU frame (ordered) the codec cannot read, never an
//     MBAP request (the client would wait for ever);
//   - the same input always gives the same decision.
// Input: flags (read_only, ordered, an allow-list or not), the unit, up to 4
// allowed units, then the PDU.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "rtukit/core.hpp"
#include "rtukit/driver/gateway.hpp"

using namespace rtukit;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  GatewayOptions o;
  o.read_only = data[0] & 1;
  const bool ordered = data[0] & 2;
  const unsigned listed = (data[0] >> 2) & 7;  // 0: no allow-list (1..247); 1..4 units
  const uint8_t unit = data[1];
  size_t at = 2;
  for (unsigned i = 0; i < listed && i < 4 && at < size; ++i) o.allowed_units.push_back(data[at++]);
  if (at >= size || size - at > kMaxPduSize) return 0;
  const std::span<const uint8_t> pdu(data + at, size - at);

  const GatewayAdmission a = admit_gateway_request(o, unit, pdu, ordered);
  const GatewayAdmission again = admit_gateway_request(o, unit, pdu, ordered);
  if (a.action != again.action || a.exception != again.exception) std::abort();

  const Result<Request> decoded = decode_request(pdu);
  // Unit 0 (broadcast) only without a list and only for the writes a broadcast carries.
  const bool broadcast = unit == 0 && decoded.ok() && is_broadcastable(decoded->function);
  const bool allowed = o.allowed_units.empty()
                           ? (unit >= 1 && unit <= 247) || broadcast
                           : unit != 0 && std::find(o.allowed_units.begin(), o.allowed_units.end(), unit) !=
                                              o.allowed_units.end();
  using Action = GatewayAdmission::Action;
  switch (a.action) {
    case Action::relay: {
      if (!decoded.ok() || !allowed) std::abort();
      if (o.read_only && !relays_when_read_only(a.request)) std::abort();
      std::array<uint8_t, kMaxPduSize> out{};
      const Result<size_t> n = encode_request(a.request, out);
      if (!n.ok() || *n != pdu.size() || std::memcmp(out.data(), pdu.data(), pdu.size()) != 0) std::abort();
      if (a.request.function != pdu[0]) std::abort();
      break;
    }
    case Action::refuse: {
      const auto code = static_cast<uint16_t>(a.exception);
      if (code != 0x01 && code != 0x02 && code != 0x03 && code != 0x04 && code != 0x0A) std::abort();
      if (a.exception == Errc::gateway_path_unavailable && (allowed || !decoded.ok())) std::abort();
      if (decoded.ok()) {
        // A readable request is refused only for its unit or outside a read-only gateway's allow-list.
        if (allowed && !(o.read_only && !relays_when_read_only(*decoded))) std::abort();
        if (allowed && a.exception != Errc::illegal_function) std::abort();
      }
      break;
    }
    case Action::drop:
      if (!ordered || decoded.ok() || decoded.error().is_exception()) std::abort();
      break;
  }
  return 0;
}
