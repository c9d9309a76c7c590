// Rehand 6600 register map and error table, as data. The single source of
// truth: the controller model validates with it, the host controller and the
// CLI decode with it, `rtukit rehand6600 registers|errors` print the
// references in docs/rehand6600.md from it. Read it like the seed's tables 1,
// 2 and 3 (docs/spec/rehand6600.md).
//
// Table 1 (the host reads) are read-only holding registers; table 2 (the
// host writes) are write-only (D-3: a read there gets exception 02). A row's
// role says what a command does with its value: setting (kept), hold (active
// while non-zero; the host writes 0 on release), pulse (acts on the rising
// edge), reserved (stored, no effect).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/profile/register_map.hpp"

namespace rtukit::rehand6600 {

using profile::Encoding;
using profile::Named;
using profile::Role;
using profile::Row;
using profile::Space;

inline constexpr uint8_t kDefaultAddress = 0x01;
inline constexpr uint32_t kDefaultBaud = 115200;  // D-1
inline constexpr uint16_t kDeviceId = 0x68;

/// The Rehand's own row flag: a posture or drive command, refused (04) while
/// a local fault is active (D-6).
inline constexpr profile::Flags kMotion = 1U << 1;

namespace detail {
inline constexpr Named kOffOn[] = {{0, "off"}, {1, "on"}};
inline constexpr Named kNoYes[] = {{0, "no"}, {1, "yes"}};
inline constexpr Named kClutch[] = {{0, "push"}, {1, "drive"}};
inline constexpr Named kMotionStates[] = {{1, "static"},        {2, "forward"},      {3, "reverse"},
                                          {4, "spin left"},     {5, "spin right"},   {6, "forward-left"},
                                          {7, "forward-right"}, {8, "reverse-left"}, {9, "reverse-right"}};
inline constexpr Named kLift[] = {{0, "still"}, {1, "rising"}, {2, "lowering"}};
inline constexpr Named kBack[] = {{0, "still"}, {1, "tilting forward"}, {2, "tilting back"}};
inline constexpr Named kStand[] = {{0, "still"}, {1, "standing up"}, {2, "sitting down"}};
inline constexpr Named kTilt[] = {{0, "still"}, {1, "forward"}, {2, "back"}};
inline constexpr Named kLegs[] = {
    {0, "still"}, {1, "rotating up"}, {2, "rotating down"}, {3, "extending/retracting"}};
inline constexpr Named kActuator[] = {
    {0, "still"}, {1, "moving"}, {2, "upper limit"}, {3, "lower limit"}, {4, "over-current"}};
inline constexpr Named kMotor[] = {{0, "still"}, {1, "running"}, {4, "over-current"}};
inline constexpr Named kDriveModes[] = {{1, "normal"}, {2, "indoor"}, {3, "outdoor"}};
inline constexpr Named kStandCmd[] = {{0, "off"}, {1, "stand"}, {2, "sit"}};
inline constexpr Named kUpDown[] = {{0, "off"}, {1, "up"}, {2, "down"}};
inline constexpr Named kFwdBack[] = {{0, "off"}, {1, "forward"}, {2, "back"}};
inline constexpr Named kOutIn[] = {{0, "off"}, {1, "extend"}, {2, "retract"}};
inline constexpr Named kPhoneLightValues[] = {{0, "off"}, {1, "on"}, {2, "on"}};  // D-4: the seed prints 2

constexpr Row status(uint16_t a, std::string_view key, std::string_view title, std::string_view unit = {},
                     std::span<const Named> choices = {}, std::string_view notes = {}, bool is_signed = false,
                     uint16_t max = 0xFFFF) {
  return {.space = Space::holding,
          .address = a,
          .key = key,
          .title = title,
          .role = Role::status,
          .encoding = !choices.empty() ? Encoding::choice
                      : is_signed      ? Encoding::i16
                                       : Encoding::u16,
          .unit = unit,
          .access = profile::Access::read_only,
          .range = is_signed ? profile::Range{} : profile::Range{0, max},
          .names = choices,
          .notes = notes};
}
constexpr Row command(uint16_t a, std::string_view key, std::string_view title, Role role,
                      std::span<const Named> choices, uint16_t default_value, bool motion,
                      std::string_view notes = {}, uint16_t min = 0, uint16_t max = 0xFFFF,
                      bool is_signed = false) {
  return {.space = Space::holding,
          .address = a,
          .key = key,
          .title = title,
          .role = role,
          .encoding = !choices.empty() ? Encoding::choice
                      : is_signed      ? Encoding::i16
                                       : Encoding::u16,
          .access = profile::Access::write_only,
          .range = is_signed ? profile::Range{} : profile::Range{min, max},
          .default_value = default_value,
          .flags = motion ? kMotion : 0,
          .names = choices,
          .notes = notes};
}
}  // namespace detail

namespace detail {
inline constexpr Row kTable[] = {
    detail::status(0x0000, "device_id", "device ID", {}, {},
                   "always 0x68; the host's handshake reads it first"),
    detail::status(0x0001, "battery", "battery", "%", {}, {}, false, 100),
    detail::status(0x0002, "charging", "charging", {}, kNoYes, "no driving while charging"),
    detail::status(0x0003, "speed", "speed", "km/h"),
    detail::status(0x0004, "clutch", "clutch", {}, kClutch,
                   "push: free-wheel, the chair can be pushed by hand"),
    detail::status(0x0005, "motion", "motion state", {}, kMotionStates),
    detail::status(0x0006, "distance_front", "ultrasonic distance front", "mm"),
    detail::status(0x0007, "distance_rear", "ultrasonic distance rear", "mm"),
    detail::status(0x0008, "distance_left", "ultrasonic distance left", "mm"),
    detail::status(0x0009, "distance_right", "ultrasonic distance right", "mm"),
    detail::status(0x000A, "joystick_x", "joystick X", {}, {}, "reserved", true),
    detail::status(0x000B, "joystick_y", "joystick Y", {}, {}, "reserved", true),
    detail::status(0x000C, "joystick_z", "joystick Z", {}, {}, "reserved", true),
    detail::status(0x000D, "main_light", "main light", {}, kOffOn),
    detail::status(0x000E, "left_signal", "left turn signal", {}, kOffOn),
    detail::status(0x000F, "right_signal", "right turn signal", {}, kOffOn),
    detail::status(0x0010, "seat_lift_status", "seat lift", {}, kLift),
    detail::status(0x0011, "backrest_status", "backrest", {}, kBack),
    detail::status(0x0012, "stand_status", "stand/sit", {}, kStand),
    detail::status(0x0013, "seat_tilt_status", "seat tilt", {}, kTilt),
    detail::status(0x0014, "leg_rest_status", "leg rest", {}, kLegs, "rotation also moves the extension"),
    detail::status(0x0015, "actuator1_position", "actuator 1 (seat lift) position", "per-mille"),
    detail::status(0x0016, "actuator2_position", "actuator 2 (backrest) position", "per-mille"),
    detail::status(0x0017, "actuator3_position", "actuator 3 (seat tilt) position", "per-mille"),
    detail::status(0x0018, "actuator4_position", "actuator 4 (leg-rest rotation) position", "per-mille"),
    detail::status(0x0019, "actuator5_position", "actuator 5 (leg-rest extension) position", "per-mille"),
    detail::status(0x001A, "actuator6_position", "actuator 6 (seat-plate tilt) position", "per-mille"),
    detail::status(0x001B, "actuator1_state", "actuator 1 state", {}, kActuator),
    detail::status(0x001C, "actuator2_state", "actuator 2 state", {}, kActuator),
    detail::status(0x001D, "actuator3_state", "actuator 3 state", {}, kActuator),
    detail::status(0x001E, "actuator4_state", "actuator 4 state", {}, kActuator),
    detail::status(0x001F, "actuator5_state", "actuator 5 state", {}, kActuator),
    detail::status(0x0020, "actuator6_state", "actuator 6 state", {}, kActuator),
    detail::status(0x0021, "motor1_state", "chassis motor 1", {}, kMotor),
    detail::status(0x0022, "motor2_state", "chassis motor 2", {}, kMotor),
    detail::status(0x0023, "horn_button", "horn button (joystick)", {}, kOffOn, "the host plays the horn"),
    detail::status(0x0024, "view_button", "360-view button (joystick)", {}, kOffOn,
                   "the host shows the 360-degree view"),
    detail::status(0x0025, "software_version", "software version"),
    detail::status(0x0026, "error_code", "local error code", {}, {}, "0 none, else a code of table 3"),
    detail::status(0x0027, "reserved_27", "reserved", {}, {}, "reads 0"),
    detail::status(0x0028, "reserved_28", "reserved", {}, {}, "reads 0"),
    detail::status(0x0029, "reserved_29", "reserved", {}, {}, "reads 0"),
    detail::status(0x002A, "reserved_2a", "reserved", {}, {}, "reads 0"),
    detail::status(0x002B, "reserved_2b", "reserved", {}, {}, "reads 0"),
    detail::status(0x002C, "reserved_2c", "reserved", {}, {}, "reads 0"),
    detail::status(0x002D, "reserved_2d", "reserved", {}, {}, "reads 0"),
    detail::status(0x002E, "reserved_2e", "reserved", {}, {}, "reads 0"),
    detail::status(0x002F, "reserved_2f", "reserved", {}, {}, "reads 0"),
    // ---- table 2: the host writes ----
    detail::command(0x0060, "drive_mode", "drive mode", Role::setting, kDriveModes, 1, false),
    detail::command(0x0061, "light", "main light (UI or phone)", Role::pulse, kOffOn, 0, false,
                    "toggles 0x000D"),
    detail::command(0x0062, "stand", "posture 1: stand / sit (one-touch)", Role::hold, kStandCmd, 0, true,
                    "drives actuators 1, 2 and 4 together"),
    detail::command(0x0063, "seat_lift", "posture 2: seat lift", Role::hold, kUpDown, 0, true, "actuator 1"),
    detail::command(0x0064, "backrest", "posture 3: backrest", Role::hold, kFwdBack, 0, true, "actuator 2"),
    detail::command(0x0065, "seat_tilt", "posture 4: whole-seat tilt", Role::hold, kFwdBack, 0, true,
                    "actuator 3"),
    detail::command(0x0066, "leg_rotate", "posture 5: leg rest rotate", Role::hold, kUpDown, 0, true,
                    "actuator 4, with actuator 5"),
    detail::command(0x0067, "leg_extend", "posture 6: leg rest extend / retract", Role::hold, kOutIn, 0, true,
                    "actuator 5"),
    detail::command(0x0068, "plate_tilt", "posture 7: seat-plate tilt", Role::hold, kFwdBack, 0, true,
                    "actuator 6"),
    detail::command(0x0069, "speed_level", "chassis speed level", Role::setting, {}, 1, false, {}, 1, 5),
    detail::command(0x006A, "anti_pinch", "anti-pinch stop", Role::hold, kOffOn, 0, false,
                    "while 1 every actuator stops and posture commands have no effect"),
    detail::command(0x006B, "host_ready", "host boot complete", Role::hold, kOffOn, 0, false),
    detail::command(0x006C, "host_fault", "host fault code", Role::setting, {}, 0, false,
                    "int16, host-defined, 0 = none", 0, 0xFFFF, true),
    detail::command(0x006D, "sos", "SOS call", Role::hold, kOffOn, 0, false, "reserved"),
    detail::command(0x006E, "phone_forward", "phone: forward", Role::hold, kOffOn, 0, true,
                    "only while the joystick is neutral and the chair static"),
    detail::command(0x006F, "phone_reverse", "phone: reverse", Role::hold, kOffOn, 0, true,
                    "as phone forward"),
    detail::command(0x0070, "phone_left", "phone: turn left", Role::hold, kOffOn, 0, true,
                    "as phone forward"),
    detail::command(0x0071, "phone_right", "phone: turn right", Role::hold, kOffOn, 0, true,
                    "as phone forward"),
    detail::command(0x0072, "phone_left_signal", "phone: left turn signal", Role::pulse, kOffOn, 0, false,
                    "toggles; turning one signal on turns the other off"),
    detail::command(0x0073, "phone_right_signal", "phone: right turn signal", Role::pulse, kOffOn, 0, false,
                    "toggles; turning one signal on turns the other off"),
    detail::command(0x0074, "phone_horn", "phone: horn", Role::hold, kOffOn, 0, false),
    detail::command(0x0075, "phone_light", "phone: lighting", Role::pulse, kPhoneLightValues, 0, false,
                    "toggles the main light; the seed writes 2 for on (D-4: 1 accepted too)"),
    detail::command(0x0076, "reserved_76", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x0077, "reserved_77", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x0078, "reserved_78", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x0079, "reserved_79", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x007A, "reserved_7a", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x007B, "reserved_7b", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x007C, "reserved_7c", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x007D, "reserved_7d", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x007E, "reserved_7e", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
    detail::command(0x007F, "reserved_7f", "reserved", Role::reserved, {}, 0, false, "stored, no effect"),
};
}  // namespace detail

/// Every row: table 1 (0x0000..0x002F), then table 2 (0x0060..0x007F).
inline constexpr const auto& kRows = detail::kTable;

inline constexpr profile::FlagName kFlagNames[] = {{profile::kPersisted, "persisted"}, {kMotion, "motion"}};

inline constexpr profile::Profile kProfile{
    .name = "rehand6600",
    .title = "Rehand 6600 wheelchair controller",
    .vendor = "Rehand",
    .rows = kRows,
    .flag_names = kFlagNames,
    .link = {.unit = kDefaultAddress, .unit_max = 247, .baud = kDefaultBaud, .parity = 'N', .stop_bits = 1},
    .quirks = {.fc03_two_byte_count = true},
};

inline constexpr profile::RegisterMap kMap{kRows};

/// Table 1 (the host reads) or table 2 (the host writes).
enum class Table : uint8_t { status, command };
constexpr Table table_of(const Row& r) noexcept {
  return r.access == profile::Access::write_only ? Table::command : Table::status;
}
using Register = Row;
using Kind = Role;

/// Every row.
constexpr std::span<const Row> registers() noexcept {
  return kRows;
}
/// The row at `address`, or nullptr (0x0030..0x005F and above 0x007F do not exist).
constexpr const Row* find_register(uint16_t address) noexcept {
  return kMap.at(Space::holding, address).row;
}
/// The row named `key` (either case style), or nullptr.
constexpr const Row* find_register(std::string_view key) noexcept {
  return kMap.find(key);
}
/// ok, or illegal_data_value (03) when `value` is not one the row accepts.
constexpr Errc check_value(const Row& r, uint16_t value) noexcept {
  const int64_t raw = r.is_signed() ? int64_t{static_cast<int16_t>(value)} : int64_t{value};  // one-word rows
  return profile::RegisterMap::check_value(r, raw).code();
}

/// Registers used by name in code, by address; each is looked up by its key
/// in the table at compile time (a wrong key does not compile).
namespace reg {
consteval uint16_t at(std::string_view key) {
  return kMap.row(kMap.handle(key)).address;
}
inline constexpr uint16_t kDeviceId = at("device_id");
inline constexpr uint16_t kBattery = at("battery");
inline constexpr uint16_t kCharging = at("charging");
inline constexpr uint16_t kSpeed = at("speed");
inline constexpr uint16_t kClutch = at("clutch");
inline constexpr uint16_t kMotion = at("motion");
inline constexpr uint16_t kDistanceFront = at("distance_front");
inline constexpr uint16_t kDistanceRear = at("distance_rear");
inline constexpr uint16_t kDistanceLeft = at("distance_left");
inline constexpr uint16_t kDistanceRight = at("distance_right");
inline constexpr uint16_t kJoystickX = at("joystick_x");
inline constexpr uint16_t kJoystickY = at("joystick_y");
inline constexpr uint16_t kMainLight = at("main_light");
inline constexpr uint16_t kLeftSignal = at("left_signal");
inline constexpr uint16_t kRightSignal = at("right_signal");
inline constexpr uint16_t kSeatLiftStatus = at("seat_lift_status");
inline constexpr uint16_t kBackrestStatus = at("backrest_status");
inline constexpr uint16_t kStandStatus = at("stand_status");
inline constexpr uint16_t kSeatTiltStatus = at("seat_tilt_status");
inline constexpr uint16_t kLegRestStatus = at("leg_rest_status");
inline constexpr uint16_t kActuatorPosition = at("actuator1_position");  ///< .. 0x001A, actuators 1..6
inline constexpr uint16_t kActuatorState = at("actuator1_state");        ///< .. 0x0020
/// Actuator `n`'s (1..6) position and state registers.
constexpr uint16_t actuator_position(unsigned n) noexcept {
  return static_cast<uint16_t>(kActuatorPosition + n - 1);
}
constexpr uint16_t actuator_state(unsigned n) noexcept {
  return static_cast<uint16_t>(kActuatorState + n - 1);
}
inline constexpr uint16_t kMotor1State = at("motor1_state");
inline constexpr uint16_t kMotor2State = at("motor2_state");
inline constexpr uint16_t kHornButton = at("horn_button");
inline constexpr uint16_t kViewButton = at("view_button");
inline constexpr uint16_t kSoftwareVersion = at("software_version");
inline constexpr uint16_t kErrorCode = at("error_code");
inline constexpr uint16_t kStatusCount = 0x0030;  ///< table 1 = 0x0000..0x002F

inline constexpr uint16_t kDriveMode = at("drive_mode");
inline constexpr uint16_t kLight = at("light");
inline constexpr uint16_t kStandSit = at("stand");        ///< posture 1
inline constexpr uint16_t kSeatLift = at("seat_lift");    ///< posture 2
inline constexpr uint16_t kBackrest = at("backrest");     ///< posture 3
inline constexpr uint16_t kSeatTilt = at("seat_tilt");    ///< posture 4
inline constexpr uint16_t kLegRotate = at("leg_rotate");  ///< posture 5
inline constexpr uint16_t kLegExtend = at("leg_extend");  ///< posture 6
inline constexpr uint16_t kPlateTilt = at("plate_tilt");  ///< posture 7
inline constexpr uint16_t kSpeedLevel = at("speed_level");
inline constexpr uint16_t kAntiPinch = at("anti_pinch");
inline constexpr uint16_t kHostReady = at("host_ready");
inline constexpr uint16_t kHostFault = at("host_fault");
inline constexpr uint16_t kSos = at("sos");
inline constexpr uint16_t kPhoneForward = at("phone_forward");
inline constexpr uint16_t kPhoneReverse = at("phone_reverse");
inline constexpr uint16_t kPhoneLeft = at("phone_left");
inline constexpr uint16_t kPhoneRight = at("phone_right");
inline constexpr uint16_t kPhoneLeftSignal = at("phone_left_signal");
inline constexpr uint16_t kPhoneRightSignal = at("phone_right_signal");
/// The phone's four drive commands (forward, reverse, left, right): what D-14,
/// D-10 and R-18 mean by "a phone drives".
constexpr bool is_phone_drive(uint16_t address) noexcept {
  return address >= kPhoneForward && address <= kPhoneRight;
}
inline constexpr uint16_t kPhoneHorn = at("phone_horn");
inline constexpr uint16_t kPhoneLight = at("phone_light");
inline constexpr uint16_t kCommandFirst = 0x0060;
inline constexpr uint16_t kCommandCount = 0x0020;  ///< table 2 = 0x0060..0x007F
}  // namespace reg

// ---- table 3: error codes ----

struct ErrorGroup {
  std::string_view function;        ///< "Master", "Legs", ...
  uint16_t first, last;             ///< a range of codes
  std::span<const uint16_t> extra;  ///< codes outside the range
};

/// What a code of a group means and what to check, for the person at the
/// chair. Table 3 names only the function; these are our reading of it.
struct ErrorAdvice {
  std::string_view function;  ///< as in ErrorGroup
  std::string_view meaning;   ///< "the seat-lift actuator (actuator 1) or its drive reports a fault"
  std::string_view check;     ///< "nothing blocks the seat above or below; ..."
};

namespace detail {
inline constexpr uint16_t kMasterExtra[] = {0x101D};
inline constexpr uint16_t kLegsExtra[] = {0x109A, 0x109B, 0x119A,
                                          0x119B};  // printed 119A/119B; keep both readable
inline constexpr uint16_t kTiltExtra[] = {0x108D};
inline constexpr uint16_t kStandExtra[] = {0x10DD};
inline constexpr ErrorGroup kGroups[] = {
    {"Master", 0x1010, 0x1017, kMasterExtra}, {"Legs", 0x1091, 0x1099, kLegsExtra},
    {"Tilt", 0x1081, 0x108A, kTiltExtra},     {"Back", 0x10B1, 0x10BB, {}},
    {"Seat lift", 0x10C1, 0x10CB, {}},        {"Stand", 0x10D1, 0x10DA, kStandExtra},
    {"Support wheels", 0x1171, 0x117B, {}},   {"Chassis motor", 0x1271, 0x127B, {}},
};
inline constexpr ErrorAdvice kAdvice[] = {
    {"Master", "the controller's main board reports a fault",
     "the controller's power and battery connection; switch the chair off and on; a code that comes back "
     "needs the dealer"},
    {"Legs", "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault",
     "nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator "
     "states show over-current"},
    {"Tilt",
     "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive "
     "reports a fault",
     "nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the "
     "actuator states show over-current"},
    {"Back", "the backrest actuator (actuator 2) or its drive reports a fault",
     "nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show "
     "over-current"},
    {"Seat lift", "the seat-lift actuator (actuator 1) or its drive reports a fault",
     "nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator "
     "states show over-current"},
    {"Stand", "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault",
     "nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and "
     "4; the user's position"},
    {"Support wheels", "the support (anti-tip) wheels or their drive report a fault",
     "the support wheels move freely and touch nothing; their cables and connectors"},
    {"Chassis motor", "a drive motor or its motor driver reports a fault",
     "the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery "
     "charge"},
};

}  // namespace detail

/// The groups of table 3.
constexpr std::span<const ErrorGroup> error_groups() noexcept {
  return detail::kGroups;
}
/// The function of `code` ("Legs"), or empty when table 3 does not list it.
constexpr std::string_view error_function(uint16_t code) noexcept {
  for (const ErrorGroup& g : detail::kGroups) {
    if (code >= g.first && code <= g.last) return g.function;
    for (uint16_t e : g.extra) {
      if (e == code) return g.function;
    }
  }
  return {};
}

/// What a group's codes mean and what to check (`function` as error_function
/// gives it); nullptr for a function table 3 does not list.
constexpr const ErrorAdvice* error_group_advice(std::string_view function) noexcept {
  for (const ErrorAdvice& a : detail::kAdvice) {
    if (a.function == function) return &a;
  }
  return nullptr;
}

/// The Master error the host raises for a communication failure.
inline constexpr uint16_t kMasterCommunicationError = 0x1010;

}  // namespace rtukit::rehand6600
