// ECDSA P-256 verification for keys made by WebCrypto (webcrypto.hpp).
// OpenSSL reads a public key from a SubjectPublicKeyInfo and a signature as
// DER; WebCrypto gives the raw point and r||s. Both conversions are fixed
// and small, so they are done here rather than through OpenSSL's parameter
// builders: the SPKI of an uncompressed P-256 point is a constant prefix and
// the 65 bytes.
#include "rtukit/web/webcrypto.hpp"

#include <openssl/bn.h>
#include <openssl/ec.h>
#include <openssl/ecdsa.h>
#include <openssl/evp.h>
#include <openssl/x509.h>

#include <array>
#include <memory>

namespace rtukit::web {
namespace {

constexpr std::string_view kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
constexpr size_t kPointSize = 65;      // 0x04, x (32), y (32)
constexpr size_t kSignatureSize = 64;  // r (32), s (32)

// DER of SEQUENCE { SEQUENCE { id-ecPublicKey, prime256v1 }, BIT STRING (66 bytes) }, before the point.
constexpr std::array<unsigned char, 26> kSpkiPrefix = {0x30, 0x59, 0x30, 0x13, 0x06, 0x07, 0x2a, 0x86, 0x48,
                                                       0xce, 0x3d, 0x02, 0x01, 0x06, 0x08, 0x2a, 0x86, 0x48,
                                                       0xce, 0x3d, 0x03, 0x01, 0x07, 0x03, 0x42, 0x00};

struct PkeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
using Pkey = std::unique_ptr<EVP_PKEY, PkeyFree>;

Pkey p256_key(std::string_view raw) {
  if (raw.size() != kPointSize || static_cast<unsigned char>(raw[0]) != 0x04) return nullptr;
  std::array<unsigned char, kSpkiPrefix.size() + kPointSize> der{};
  std::copy(kSpkiPrefix.begin(), kSpkiPrefix.end(), der.begin());
  std::copy(raw.begin(), raw.end(), der.begin() + kSpkiPrefix.size());
  const unsigned char* p = der.data();
  // d2i_PUBKEY checks the point is on the curve.
  Pkey key(d2i_PUBKEY(nullptr, &p, static_cast<long>(der.size())));
  if (!key || p != der.data() + der.size()) return nullptr;
  return key;
}

}  // namespace

std::string base64url(std::string_view bytes) {
  std::string out;
  out.reserve((bytes.size() * 4 + 2) / 3);
  uint32_t bits = 0;
  int count = 0;
  for (const char ch : bytes) {
    bits = (bits << 8) | static_cast<unsigned char>(ch);
    count += 8;
    while (count >= 6) {
      count -= 6;
      out += kAlphabet[(bits >> count) & 0x3f];
    }
  }
  if (count > 0) out += kAlphabet[(bits << (6 - count)) & 0x3f];
  return out;
}

std::optional<std::string> from_base64url(std::string_view text) {
  if (text.size() % 4 == 1) return std::nullopt;  // no byte count encodes to that length
  std::string out;
  out.reserve(text.size() * 3 / 4);
  uint32_t bits = 0;
  int count = 0;
  for (const char ch : text) {
    const size_t v = kAlphabet.find(ch);
    if (v == std::string_view::npos) return std::nullopt;
    bits = (bits << 6) | static_cast<uint32_t>(v);
    count += 6;
    if (count >= 8) {
      count -= 8;
      out += static_cast<char>((bits >> count) & 0xff);
    }
  }
  // The bits left over must be zero: one text per byte string.
  if ((bits & ((1u << count) - 1)) != 0) return std::nullopt;
  return out;
}

bool valid_p256_key(std::string_view public_key) noexcept {
  return p256_key(public_key) != nullptr;
}

bool verify_p256(std::string_view public_key, std::string_view message, std::string_view signature) noexcept {
  if (signature.size() != kSignatureSize) return false;
  const Pkey key = p256_key(public_key);
  if (!key) return false;
  // r||s to DER's SEQUENCE { INTEGER r, INTEGER s }.
  ECDSA_SIG* sig = ECDSA_SIG_new();
  if (!sig) return false;
  const auto* sb = reinterpret_cast<const unsigned char*>(signature.data());
  BIGNUM* r = BN_bin2bn(sb, 32, nullptr);
  BIGNUM* s = BN_bin2bn(sb + 32, 32, nullptr);
  if (!r || !s || ECDSA_SIG_set0(sig, r, s) != 1) {
    BN_free(r);
    BN_free(s);
    ECDSA_SIG_free(sig);
    return false;
  }
  unsigned char* der = nullptr;
  const int der_size = i2d_ECDSA_SIG(sig, &der);
  ECDSA_SIG_free(sig);
  if (der_size <= 0) return false;
  bool ok = false;
  if (EVP_MD_CTX* ctx = EVP_MD_CTX_new()) {
    ok = EVP_DigestVerifyInit(ctx, nullptr, EVP_sha256(), nullptr, key.get()) == 1 &&
         EVP_DigestVerify(ctx, der, static_cast<size_t>(der_size),
                          reinterpret_cast<const unsigned char*>(message.data()), message.size()) == 1;
    EVP_MD_CTX_free(ctx);
  }
  OPENSSL_free(der);
  return ok;
}

}  // namespace rtukit::web
