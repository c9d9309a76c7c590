// What a server needs of a key a web page made with WebCrypto: the page
// keeps an ECDSA P-256 private key it cannot export (the browser holds it,
// for that origin only) and proves it holds it by signing a challenge; the
// server keeps only the public key. Used by the Rehand host's phone page
// (docs/rehand6600-remote.md, "How a phone proves it is paired").
//
// The encodings are WebCrypto's own, so the page sends what it gets:
//  - a public key is exportKey("raw"): the uncompressed point, 65 bytes
//    (0x04, x, y);
//  - a signature is sign({name: "ECDSA", hash: "SHA-256"}): IEEE P1363,
//    r and s as 32 big-endian bytes each (not DER).
// Both travel as unpadded base64url text.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace rtukit::web {

/// Unpadded base64url (RFC 4648 section 5) of `bytes`.
std::string base64url(std::string_view bytes);

/// The bytes of unpadded base64url `text`; nullopt when `text` holds a
/// character outside the alphabet, padding, or a length no encoding has.
std::optional<std::string> from_base64url(std::string_view text);

/// Whether `public_key` (raw, 65 bytes) is a point on P-256 that OpenSSL
/// accepts as a public key. Never throws; false for anything malformed.
bool valid_p256_key(std::string_view public_key) noexcept;

/// Whether `signature` (P1363, 64 bytes) is a valid ECDSA P-256 / SHA-256
/// signature of `message` under `public_key` (raw, 65 bytes). False for
/// any malformed input (a wrong length, a point not on the curve, r or s
/// zero or not below the order): never throws, never crashes.
bool verify_p256(std::string_view public_key, std::string_view message, std::string_view signature) noexcept;

}  // namespace rtukit::web
