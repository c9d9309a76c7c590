// rtukit Rehand 6600: what a local tool asks of the controller, once: the
// one-shot handshake (is the slave the controller?), and a hold or pulse
// command named by key, its direction and its length, checked against the
// command table before anything is sent. The rules of who may command what
// stay the Session's (session.hpp); this is how a command is named.
#pragma once

#include <chrono>
#include <cstdint>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/verb.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/driver/master.hpp"

namespace rtukit::rehand6600 {

class Host;

/// "device ID 0x42, expected 0x68": what a handshake that reads another ID says.
std::string device_id_mismatch(uint16_t id);

/// The host's handshake once, for a one-shot read: reads the device ID
/// (0x0000) and expects 0x68. Nothing is written (the boot-complete write is
/// the host controller's, host.hpp). Errors:
///  - refused: another device answers ("handshake: device ID 0x42, expected
///    0x68 (not a Rehand 6600 controller?)", "handshake: Modbus exception 02");
///  - io_error, not_connected: the port, as the Master said it;
///  - any other (timeout, CRC): no answer, "handshake: no answer (timeout)".
rtukit::Status handshake(Master& master, UnitId unit);

/// The handshake as every one-shot command words its failure (the device
/// entry's `identify`: `get` and the other common verbs check it first):
/// ok; refused, "1010 Master Error: handshake: device ID 0x42, expected 0x68
/// (not a Rehand 6600 controller?)" with what to check; no answer and I/O
/// errors as handshake() gives them, under "handshake".
rtukit::Status identify(Master& master, UnitId unit);

/// The command of `kind` (Kind::hold or Kind::pulse) named `key`
/// ("seat_lift" or "seat-lift"); invalid_argument naming the commands there
/// are: "'fly' is not a hold command (stand, seat_lift, ...)".
Outcome<const Register*> command_register(std::string_view key, Kind kind);

/// A hold's direction, by the name the command table gives it ("up",
/// "down", "stand", "sit", "forward", "back", "extend", "retract") or its
/// number. A command with two directions must name one; one with a single
/// non-zero value (phone_forward: on) needs none. invalid_argument naming
/// the directions: "hold seat_lift needs a direction: up (1) or down (2)
/// (nothing sent)".
Outcome<uint16_t> command_value(const Register& r, std::string_view text);

/// How long a hold lasts: the duration form every front-end takes ("1m",
/// "1m30s", "1:30", "90s": profile::parse_duration), or "500ms", "1.5"
/// (seconds); more than 0 and at most 10 minutes. invalid_argument:
/// "duration '0s': e.g. 2s, 500ms, 1m (at most 10 minutes)".
Outcome<std::chrono::milliseconds> parse_hold_duration(std::string_view text);

/// A setting to write: drive mode, speed level or the host fault code.
struct SettingChange {
  const Register* row;
  uint16_t raw;
};
/// The setting `what` ("drive-mode", "drive_mode", "speed-level",
/// "host-fault") at `value`, as its row reads it ("outdoor" or 3; 1..5).
/// invalid_argument: "set fly: expected drive-mode, speed-level or
/// host-fault", or the row's refusal ("speed_level: 6 is outside 1..5").
Outcome<SettingChange> parse_setting(std::string_view what, std::string_view value);
/// Writes it through the host controller (Host::set_drive_mode,
/// set_speed_level, set_host_fault), waiting for the write.
rtukit::Status write_setting(Host& host, const SettingChange& c);

/// The verbs that print from the tables, as a command line takes them
/// (profile/verb.hpp): `errors [CODE]`, `stopping`. profile::RunVerb.
const std::vector<profile::Verb>& verb_table();
Outcome<profile::VerbResult> run_verb(const profile::Verb& verb, const profile::VerbArgs& args,
                                      profile::VerbContext& context);

}  // namespace rtukit::rehand6600
