// The PDU codec. Properties: a request that decodes re-encodes to exactly the
// same bytes and decodes to the same fields; decode_response on arbitrary bytes
// never crashes and never returns data past the PDU. Every function rtukit
// implements, diagnostics and identification included (issue 14).
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "rtukit/core.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace rtukit;
  if (size == 0 || size > kMaxPduSize) return 0;
  const std::span<const uint8_t> pdu(data, size);
  const Result<Request> r = decode_request(pdu);
  if (r.ok()) {
    std::array<uint8_t, kMaxPduSize> out{};
    const Result<size_t> n = encode_request(*r, out);
    if (!n.ok() || *n != size || std::memcmp(out.data(), data, size) != 0) std::abort();
    const Result<Request> again = decode_request({out.data(), *n});
    if (!again.ok() || again->address != r->address || again->quantity != r->quantity) std::abort();
  }
  // Interpret the first bytes as a request and the rest as its response.
  if (size >= 6) {
    Request q;
    q.function = data[0];
    q.address = load_be16(data + 1);
    q.quantity = static_cast<uint16_t>(load_be16(data + 3) % 2001);
    q.value = q.quantity;
    // The fields of FC08, FC16, FC17 and FC2B requests, from the same bytes.
    q.sub_function = load_be16(data + 1);
    q.read_code = data[1];
    q.and_mask = load_be16(data + 1);
    q.or_mask = load_be16(data + 3);
    const Result<Response> resp = decode_response(q, pdu.subspan(5));
    if (resp.ok() && !resp->data.empty() &&
        (resp->data.data() < data + 5 || resp->data.data() + resp->data.size() > data + size)) {
      std::abort();
    }
    if (resp.ok() && !resp->body.empty() &&
        (resp->body.data() < data + 5 || resp->body.data() + resp->body.size() > data + size)) {
      std::abort();
    }
  }
  return 0;
}
