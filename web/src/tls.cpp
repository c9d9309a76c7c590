// The listener's certificate, on OpenSSL 3. EC P-256 because every phone
// browser takes it and it is quick to make on the board at first start;
// files are written through io::write_file_atomically, so a power cut while
// they are written leaves no half-written PEM behind.
#include "rtukit/web/tls.hpp"

#include <arpa/inet.h>
#include <fmt/core.h>
#include <openssl/bio.h>
#include <openssl/bn.h>
#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "rtukit/io/atomic_file.hpp"

namespace rtukit::web {
namespace {

template <class T, auto Free>
struct Deleter {
  void operator()(T* p) const noexcept { Free(p); }
};
using Pkey = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using Cert = std::unique_ptr<X509, Deleter<X509, X509_free>>;
using Bio = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using Ext = std::unique_ptr<X509_EXTENSION, Deleter<X509_EXTENSION, X509_EXTENSION_free>>;
using Bignum = std::unique_ptr<BIGNUM, Deleter<BIGNUM, BN_free>>;

constexpr size_t kMaxPem = 1 << 20;  // a certificate chain is a few KB; a bigger file is not one

// OpenSSL keeps its errors in a per-thread queue: the first one says why,
// and the queue is emptied so the next call starts clean.
std::string openssl_error() {
  const unsigned long e = ERR_get_error();
  ERR_clear_error();
  if (e == 0) return "OpenSSL failed";
  char text[256];
  ERR_error_string_n(e, text, sizeof text);
  return text;
}

bool exists(const std::string& path) {
  struct stat st {};
  return ::lstat(path.c_str(), &st) == 0;  // a dangling symlink is there too: never written through
}

// Never a passphrase prompt on the terminal: an encrypted key is an error.
int no_passphrase(char*, int, int, void*) {
  return 0;
}

Outcome<Cert> load_cert(const std::string& path) {
  Outcome<std::string> text = io::read_regular_file(path, kMaxPem);
  if (!text) return text.error();
  Bio bio(BIO_new_mem_buf(text->data(), static_cast<int>(text->size())));
  if (!bio) return Status(Errc::io_error, fmt::format("{}: {}", path, openssl_error()));
  Cert cert(PEM_read_bio_X509(bio.get(), nullptr, no_passphrase, nullptr));
  if (!cert)
    return Status(Errc::malformed, fmt::format("{}: not a PEM certificate ({})", path, openssl_error()));
  return Outcome<Cert>(std::move(cert));
}

Outcome<Pkey> load_key(const std::string& path) {
  Outcome<std::string> text = io::read_regular_file(path, kMaxPem);
  if (!text) return text.error();
  Bio bio(BIO_new_mem_buf(text->data(), static_cast<int>(text->size())));
  if (!bio) return Status(Errc::io_error, fmt::format("{}: {}", path, openssl_error()));
  Pkey key(PEM_read_bio_PrivateKey(bio.get(), nullptr, no_passphrase, nullptr));
  OPENSSL_cleanse(text->data(), text->size());
  if (!key)
    return Status(Errc::malformed,
                  fmt::format("{}: not an unencrypted PEM private key ({})", path, openssl_error()));
  return Outcome<Pkey>(std::move(key));
}

std::string bio_text(BIO* bio) {
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  return n > 0 ? std::string(data, static_cast<size_t>(n)) : std::string();
}

// What a SAN may hold here: an IP address, or a host name's characters.
// Anything else could smuggle more entries into the extension's text form.
std::optional<std::string> san_of(const std::string& name) {
  unsigned char ip[16];
  if (::inet_pton(AF_INET, name.c_str(), ip) == 1 || ::inet_pton(AF_INET6, name.c_str(), ip) == 1)
    return "IP:" + name;
  if (name.empty() || name.size() > 253) return std::nullopt;
  for (const char c : name)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
          c == '.' || c == '_'))
      return std::nullopt;
  return "DNS:" + name;
}

bool add_extension(X509* cert, int nid, const std::string& value) {
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, cert, cert, nullptr, nullptr, 0);
  Ext ext(X509V3_EXT_conf_nid(nullptr, &ctx, nid, value.c_str()));
  return ext && X509_add_ext(cert, ext.get(), -1) == 1;
}

Outcome<Cert> make_certificate(EVP_PKEY* key, const std::string& common_name, const std::string& san) {
  Cert cert(X509_new());
  if (!cert) return Status(Errc::io_error, openssl_error());
  // A random positive 127-bit serial: two certificates of one name never share one.
  unsigned char serial[16];
  if (RAND_bytes(serial, sizeof serial) != 1) return Status(Errc::io_error, openssl_error());
  serial[0] &= 0x7F;
  Bignum bn(BN_bin2bn(serial, sizeof serial, nullptr));
  X509_NAME* name = X509_get_subject_name(cert.get());
  const bool ok = bn && X509_set_version(cert.get(), 2) == 1 &&  // v3
                  BN_to_ASN1_INTEGER(bn.get(), X509_get_serialNumber(cert.get())) != nullptr &&
                  // A day back: the phone's clock and the board's may differ (the board may have no RTC).
                  X509_gmtime_adj(X509_getm_notBefore(cert.get()), -24L * 3600) != nullptr &&
                  X509_time_adj_ex(X509_getm_notAfter(cert.get()), 10 * 365 + 2, 0, nullptr) != nullptr &&
                  X509_set_pubkey(cert.get(), key) == 1 &&
                  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_UTF8,
                                             reinterpret_cast<const unsigned char*>(common_name.c_str()), -1,
                                             -1, 0) == 1 &&
                  X509_set_issuer_name(cert.get(), name) == 1 &&
                  add_extension(cert.get(), NID_basic_constraints, "critical,CA:FALSE") &&
                  add_extension(cert.get(), NID_subject_alt_name, san) &&
                  add_extension(cert.get(), NID_ext_key_usage, "serverAuth") &&
                  add_extension(cert.get(), NID_subject_key_identifier, "hash") &&
                  X509_sign(cert.get(), key, EVP_sha256()) > 0;
  if (!ok) return Status(Errc::io_error, fmt::format("cannot make the certificate: {}", openssl_error()));
  return Outcome<Cert>(std::move(cert));
}

}  // namespace

Status ensure_self_signed(const std::string& cert_path, const std::string& key_path,
                          const std::string& common_name) {
  const bool have_cert = exists(cert_path), have_key = exists(key_path);
  if (have_cert && have_key) {
    Outcome<Cert> cert = load_cert(cert_path);
    if (!cert) return cert.error();
    Outcome<Pkey> key = load_key(key_path);
    if (!key) return key.error();
    if (X509_check_private_key(cert->get(), key->get()) != 1) {
      ERR_clear_error();
      return Status(Errc::malformed, fmt::format("{} is not the key of {}", key_path, cert_path));
    }
    return {};
  }
  if (have_cert || have_key) {
    // Making the missing half would need the other's key, or orphan the
    // certificate phones already trust: a person must decide.
    const std::string& there = have_cert ? cert_path : key_path;
    const std::string& missing = have_cert ? key_path : cert_path;
    return Status(Errc::refused, fmt::format("{} exists but {} does not: remove {} to make a new pair, "
                                             "or put its other half back",
                                             there, missing, there));
  }
  if (common_name.empty()) return Status(Errc::invalid_argument, "a certificate needs a common name");
  const std::optional<std::string> san = san_of(common_name);
  if (!san)
    return Status(Errc::invalid_argument,
                  fmt::format("'{}': not an IP address or a host name", common_name.substr(0, 64)));

  Pkey key(EVP_EC_gen("P-256"));
  if (!key) return Status(Errc::io_error, fmt::format("cannot make an EC P-256 key: {}", openssl_error()));
  Outcome<Cert> cert = make_certificate(key.get(), common_name, *san);
  if (!cert) return cert.error();

  Bio key_bio(BIO_new(BIO_s_mem())), cert_bio(BIO_new(BIO_s_mem()));
  if (!key_bio || !cert_bio ||
      PEM_write_bio_PrivateKey(key_bio.get(), key.get(), nullptr, nullptr, 0, nullptr, nullptr) != 1 ||
      PEM_write_bio_X509(cert_bio.get(), cert->get()) != 1)
    return Status(Errc::io_error, fmt::format("cannot encode the key and certificate: {}", openssl_error()));
  std::string key_pem = bio_text(key_bio.get());
  const Status wrote_key = io::write_file_atomically(key_path, key_pem, 0600);
  OPENSSL_cleanse(key_pem.data(), key_pem.size());
  if (wrote_key) return wrote_key;
  if (Status e = io::write_file_atomically(cert_path, bio_text(cert_bio.get()), 0600)) {
    ::unlink(key_path.c_str());  // no half pair left behind: the next start makes both again
    return e;
  }
  return {};
}

Outcome<std::string> certificate_fingerprint(const std::string& cert_path) {
  Outcome<Cert> cert = load_cert(cert_path);
  if (!cert) return cert.error();
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (X509_digest(cert->get(), EVP_sha256(), md, &n) != 1)
    return Status(Errc::io_error, fmt::format("{}: {}", cert_path, openssl_error()));
  std::string out;
  for (unsigned int i = 0; i < n; ++i) out += fmt::format("{}{:02X}", i ? ":" : "", md[i]);
  return out;
}

Outcome<std::string> spki_sha256_base64(const std::string& cert_path) {
  Outcome<Cert> cert = load_cert(cert_path);
  if (!cert) return cert.error();
  X509_PUBKEY* spki = X509_get_X509_PUBKEY(cert->get());
  const int len = spki ? i2d_X509_PUBKEY(spki, nullptr) : -1;
  if (len <= 0)
    return Status(Errc::malformed, fmt::format("{}: no public key ({})", cert_path, openssl_error()));
  std::vector<unsigned char> der(static_cast<size_t>(len));
  unsigned char* p = der.data();
  i2d_X509_PUBKEY(spki, &p);
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (EVP_Digest(der.data(), der.size(), md, &n, EVP_sha256(), nullptr) != 1)
    return Status(Errc::io_error, fmt::format("{}: {}", cert_path, openssl_error()));
  unsigned char b64[4 * ((EVP_MAX_MD_SIZE + 2) / 3) + 1];
  const int out = EVP_EncodeBlock(b64, md, static_cast<int>(n));
  return std::string(reinterpret_cast<const char*>(b64), static_cast<size_t>(out));
}

bool random_bytes(unsigned char* out, size_t n) noexcept {
  size_t got = 0;
  while (got < n) {
    const ssize_t r = ::getrandom(out + got, n - got, 0);
    if (r < 0 && errno == EINTR) continue;  // a signal before any byte: ask again
    if (r <= 0) return false;
    got += static_cast<size_t>(r);
  }
  return true;
}

}  // namespace rtukit::web
