// A phone's key as the phone page makes it with WebCrypto (ECDSA P-256, the
// public key raw, signatures r||s), made here with OpenSSL: for the tests of
// the pairing store and the daemon's phone authentication.
#pragma once

#include <openssl/bn.h>
#include <openssl/core_names.h>
#include <openssl/ecdsa.h>
#include <openssl/evp.h>

#include <array>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rtukit::testing {

class PhoneKey {
 public:
  PhoneKey() : key_(EVP_PKEY_Q_keygen(nullptr, nullptr, "EC", "P-256")) {
    if (!key_) throw std::runtime_error("EVP_PKEY_Q_keygen failed");
  }
  ~PhoneKey() { EVP_PKEY_free(key_); }
  PhoneKey(const PhoneKey&) = delete;
  PhoneKey& operator=(const PhoneKey&) = delete;

  /// The uncompressed point, 65 bytes (WebCrypto's exportKey("raw")).
  std::string public_raw() const {
    std::array<unsigned char, 65> out{};
    size_t n = 0;
    if (EVP_PKEY_get_octet_string_param(key_, OSSL_PKEY_PARAM_PUB_KEY, out.data(), out.size(), &n) != 1 ||
        n != out.size())
      throw std::runtime_error("no public key");
    return {reinterpret_cast<const char*>(out.data()), n};
  }

  /// `message` signed, r||s (WebCrypto's sign()).
  std::string sign(std::string_view message) const {
    EVP_MD_CTX* ctx = EVP_MD_CTX_new();
    std::array<unsigned char, 80> der{};
    size_t n = der.size();
    const bool ok =
        EVP_DigestSignInit(ctx, nullptr, EVP_sha256(), nullptr, key_) == 1 &&
        EVP_DigestSign(ctx, der.data(), &n, reinterpret_cast<const unsigned char*>(message.data()),
                       message.size()) == 1;
    EVP_MD_CTX_free(ctx);
    if (!ok) throw std::runtime_error("EVP_DigestSign failed");
    const unsigned char* p = der.data();
    ECDSA_SIG* sig = d2i_ECDSA_SIG(nullptr, &p, static_cast<long>(n));
    std::array<unsigned char, 64> raw{};
    BN_bn2binpad(ECDSA_SIG_get0_r(sig), raw.data(), 32);
    BN_bn2binpad(ECDSA_SIG_get0_s(sig), raw.data() + 32, 32);
    ECDSA_SIG_free(sig);
    return {reinterpret_cast<const char*>(raw.data()), raw.size()};
  }

 private:
  EVP_PKEY* key_;
};

}  // namespace rtukit::testing
