// The Rehand 6600 host daemon's WebSocket messages ({"op": ...}, docs/rehand6600.md),
// parsed and checked without the network, the chair or the daemon: what a
// message asks the daemon to do, or why it is refused. HostDaemon runs what
// this returns; everything that depends on the daemon's state (a pairing
// code shown, another phone driving, the chair's answer) stays there.
//
// Contract: a command returned is one `role` may send (a display never
// drives, a phone never holds posture commands or changes settings, a phone
// that has not authenticated may only authenticate or pair); its register is
// one of that command's and its value one the register accepts. Whether the
// chair may do it now is the Session's (rehand6600/session.hpp). Never
// throws, whatever the text.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"

namespace rtukit::programs {

enum class HostRole { display, phone };

/// What a checked message asks for (docs/rehand6600-remote.md).
struct HostCommand {
  enum class Kind {
    press,        ///< start press `press` of hold command `address` at `value` (non-zero)
    renew,        ///< keep press `press` alive
    release,      ///< end press `press` (the finger lifted)
    stop,         ///< display: STOP, an emergency stop (0x006A) latched until lift_stop
    lift_stop,    ///< display: lift STOP (0x006A released once the chair is still)
    pulse,        ///< pulse `address` (display: the light; phone: light, turn signals)
    set,          ///< display: `value` into `address` (drive_mode or speed_level)
    pair_start,   ///< display: show a pairing code
    pair_cancel,  ///< display: withdraw the code
    forget,       ///< display: unpair phone `phone`
    forget_all,   ///< display: unpair every phone
    confirm,      ///< display: allow phone `phone` to drive (R-18)
    auth,         ///< phone: phone `phone` proves it is paired: `signature` of this connection's challenge
    pair,         ///< phone: pair with `code`, named `name`, with `public_key`; `signature` of the challenge
  };
  Kind kind = Kind::pair_cancel;
  uint16_t address = 0;
  uint16_t value = 0;
  uint64_t press = 0;
  std::string code, name, phone;
  std::string public_key;  ///< raw P-256 point (bytes, decoded), a checked point on the curve
  std::string signature;   ///< P1363 bytes (decoded), 64 of them
};

/// A phone's name as the display shows it and the log writes it, from what a
/// phone chose (a web pairing's "name", a Bluetooth device's Alias: anyone in
/// radio range picks those bytes). Invalid UTF-8 becomes U+FFFD; control
/// characters (C0, DEL, C1), bidirectional controls (U+061C, U+200E/F,
/// U+202A..U+202E, U+2066..U+2069), zero-width spaces and line separators
/// are dropped, so a name can neither forge a log line nor reorder the text
/// around it; runs of spaces become one; at most 40 characters; an empty
/// result is `fallback`. Never throws.
std::string phone_name(std::string_view raw, std::string_view fallback = "Phone");

/// A message as a client sent it.
struct HostMessage {
  /// A JSON object with a string "op". False: answered {"type": "error"}, nothing else.
  bool envelope = false;
  std::string op;
  std::optional<nlohmann::json> id;  ///< "id", echoed in the result
  /// Errors: invalid_argument (a field missing, of the wrong type or value;
  /// an unknown op), refused (a phone that has not authenticated), with the
  /// reason the client is told.
  rtukit::Outcome<HostCommand> command = HostCommand{};
};

/// Parses and checks `text` from a client of `role`; `authenticated`: a
/// phone that has authenticated or paired on this connection (a display
/// always is). An unauthenticated phone may only send auth or pair.
HostMessage parse_host_message(std::string_view text, HostRole role, bool authenticated);

}  // namespace rtukit::programs
