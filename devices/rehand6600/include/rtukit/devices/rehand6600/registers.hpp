// Rehand 6600 register map and error table, as data. The single source of
// truth: the simulator validates with it, the host controller and the CLI
// decode with it, `rtukit rehand6600 registers|errors` print the references
// in docs/rehand6600.md from it. Read it like the seed's tables 1, 2 and 3
// (../shared/spec/rehand6600.md).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "rtukit/core/error.hpp"

namespace rtukit::rehand6600 {

inline constexpr uint8_t kDefaultAddress = 0x01;
inline constexpr uint32_t kDefaultBaud = 115200;  // D-1
inline constexpr uint16_t kDeviceId = 0x68;

/// Table 1 (the host reads) or table 2 (the host writes). D-3: strict.
enum class Table : uint8_t { status, command };

/// What a table-2 command does with its value.
enum class Kind : uint8_t {
  status,    ///< table 1: read only
  setting,   ///< kept until written again
  hold,      ///< active while the register holds it; the host writes 0 on release
  pulse,     ///< acts on the rising edge (0 -> non-zero); the host writes 1 then 0
  reserved,  ///< stored, no effect
};

struct Choice {
  uint16_t value;
  std::string_view name;
};

struct Register {
  Table table;
  uint16_t address;
  std::string_view key;  ///< stable identifier (JSON, CLI: `hold stand 1`)
  std::string_view title;
  Kind kind;
  std::string_view unit;            ///< "%", "km/h", "mm", "per-mille" or empty
  bool is_signed;                   ///< int16 on the wire
  uint16_t min, max;                ///< accepted values (writes; for reads: what the device reports)
  std::span<const Choice> choices;  ///< when set, only these values are accepted
  uint16_t default_value;
  std::string_view notes;
  bool motion = false;  ///< posture or drive command: refused (04) while a local fault is active (D-6)
};

/// Every row: table 1 (0x0000..0x002F), then table 2 (0x0060..0x007F).
std::span<const Register> registers() noexcept;
/// The row at `address`, or nullptr (0x0030..0x005F and above 0x007F do not exist).
const Register* find_register(uint16_t address) noexcept;
/// The row named `key`, or nullptr.
const Register* find_register(std::string_view key) noexcept;
/// ok, or illegal_data_value (03) when `value` is not one the row accepts.
Errc check_value(const Register& reg, uint16_t value) noexcept;
/// "spin left (4)", "12 km/h", "on", "-5".
std::string format_value(const Register& reg, uint16_t raw);
std::string_view choice_name(const Register& reg, uint16_t value) noexcept;
/// Tables 1 and 2 as Markdown (docs/rehand6600.md).
std::string registers_markdown();

// ---- table 3: error codes ----

struct ErrorGroup {
  std::string_view function;        ///< "Master", "Legs", ...
  uint16_t first, last;             ///< a range of codes
  std::span<const uint16_t> extra;  ///< codes outside the range
};

/// The groups of table 3.
std::span<const ErrorGroup> error_groups() noexcept;
/// The function of `code` ("Legs"), or empty when table 3 does not list it.
std::string_view error_function(uint16_t code) noexcept;
/// The UI text: "1010 Master Error"; unknown codes: "1234 Unknown Error".
std::string error_text(uint16_t code);
/// Every listed code, ascending.
std::span<const uint16_t> error_codes() noexcept;
/// Table 3 as Markdown.
std::string errors_markdown();

/// The Master error the host raises for a communication failure.
inline constexpr uint16_t kMasterCommunicationError = 0x1010;

namespace reg {
inline constexpr uint16_t kDeviceId = 0x0000;
inline constexpr uint16_t kBattery = 0x0001;
inline constexpr uint16_t kCharging = 0x0002;
inline constexpr uint16_t kSpeed = 0x0003;
inline constexpr uint16_t kClutch = 0x0004;
inline constexpr uint16_t kMotion = 0x0005;
inline constexpr uint16_t kDistanceFront = 0x0006;  ///< .. 0x0009 rear, left, right
inline constexpr uint16_t kJoystickX = 0x000A;
inline constexpr uint16_t kJoystickY = 0x000B;
inline constexpr uint16_t kMainLight = 0x000D;
inline constexpr uint16_t kLeftSignal = 0x000E;
inline constexpr uint16_t kRightSignal = 0x000F;
inline constexpr uint16_t kSeatLiftStatus = 0x0010;
inline constexpr uint16_t kBackrestStatus = 0x0011;
inline constexpr uint16_t kStandStatus = 0x0012;
inline constexpr uint16_t kSeatTiltStatus = 0x0013;
inline constexpr uint16_t kLegRestStatus = 0x0014;
inline constexpr uint16_t kActuatorPosition = 0x0015;  ///< .. 0x001A, actuators 1..6
inline constexpr uint16_t kActuatorState = 0x001B;     ///< .. 0x0020
inline constexpr uint16_t kMotor1State = 0x0021;
inline constexpr uint16_t kMotor2State = 0x0022;
inline constexpr uint16_t kHornButton = 0x0023;
inline constexpr uint16_t kViewButton = 0x0024;
inline constexpr uint16_t kSoftwareVersion = 0x0025;
inline constexpr uint16_t kErrorCode = 0x0026;
inline constexpr uint16_t kStatusCount = 0x0030;  ///< table 1 = 0x0000..0x002F

inline constexpr uint16_t kDriveMode = 0x0060;
inline constexpr uint16_t kLight = 0x0061;
inline constexpr uint16_t kStandSit = 0x0062;   ///< posture 1
inline constexpr uint16_t kSeatLift = 0x0063;   ///< posture 2
inline constexpr uint16_t kBackrest = 0x0064;   ///< posture 3
inline constexpr uint16_t kSeatTilt = 0x0065;   ///< posture 4
inline constexpr uint16_t kLegRotate = 0x0066;  ///< posture 5
inline constexpr uint16_t kLegExtend = 0x0067;  ///< posture 6
inline constexpr uint16_t kPlateTilt = 0x0068;  ///< posture 7
inline constexpr uint16_t kSpeedLevel = 0x0069;
inline constexpr uint16_t kAntiPinch = 0x006A;
inline constexpr uint16_t kHostReady = 0x006B;
inline constexpr uint16_t kHostFault = 0x006C;
inline constexpr uint16_t kSos = 0x006D;
inline constexpr uint16_t kPhoneForward = 0x006E;
inline constexpr uint16_t kPhoneReverse = 0x006F;
inline constexpr uint16_t kPhoneLeft = 0x0070;
inline constexpr uint16_t kPhoneRight = 0x0071;
inline constexpr uint16_t kPhoneLeftSignal = 0x0072;
inline constexpr uint16_t kPhoneRightSignal = 0x0073;
inline constexpr uint16_t kPhoneHorn = 0x0074;
inline constexpr uint16_t kPhoneLight = 0x0075;
inline constexpr uint16_t kCommandFirst = 0x0060;
inline constexpr uint16_t kCommandCount = 0x0020;  ///< table 2 = 0x0060..0x007F
}  // namespace reg

}  // namespace rtukit::rehand6600
