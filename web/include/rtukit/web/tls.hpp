// The TLS certificate a listener serves (OpenSSL): a self-signed one made at
// first start, and the two digests people and browsers pin it by.
//
// A self-signed certificate is all a device on its own hotspot can have (no
// name a public CA would sign); the user trusts it by comparing its
// fingerprint with the one the device's own screen shows.
#pragma once

#include <cstddef>
#include <string>

#include "rtukit/base/status.hpp"

namespace rtukit::web {

/// Makes sure `cert_path` and `key_path` hold a certificate and its key:
///  - neither exists: creates an EC P-256 key and a self-signed X.509 v3
///    certificate for it (SHA-256, valid from a day ago (clocks differ) for
///    10 years, a random serial, subject CN and
///    subjectAltName `common_name` (an IP address becomes an IP SAN, anything
///    else a DNS SAN), CA:FALSE, extended key usage serverAuth). Each file is
///    written atomically (a temporary file created exclusively, mode 0600, in
///    the same folder, flushed, renamed; the folder is created if missing)
///    and ends up 0600. The key is written first; if the certificate cannot
///    be written, the key is removed again.
///  - both exist: leaves them as they are, after checking that both are PEM
///    and that the key is the certificate's.
/// Errors: invalid_argument (files to make, and `common_name` is empty or
/// neither an IP address nor a host name), refused (only one of the
/// two exists: the reason names it), malformed (not PEM, or the key does not
/// match the certificate), io_error (a file cannot be read or written; an
/// OpenSSL failure), each with the path in the reason.
rtukit::Status ensure_self_signed(const std::string& cert_path, const std::string& key_path,
                                  const std::string& common_name);

/// The SHA-256 of the certificate's DER encoding as upper-case hex pairs
/// joined by ':' ("AB:CD:...", 32 pairs): what a browser shows as the
/// certificate's SHA-256 fingerprint. Errors: io_error (cannot read),
/// malformed (not a PEM certificate), with the path in the reason.
rtukit::Outcome<std::string> certificate_fingerprint(const std::string& cert_path);

/// The base64 of the SHA-256 of the certificate's DER SubjectPublicKeyInfo:
/// the pin Chromium's `--ignore-certificate-errors-spki-list` takes (and
/// HPKP's pin-sha256). Errors as certificate_fingerprint.
rtukit::Outcome<std::string> spki_sha256_base64(const std::string& cert_path);

/// Fills `out` from the OS random source (getrandom), for secrets: session
/// and phone tokens, salts, pairing codes. False when the OS gives none;
/// there is never a weaker fallback.
bool random_bytes(unsigned char* out, size_t n) noexcept;

}  // namespace rtukit::web
