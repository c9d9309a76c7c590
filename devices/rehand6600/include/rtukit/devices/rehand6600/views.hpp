// rtukit Rehand 6600: table 1 as people read it, once, for every text
// front-end (`rtukit rehand6600 status`, `watch`, `hold`, `pulse`). Plain
// text and JSON: the caller decides how an error is highlighted
// (`Highlight`) and what goes around a line, so nothing here knows a terminal.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/devices/rehand6600/snapshot.hpp"

namespace rtukit::rehand6600 {

/// How a front-end marks what needs attention (an active error); nullptr: as it is.
using Highlight = std::function<std::string(std::string_view)>;

/// A status register by key, as its row names the value ("drive", "on"), or
/// its formatted value when the row has no name for it.
std::string value_text(const Snapshot& s, std::string_view key);
/// "6 km/h", or "3.7 mph" when `mph`.
std::string speed_text(const Snapshot& s, bool mph);
/// `text` in lines of at most 80 columns, each after `head` (the first) or
/// as many spaces (the rest), each ending in '\n': the panel's "advice" rows.
std::string wrapped(std::string_view head, std::string_view text);
/// The six actuator positions (per mille), space-separated.
std::string actuators(const Snapshot& s);
/// The status panel: lines of at most 80 columns, each ending in '\n'; an
/// active error's banner and name go through `alert`.
std::string panel(const Snapshot& s, bool mph, const Highlight& alert = nullptr);
/// The status in one line ("battery 80% | ... | error none").
std::string line(const Snapshot& s, bool mph);
/// Table 1 in rtukit's JSON shape (docs/json.md), the "values" of `status
/// --json`: each status register an entry, plus "speed_mph" (when `mph`),
/// "error_text" and "error_advice".
nlohmann::ordered_json snapshot_values(const Snapshot& s, bool mph);

/// The host's state document's pieces, for the display and the phones
/// (docs/rehand6600.md, "The host daemon"): the device's facts, once.
///
/// Table 1's status registers by key as plain numbers, a signed row (the
/// joystick) as its signed value; reserved rows left out.
nlohmann::ordered_json status_numbers(const Snapshot& s);
/// The postures, one object per row of kPostures (motion.hpp): "key",
/// "status" (its status register's name for the value, "still" when the
/// register shows none of this posture's values), "held" (the name of the
/// value a client holds on its command, "" for none), "moving" (its status
/// register says so, or its command is held and an actuator it drives
/// moves: holding seat lift moves actuator 1, which stand/sit shares, and
/// only seat lift moves), "badge" and "badge_kind" (the one word a screen
/// shows: "over-current" when an actuator reports it; else, while moving,
/// the status's name or "moving" (kind "moving"); else an actuator's
/// "upper limit"/"lower limit" (kind "limit"); else "still") and
/// "actuators": each actuator it drives, {"n",
/// "state" (its row's name), "position" (per mille)}. `held(command)`: the
/// value held on that command, 0 for none.
nlohmann::ordered_json postures_view(const Snapshot& s, const std::function<uint16_t(uint16_t)>& held);
/// Stand/sit's progress, 0..100 %: the mean position of the actuators it drives.
int stand_progress(const Snapshot& s);
/// The four ultrasonic distances in mm: {"front", "rear", "left", "right"}.
nlohmann::ordered_json distances_view(const Snapshot& s);

/// Who the host's clients are, as the state document names them; the
/// daemon knows its connections, the device layer does not.
struct ClientNames {
  /// Who holds a press: a phone's name, or "display".
  std::function<std::string(Session::ClientId)> owner;
  /// The phone id of the client in the driver's seat ("" when none is known).
  std::function<std::string(Session::ClientId)> phone;
};

/// The chair's part of the host daemon's state document (docs/rehand6600.md,
/// "The host daemon"), from one HostState: "connected" (linked and a poll
/// read), "error", "error_text", "error_advice" (table 3's advice, "" when
/// no error), "values" (status_numbers), "text" (each status register as
/// its row formats it), "drive_mode" (its row's name), "speed_level",
/// "postures", "stand_progress", "distances", "near_obstacle",
/// "emergency", "stop", "presses" ([{"command" key, "value", "owner"}]),
/// "disabled" ({"all", "drive", "raise"}: why, "" when allowed) and
/// "driver" (names.phone of the driver, "" for none). The caller adds its
/// own fields (the type, the pairing code, the phones).
nlohmann::ordered_json state_view(const HostState& s, const ClientNames& names);

/// One table-3 error code as JSON: {"code": "10C3", "function", "text",
/// "advice"} (`rtukit rehand6600 errors --json`).
nlohmann::ordered_json error_json(uint16_t code);

/// Why the host cannot talk to the controller, as the chair's own error says
/// it, and what to check: "1010 Master Error: handshake: no answer (timeout);
/// check that the controller is powered on, the UART cable and its
/// connectors, --baud (115200 unless changed) and --unit (1)"; when another
/// device answers (`another_device`): "1010 Master Error: REASON; check
/// --port and --unit: another device answers there".
std::string link_failure_text(std::string_view reason, bool another_device);

}  // namespace rtukit::rehand6600
