// The Rehand 6600 host daemon's WebSocket messages ({"op": ...}, docs/rehand6600.md),
// parsed and checked without the network, the chair or the daemon: what a
// message asks the daemon to do, or why it is refused. HostDaemon runs what
// this returns; everything that depends on the daemon's state (a pairing
// code shown, another phone driving, the chair's answer) stays there.
//
// Contract: a command returned is one `role` may send (a display never
// drives, a phone never holds posture commands or changes settings, a phone
// that has not paired may only pair); its register is one of that command's
// and its value one the register accepts. Never throws, whatever the text.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "rtukit/io/status.hpp"

namespace rtukit::programs {

enum class HostRole { display, phone };

/// What a checked message asks for.
struct HostCommand {
  enum class Kind {
    hold,         ///< display: hold `address` (posture or anti-pinch) at `value` (non-zero), leased
    release,      ///< display: release `address`
    pulse,        ///< pulse `address` (display: the light; phone: light, turn signals)
    set,          ///< display: `value` into `address` (drive_mode or speed_level)
    one_touch,    ///< display: stand (`value` 1) or sit (2) until done; 0 stops it
    pair_start,   ///< display: show a pairing code
    pair_cancel,  ///< display: withdraw the code
    revoke,       ///< display: unpair phone `client`
    pair,         ///< phone: pair with `code`, named `name`
    drive,        ///< phone: drive towards `address` (a phone direction); 0 stops driving
    horn,         ///< phone: the horn on (`value` 1) or off (0)
  };
  Kind kind = Kind::pair_cancel;
  uint16_t address = 0;
  uint16_t value = 0;
  uint64_t client = 0;
  std::string code, name;
};

/// A message as a client sent it.
struct HostMessage {
  /// A JSON object with a string "op". False: answered {"type": "error"}, nothing else.
  bool envelope = false;
  std::string op;
  std::optional<nlohmann::json> id;  ///< "id", echoed in the result
  /// Errors: invalid_argument (a field missing, of the wrong type or value;
  /// an unknown op), refused (a phone that has not paired), with the reason
  /// the client is told.
  rtukit::Outcome<HostCommand> command = HostCommand{};
};

/// Parses and checks `text` from a client of `role`; `paired`: a phone that
/// has paired (a display always may).
HostMessage parse_host_message(std::string_view text, HostRole role, bool paired);

}  // namespace rtukit::programs
