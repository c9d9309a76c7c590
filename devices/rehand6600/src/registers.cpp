// The Rehand 6600 tables (spec rehand6600.md). Everything else reads these.
#include "rtukit/devices/rehand6600/registers.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <vector>

namespace rtukit::rehand6600 {
namespace {

constexpr Choice kOffOn[] = {{0, "off"}, {1, "on"}};
constexpr Choice kNoYes[] = {{0, "no"}, {1, "yes"}};
constexpr Choice kClutch[] = {{0, "push"}, {1, "drive"}};
constexpr Choice kMotion[] = {{1, "static"},        {2, "forward"},      {3, "reverse"},
                              {4, "spin left"},     {5, "spin right"},   {6, "forward-left"},
                              {7, "forward-right"}, {8, "reverse-left"}, {9, "reverse-right"}};
constexpr Choice kLift[] = {{0, "still"}, {1, "rising"}, {2, "lowering"}};
constexpr Choice kBack[] = {{0, "still"}, {1, "tilting forward"}, {2, "tilting back"}};
constexpr Choice kStand[] = {{0, "still"}, {1, "standing up"}, {2, "sitting down"}};
constexpr Choice kTilt[] = {{0, "still"}, {1, "forward"}, {2, "back"}};
constexpr Choice kLegs[] = {
    {0, "still"}, {1, "rotating up"}, {2, "rotating down"}, {3, "extending/retracting"}};
constexpr Choice kActuator[] = {
    {0, "still"}, {1, "moving"}, {2, "upper limit"}, {3, "lower limit"}, {4, "over-current"}};
constexpr Choice kMotor[] = {{0, "still"}, {1, "running"}, {4, "over-current"}};
constexpr Choice kDriveModes[] = {{1, "normal"}, {2, "indoor"}, {3, "outdoor"}};
constexpr Choice kStandCmd[] = {{0, "off"}, {1, "stand"}, {2, "sit"}};
constexpr Choice kUpDown[] = {{0, "off"}, {1, "up"}, {2, "down"}};
constexpr Choice kFwdBack[] = {{0, "off"}, {1, "forward"}, {2, "back"}};
constexpr Choice kOutIn[] = {{0, "off"}, {1, "extend"}, {2, "retract"}};
constexpr Choice kPhoneLightValues[] = {{0, "off"}, {1, "on"}, {2, "on"}};  // D-4: the seed prints 2

constexpr Register status(uint16_t a, std::string_view key, std::string_view title,
                          std::string_view unit = {}, std::span<const Choice> choices = {},
                          std::string_view notes = {}, bool is_signed = false, uint16_t max = 0xFFFF) {
  return Register{Table::status, a, key, title, Kind::status, unit, is_signed, 0, max, choices, 0, notes};
}
constexpr Register command(uint16_t a, std::string_view key, std::string_view title, Kind kind,
                           std::span<const Choice> choices, uint16_t default_value, bool motion,
                           std::string_view notes = {}, uint16_t min = 0, uint16_t max = 0xFFFF,
                           bool is_signed = false) {
  return Register{Table::command, a,     key,   title, kind, {}, is_signed, min, max, choices,
                  default_value,  notes, motion};
}

constexpr std::array kRegisters = {
    status(0x0000, "device_id", "device ID", {}, {}, "always 0x68; the host's handshake reads it first"),
    status(0x0001, "battery", "battery", "%", {}, {}, false, 100),
    status(0x0002, "charging", "charging", {}, kNoYes, "no driving while charging"),
    status(0x0003, "speed", "speed", "km/h"),
    status(0x0004, "clutch", "clutch", {}, kClutch, "push: free-wheel, the chair can be pushed by hand"),
    status(0x0005, "motion", "motion state", {}, kMotion),
    status(0x0006, "distance_front", "ultrasonic distance front", "mm"),
    status(0x0007, "distance_rear", "ultrasonic distance rear", "mm"),
    status(0x0008, "distance_left", "ultrasonic distance left", "mm"),
    status(0x0009, "distance_right", "ultrasonic distance right", "mm"),
    status(0x000A, "joystick_x", "joystick X", {}, {}, "reserved", true),
    status(0x000B, "joystick_y", "joystick Y", {}, {}, "reserved", true),
    status(0x000C, "joystick_z", "joystick Z", {}, {}, "reserved", true),
    status(0x000D, "main_light", "main light", {}, kOffOn),
    status(0x000E, "left_signal", "left turn signal", {}, kOffOn),
    status(0x000F, "right_signal", "right turn signal", {}, kOffOn),
    status(0x0010, "seat_lift_status", "seat lift", {}, kLift),
    status(0x0011, "backrest_status", "backrest", {}, kBack),
    status(0x0012, "stand_status", "stand/sit", {}, kStand),
    status(0x0013, "seat_tilt_status", "seat tilt", {}, kTilt),
    status(0x0014, "leg_rest_status", "leg rest", {}, kLegs, "rotation also moves the extension"),
    status(0x0015, "actuator1_position", "actuator 1 (seat lift) position", "per-mille"),
    status(0x0016, "actuator2_position", "actuator 2 (backrest) position", "per-mille"),
    status(0x0017, "actuator3_position", "actuator 3 (seat tilt) position", "per-mille"),
    status(0x0018, "actuator4_position", "actuator 4 (leg-rest rotation) position", "per-mille"),
    status(0x0019, "actuator5_position", "actuator 5 (leg-rest extension) position", "per-mille"),
    status(0x001A, "actuator6_position", "actuator 6 (seat-plate tilt) position", "per-mille"),
    status(0x001B, "actuator1_state", "actuator 1 state", {}, kActuator),
    status(0x001C, "actuator2_state", "actuator 2 state", {}, kActuator),
    status(0x001D, "actuator3_state", "actuator 3 state", {}, kActuator),
    status(0x001E, "actuator4_state", "actuator 4 state", {}, kActuator),
    status(0x001F, "actuator5_state", "actuator 5 state", {}, kActuator),
    status(0x0020, "actuator6_state", "actuator 6 state", {}, kActuator),
    status(0x0021, "motor1_state", "chassis motor 1", {}, kMotor),
    status(0x0022, "motor2_state", "chassis motor 2", {}, kMotor),
    status(0x0023, "horn_button", "horn button (joystick)", {}, kOffOn, "the host plays the horn"),
    status(0x0024, "view_button", "360-view button (joystick)", {}, kOffOn,
           "the host shows the 360-degree view"),
    status(0x0025, "software_version", "software version"),
    status(0x0026, "error_code", "local error code", {}, {}, "0 none, else a code of table 3"),
    status(0x0027, "reserved_27", "reserved", {}, {}, "reads 0"),
    status(0x0028, "reserved_28", "reserved", {}, {}, "reads 0"),
    status(0x0029, "reserved_29", "reserved", {}, {}, "reads 0"),
    status(0x002A, "reserved_2a", "reserved", {}, {}, "reads 0"),
    status(0x002B, "reserved_2b", "reserved", {}, {}, "reads 0"),
    status(0x002C, "reserved_2c", "reserved", {}, {}, "reads 0"),
    status(0x002D, "reserved_2d", "reserved", {}, {}, "reads 0"),
    status(0x002E, "reserved_2e", "reserved", {}, {}, "reads 0"),
    status(0x002F, "reserved_2f", "reserved", {}, {}, "reads 0"),
    // ---- table 2: the host writes ----
    command(0x0060, "drive_mode", "drive mode", Kind::setting, kDriveModes, 1, false),
    command(0x0061, "light", "main light (UI or phone)", Kind::pulse, kOffOn, 0, false, "toggles 0x000D"),
    command(0x0062, "stand", "posture 1: stand / sit (one-touch)", Kind::hold, kStandCmd, 0, true,
            "drives actuators 1, 2 and 4 together"),
    command(0x0063, "seat_lift", "posture 2: seat lift", Kind::hold, kUpDown, 0, true, "actuator 1"),
    command(0x0064, "backrest", "posture 3: backrest", Kind::hold, kFwdBack, 0, true, "actuator 2"),
    command(0x0065, "seat_tilt", "posture 4: whole-seat tilt", Kind::hold, kFwdBack, 0, true, "actuator 3"),
    command(0x0066, "leg_rotate", "posture 5: leg rest rotate", Kind::hold, kUpDown, 0, true,
            "actuator 4, with actuator 5"),
    command(0x0067, "leg_extend", "posture 6: leg rest extend / retract", Kind::hold, kOutIn, 0, true,
            "actuator 5"),
    command(0x0068, "plate_tilt", "posture 7: seat-plate tilt", Kind::hold, kFwdBack, 0, true, "actuator 6"),
    command(0x0069, "speed_level", "chassis speed level", Kind::setting, {}, 1, false, {}, 1, 5),
    command(0x006A, "anti_pinch", "anti-pinch stop", Kind::hold, kOffOn, 0, false,
            "while 1 every actuator stops and posture commands have no effect"),
    command(0x006B, "host_ready", "host boot complete", Kind::hold, kOffOn, 0, false),
    command(0x006C, "host_fault", "host fault code", Kind::setting, {}, 0, false,
            "int16, host-defined, 0 = none", 0, 0xFFFF, true),
    command(0x006D, "sos", "SOS call", Kind::hold, kOffOn, 0, false, "reserved"),
    command(0x006E, "phone_forward", "phone: forward", Kind::hold, kOffOn, 0, true,
            "only while the joystick is neutral and the chair static"),
    command(0x006F, "phone_reverse", "phone: reverse", Kind::hold, kOffOn, 0, true, "as phone forward"),
    command(0x0070, "phone_left", "phone: turn left", Kind::hold, kOffOn, 0, true, "as phone forward"),
    command(0x0071, "phone_right", "phone: turn right", Kind::hold, kOffOn, 0, true, "as phone forward"),
    command(0x0072, "phone_left_signal", "phone: left turn signal", Kind::pulse, kOffOn, 0, false,
            "toggles; turning one signal on turns the other off"),
    command(0x0073, "phone_right_signal", "phone: right turn signal", Kind::pulse, kOffOn, 0, false,
            "toggles; turning one signal on turns the other off"),
    command(0x0074, "phone_horn", "phone: horn", Kind::hold, kOffOn, 0, false),
    command(0x0075, "phone_light", "phone: lighting", Kind::pulse, kPhoneLightValues, 0, false,
            "toggles the main light; the seed writes 2 for on (D-4: 1 accepted too)"),
    command(0x0076, "reserved_76", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x0077, "reserved_77", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x0078, "reserved_78", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x0079, "reserved_79", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x007A, "reserved_7a", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x007B, "reserved_7b", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x007C, "reserved_7c", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x007D, "reserved_7d", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x007E, "reserved_7e", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
    command(0x007F, "reserved_7f", "reserved", Kind::reserved, {}, 0, false, "stored, no effect"),
};

constexpr uint16_t kMasterExtra[] = {0x101D};
constexpr uint16_t kLegsExtra[] = {0x109A, 0x109B, 0x119A, 0x119B};  // printed 119A/119B; keep both readable
constexpr uint16_t kTiltExtra[] = {0x108D};
constexpr uint16_t kStandExtra[] = {0x10DD};
constexpr ErrorGroup kGroups[] = {
    {"Master", 0x1010, 0x1017, kMasterExtra}, {"Legs", 0x1091, 0x1099, kLegsExtra},
    {"Tilt", 0x1081, 0x108A, kTiltExtra},     {"Back", 0x10B1, 0x10BB, {}},
    {"Seat lift", 0x10C1, 0x10CB, {}},        {"Stand", 0x10D1, 0x10DA, kStandExtra},
    {"Support wheels", 0x1171, 0x117B, {}},   {"Chassis motor", 0x1271, 0x127B, {}},
};

std::string_view kind_name(Kind k) {
  switch (k) {
    case Kind::status:
      return "read";
    case Kind::setting:
      return "setting";
    case Kind::hold:
      return "hold";
    case Kind::pulse:
      return "pulse";
    case Kind::reserved:
      return "reserved";
  }
  return "?";
}

}  // namespace

std::span<const Register> registers() noexcept {
  return kRegisters;
}

const Register* find_register(uint16_t address) noexcept {
  for (const Register& r : kRegisters) {
    if (r.address == address) return &r;
  }
  return nullptr;
}

const Register* find_register(std::string_view key) noexcept {
  for (const Register& r : kRegisters) {
    if (r.key == key) return &r;
  }
  return nullptr;
}

Errc check_value(const Register& reg, uint16_t value) noexcept {
  if (!reg.choices.empty()) {
    for (const Choice& c : reg.choices) {
      if (c.value == value) return Errc::ok;
    }
    return Errc::illegal_data_value;
  }
  if (reg.is_signed) return Errc::ok;  // any int16
  return value < reg.min || value > reg.max ? Errc::illegal_data_value : Errc::ok;
}

std::string_view choice_name(const Register& reg, uint16_t value) noexcept {
  for (const Choice& c : reg.choices) {
    if (c.value == value) return c.name;
  }
  return {};
}

std::string format_value(const Register& reg, uint16_t raw) {
  if (!reg.choices.empty()) {
    const std::string_view name = choice_name(reg, raw);
    return name.empty() ? fmt::format("unknown ({})", raw) : fmt::format("{} ({})", name, raw);
  }
  if (reg.address == reg::kErrorCode || reg.address == reg::kHostFault)
    return raw == 0 ? "none" : error_text(raw);
  if (reg.address == reg::kDeviceId) return fmt::format("0x{:02X}", raw);
  if (reg.is_signed) return fmt::format("{}", static_cast<int16_t>(raw));
  return reg.unit.empty() ? fmt::format("{}", raw) : fmt::format("{} {}", raw, reg.unit);
}

std::string registers_markdown() {
  std::string out;
  for (const Table table : {Table::status, Table::command}) {
    out += table == Table::status
               ? "### Table 1: the host reads (FC03, 0x0000..0x002F; writes get exception 02)\n\n"
               : "### Table 2: the host writes (FC06/FC10, 0x0060..0x007F; reads get exception 02)\n\n";
    out += "| address | key | name | kind | values | default | notes |\n|---|---|---|---|---|---|---|\n";
    for (const Register& r : kRegisters) {
      if (r.table != table) continue;
      std::string values;
      for (const Choice& c : r.choices)
        values += fmt::format("{}{} {}", values.empty() ? "" : ", ", c.value, c.name);
      if (values.empty()) {
        if (r.is_signed)
          values = "int16";
        else if (r.min != 0 || r.max != 0xFFFF)
          values = fmt::format("{}..{}", r.min, r.max);
        else
          values = "uint16";
        if (!r.unit.empty()) values += " " + std::string(r.unit);
      }
      std::string notes(r.notes);
      if (r.motion) notes += std::string(notes.empty() ? "" : "; ") + "refused (04) during a local fault";
      out += fmt::format("| 0x{:04X} | `{}` | {} | {} | {} | {} | {} |\n", r.address, r.key, r.title,
                         kind_name(r.kind), values,
                         table == Table::status ? "-" : std::to_string(r.default_value),
                         notes.empty() ? "-" : notes);
    }
    out += "\n";
  }
  out +=
      "0x0030..0x005F and everything above 0x007F do not exist (exception 02). A value outside a register's "
      "list gets exception 03; a multi-register write is validated whole, then applied all or nothing.\n";
  return out;
}

std::span<const ErrorGroup> error_groups() noexcept {
  return kGroups;
}

std::string_view error_function(uint16_t code) noexcept {
  for (const ErrorGroup& g : kGroups) {
    if (code >= g.first && code <= g.last) return g.function;
    for (uint16_t e : g.extra) {
      if (e == code) return g.function;
    }
  }
  return {};
}

std::string error_text(uint16_t code) {
  const std::string_view f = error_function(code);
  return fmt::format("{:04X} {} Error", code, f.empty() ? std::string_view("Unknown") : f);
}

std::span<const uint16_t> error_codes() noexcept {
  static const std::vector<uint16_t> codes = [] {
    std::vector<uint16_t> v;
    for (const ErrorGroup& g : kGroups) {
      for (uint32_t c = g.first; c <= g.last; ++c) v.push_back(static_cast<uint16_t>(c));
      for (uint16_t e : g.extra) v.push_back(e);
    }
    std::sort(v.begin(), v.end());
    return v;
  }();
  return codes;
}

std::string errors_markdown() {
  std::string out = "| codes | function | UI text (example) |\n|---|---|---|\n";
  for (const ErrorGroup& g : kGroups) {
    std::string codes = fmt::format("{:04X}..{:04X}", g.first, g.last);
    for (uint16_t e : g.extra) codes += fmt::format(", {:04X}", e);
    out += fmt::format("| {} | {} | {} |\n", codes, g.function, error_text(g.first));
  }
  out +=
      "\nEvery active error shows as a full-screen overlay and disables every function. 1010 is also raised "
      "by "
      "the host itself when the controller does not answer (communication error).\n";
  return out;
}

}  // namespace rtukit::rehand6600
