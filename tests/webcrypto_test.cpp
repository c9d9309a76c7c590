// The server's half of a WebCrypto key (web/webcrypto.hpp): base64url both
// ways, and ECDSA P-256 verification of what a page's sign() gives. The
// golden vector was made by a peer we did not write (Python's
// cryptography package, from OpenSSL's own keys): a fixed private scalar,
// the raw public point and an r||s signature of a challenge message.
#include "rtukit/web/webcrypto.hpp"

#include <gtest/gtest.h>

#include <string>

#include "phone_key.hpp"

namespace rtukit::web {
namespace {

constexpr std::string_view kGoldenKey =
    "BL18c7iLLptM7aYgIrLai-Exk6W1btwm5994QuJM0LXrBgWtp72oOsaiuA1-MUBA-kf_Frg7rIXO2wFEUbt85xo";
constexpr std::string_view kGoldenSignature =
    "RxjGd4LyoUHKewPPVdZeP-gT2Jlk7e8uvxvXT2p1bvybwiluOMsx5HFEjAorsv6z1WYNiFe1iJDFQiAfBOWf1w";
constexpr std::string_view kGoldenMessage =
    "rtukit-rehand6600-phone:q2K3xY0vM5w8nJ1cT6rB4uE7zA9dF0gH2iL5oP8sV1U";

std::string decoded(std::string_view text) {
  const std::optional<std::string> bytes = from_base64url(text);
  EXPECT_TRUE(bytes.has_value()) << text;
  return bytes.value_or("");
}

TEST(Base64url, RoundTripsEveryLengthAndRefusesWhatNoEncodingGives) {
  std::string bytes;
  for (int n = 0; n < 70; ++n) {
    EXPECT_EQ(from_base64url(base64url(bytes)), bytes) << n;
    bytes += static_cast<char>(n * 37 + 200);
  }
  EXPECT_EQ(base64url("\xfb\xff"), "-_8");  // the URL alphabet, no padding
  EXPECT_EQ(base64url("Man"), "TWFu");
  EXPECT_FALSE(from_base64url("TWFu=").has_value()) << "padding";
  EXPECT_FALSE(from_base64url("TW+u").has_value()) << "the standard alphabet's +";
  EXPECT_FALSE(from_base64url("TWFuT").has_value()) << "a length no encoding has";
  EXPECT_FALSE(from_base64url("TR").has_value()) << "bits left over that are not zero (one text per bytes)";
  EXPECT_EQ(from_base64url("TQ"), "M");
}

TEST(WebCryptoKey, TheGoldenSignatureVerifies_AnyChangeFails) {
  const std::string key = decoded(kGoldenKey);
  const std::string signature = decoded(kGoldenSignature);
  ASSERT_EQ(key.size(), 65U);
  ASSERT_EQ(signature.size(), 64U);
  EXPECT_TRUE(valid_p256_key(key));
  EXPECT_TRUE(verify_p256(key, kGoldenMessage, signature));

  std::string message(kGoldenMessage);
  message.back() ^= 1;
  EXPECT_FALSE(verify_p256(key, message, signature)) << "another challenge";
  for (size_t at : {0U, 31U, 32U, 63U}) {
    std::string changed = signature;
    changed[at] ^= 0x40;
    EXPECT_FALSE(verify_p256(key, kGoldenMessage, changed)) << "signature byte " << at;
  }
  std::string other_key = key;
  other_key[64] ^= 1;  // off the curve
  EXPECT_FALSE(valid_p256_key(other_key));
  EXPECT_FALSE(verify_p256(other_key, kGoldenMessage, signature));
}

TEST(WebCryptoKey, MalformedKeysAndSignaturesAreRefusedNeverACrash) {
  const std::string key = decoded(kGoldenKey);
  const std::string signature = decoded(kGoldenSignature);
  EXPECT_FALSE(valid_p256_key(""));
  EXPECT_FALSE(valid_p256_key(key.substr(0, 64)));
  EXPECT_FALSE(valid_p256_key(key + '\0'));
  std::string compressed = key;
  compressed[0] = 0x02;
  EXPECT_FALSE(valid_p256_key(compressed)) << "only the raw uncompressed form WebCrypto exports";
  EXPECT_FALSE(valid_p256_key(std::string(65, '\0')));
  EXPECT_FALSE(verify_p256(key, kGoldenMessage, signature.substr(0, 63)));
  EXPECT_FALSE(verify_p256(key, kGoldenMessage, signature + "x"));
  EXPECT_FALSE(verify_p256(key, kGoldenMessage, std::string(64, '\0'))) << "r = s = 0";
  EXPECT_FALSE(verify_p256(key, kGoldenMessage, std::string(64, '\xff'))) << "r, s above the order";
  // A DER signature (what OpenSSL's own sign gives) is not WebCrypto's form.
  EXPECT_FALSE(verify_p256(key, kGoldenMessage, std::string(70, '\x30')));
}

TEST(WebCryptoKey, AKeyMadeNowSignsWhatItsPublicKeyVerifies) {
  const rtukit::testing::PhoneKey phone;
  const rtukit::testing::PhoneKey other;
  const std::string signature = phone.sign("challenge 1");
  EXPECT_TRUE(verify_p256(phone.public_raw(), "challenge 1", signature));
  EXPECT_FALSE(verify_p256(other.public_raw(), "challenge 1", signature)) << "another phone's key";
  EXPECT_FALSE(verify_p256(phone.public_raw(), "challenge 2", signature))
      << "a signature opens one challenge";
}

}  // namespace
}  // namespace rtukit::web
