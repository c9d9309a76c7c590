// The Rehand 6600's Bluetooth LE service (D-13) as bytes: the UUIDs, the
// state a phone reads and is notified of, the commands it writes and the
// results it is notified of. Pure: no D-Bus, no radio, no clock. The host
// daemon's GATT server (programs/rehand_host) and the reference client
// (`rtukit rehand6600 remote --ble`) both speak through these functions, and
// docs/rehand6600-ble.md documents the same layouts for phone-app developers.
//
// Every layout is little-endian and starts with its version (kVersion); a
// value fits in 20 bytes, the payload of the smallest ATT MTU (23), so a
// phone that never negotiates a larger MTU still gets every field. What a
// command may do is decided by the session (session.hpp), never here: this
// only says what the bytes ask for.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/rehand6600/session.hpp"
#include "rtukit/devices/rehand6600/snapshot.hpp"

namespace rtukit::rehand6600::ble {

/// The layouts' version, the first byte of every value.
inline constexpr uint8_t kVersion = 1;

/// The primary service and its characteristics (128-bit UUIDs, ours).
inline constexpr std::string_view kServiceUuid = "7e6a6600-0001-4b1e-9c3d-52e4a8f0c6a1";
inline constexpr std::string_view kStateUuid = "7e6a6600-0002-4b1e-9c3d-52e4a8f0c6a1";    ///< read, notify
inline constexpr std::string_view kCommandUuid = "7e6a6600-0003-4b1e-9c3d-52e4a8f0c6a1";  ///< write
inline constexpr std::string_view kResultUuid = "7e6a6600-0004-4b1e-9c3d-52e4a8f0c6a1";   ///< notify

/// The largest value of any characteristic: the payload of the smallest ATT MTU.
inline constexpr size_t kMaxValue = 20;

/// What a command asks.
enum class Op : uint8_t {
  press = 1,    ///< start press `press` of a hold function (a new id each time the finger goes down)
  renew = 2,    ///< keep press `press` alive for one more lease (300 ms)
  release = 3,  ///< end press `press` (the finger lifted)
  pulse = 4,    ///< a one-shot function (a turn signal, the light)
};

/// The phone's functions, each one register of table 2 (0x006E..0x0075).
enum class Function : uint8_t {
  forward = 1,       ///< hold: phone_forward
  reverse = 2,       ///< hold: phone_reverse
  left = 3,          ///< hold: phone_left
  right = 4,         ///< hold: phone_right
  horn = 5,          ///< hold: phone_horn
  left_signal = 6,   ///< pulse: phone_left_signal
  right_signal = 7,  ///< pulse: phone_right_signal
  light = 8,         ///< pulse: phone_light (the lighting on or off, as the chair's button)
};

/// The register a function writes (reg::kCommands row), e.g. 0x006E for forward.
uint16_t register_of(Function f) noexcept;
/// True for the hold functions (forward..horn), false for the pulses.
bool is_hold(Function f) noexcept;

/// A command as the phone writes it: 10 bytes.
///   0 version, 1 op, 2 function, 3 value (1 for a press and a pulse; any for renew, release),
///   4..7 press id (u32), 8..9 sequence (u16, echoed in the result).
struct Command {
  Op op = Op::press;
  Function function = Function::forward;
  uint8_t value = 1;
  uint32_t press = 0;
  uint16_t sequence = 0;
};
inline constexpr size_t kCommandSize = 10;

/// The command in `bytes`. Errors: invalid_argument naming what is wrong
/// ("a command is 10 bytes, not 3", "version 2: this chair speaks 1", "op 9",
/// "function 0", "a hold's value is 1, not 2", "a pulse's value is 1, not 5",
/// "a pulse has press id 0").
Outcome<Command> parse_command(std::span<const uint8_t> bytes);
std::array<uint8_t, kCommandSize> encode_command(const Command& c);

/// How a command ended.
enum class ResultCode : uint8_t {
  accepted = 0,  ///< done (a press: the chair moves while renewed)
  refused = 1,   ///< a rule refused it now (the reason says which); nothing changed
  invalid = 2,   ///< malformed, or not a phone's to send; nothing changed
  ended = 3,     ///< a renewal of a press that has ended (lapsed, released, stopped): it never restarts
};

/// A result, notified on the result characteristic after every write:
///   0 version (kResultVersion), 1..2 sequence (u16, the command's), 3 code
///   (ResultCode), 4 why (Reason, reasons.hpp: 0 when accepted; a phone
///   shows its own words for it), 5.. the reason in UTF-8 (empty when
///   accepted), cut to fit `max_size` at a character boundary.
/// Version 1 (before 2026-11-29) had no byte 4: its 16 bytes of text cut
/// most reasons ("not allowed to d").
inline constexpr uint8_t kResultVersion = 2;
struct Result {
  uint16_t sequence = 0;
  ResultCode code = ResultCode::accepted;
  std::string reason;
  Reason why = Reason::none;  ///< encode_result: reason_of(reason) when left none
};
std::vector<uint8_t> encode_result(const Result& r, size_t max_size = kMaxValue);
/// Errors: invalid_argument (shorter than 5 bytes, another version, an unknown code).
Outcome<Result> parse_result(std::span<const uint8_t> bytes);

/// The result of `c` given the session's answer: accepted, invalid
/// (invalid_argument), ended (a renewal refused), refused (any other refusal).
Result result_of(const Command& c, const rtukit::Status& answer);

/// The state a phone reads and is notified of: 18 bytes.
///   0 version
///   1 flags: bit 0 the controller answers (no 1010), 1 charging, 2 clutch
///     in drive, 3 main light, 4 left signal, 5 right signal, 6 a phone
///     drives (holds the driver's seat), 7 a lost phone's emergency stop is
///     in progress
///   2 battery (%), 3 speed (km/h), 4 motion state (table 1's 0x0005)
///   5 stand/sit, 6 seat lift, 7 backrest, 8 seat tilt, 9 leg rest (table 1's
///     0x0012, 0x0010, 0x0011, 0x0013, 0x0014: 0 still, 1 and 2 moving)
///   10..11 the active error (u16: 0 none, 0x1010 no communication, else
///     table 3's code shown on the display)
///   12 disabled: bit 0 everything (an error overlay, an emergency stop),
///     bit 1 phone driving, bit 2 standing up and raising the seat
///   13..14 distance front (mm, u16), 15..16 distance rear (mm, u16)
///   17 a counter that moves with every new reading (wraps at 256)
///   18 why everything is disabled (Reason, reasons.hpp; 0 when not)
///   19 why phone driving is disabled (Reason; 0 when a phone may drive)
/// Bytes 18 and 19 came with 2026-11-29 (the version stays 1: a reader of
/// 18 bytes reads on).
struct StateView {
  Snapshot snapshot;
  uint16_t active_error = 0;
  Disabled disabled;
  bool phone_driving = false;  ///< a phone (over BLE or the web) holds the driver's seat
  bool emergency = false;
};
inline constexpr size_t kStateSize = 20;
std::array<uint8_t, kStateSize> encode_state(const StateView& v);

/// The state as a phone decodes it (the reference client).
struct State {
  bool link = false, charging = false, clutch_drive = false, main_light = false, left_signal = false,
       right_signal = false, driving = false, emergency = false;
  unsigned battery = 0, speed_kmh = 0, motion = 0;
  std::array<uint8_t, 5> postures{};  ///< stand/sit, seat lift, backrest, seat tilt, leg rest
  uint16_t active_error = 0;
  bool all_disabled = false, drive_disabled = false, raise_disabled = false;
  unsigned distance_front_mm = 0, distance_rear_mm = 0;
  uint8_t counter = 0;
  Reason all_reason = Reason::none, drive_reason = Reason::none;  ///< none from an 18-byte state
};
/// Errors: invalid_argument (shorter than 18 bytes, another version).
Outcome<State> parse_state(std::span<const uint8_t> bytes);

}  // namespace rtukit::rehand6600::ble
