// Inverjet register map, as data. This table is the single source of truth:
// the simulator validates writes with it, the CLI and the typed client decode
// values with it, and `rtukit inverjet registers` prints the reference in
// docs/inverjet.md from it. Read it like the device manual
// (../shared/spec/inverjet.md, seed 002 section 3).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "rtukit/core/error.hpp"

namespace rtukit::inverjet {

/// Default link settings (spec D-1, D-2).
inline constexpr uint8_t kDefaultAddress = 21;
inline constexpr uint32_t kDefaultBaud = 9600;
inline constexpr unsigned kPlanCount = 4;
inline constexpr unsigned kSegmentsPerPlan = 50;
inline constexpr uint16_t kMaxTime = 5999;  ///< seconds (99:59), every time register
inline constexpr uint16_t kMaxSpeed = 100;  ///< percent

enum class Table : uint8_t { holding, input };

/// How a raw value reads to a person.
enum class Format : uint8_t {
  number,   ///< plain unsigned, with the unit
  seconds,  ///< shown as mm:ss
  choice,   ///< one of `choices`
  bits,     ///< bit set; `choices` names the bits (value = bit number)
  version,  ///< u32: high word major, low word minor ("V1.2")
  scaled,   ///< value / `scale` in `unit`
};

struct Range {
  uint16_t min = 0;
  uint16_t max = 0xFFFF;
};

/// One named value (Format::choice) or bit (Format::bits, value = bit number).
struct Choice {
  uint16_t value;
  std::string_view name;
};

/// One row of the map. A row may describe a repeated block: `repeat` entries
/// `stride` registers apart (the 50 segments of a training plan).
struct Register {
  Table table;
  uint16_t address;      ///< first (lowest) address
  uint16_t words;        ///< 1, or 2 for 32-bit values (high word first, D-9)
  std::string_view key;  ///< stable identifier: JSON keys, CLI names
  std::string_view title;
  bool writable;
  Format format;
  std::string_view unit;  ///< "%", "s", "degC", ... or empty
  uint16_t scale;         ///< Format::scaled divisor (10 = 0.1 units), else 1
  Range range;            ///< documented range
  Range writable_range;   ///< what a write may carry (narrower for 0x0004 and 0x0022)
  uint16_t default_value;
  uint16_t default_first;  ///< default of the first entry of a repeated block
  bool persisted;          ///< kept in flash (the simulator's state file)
  bool control;            ///< masked by control-mask bit 1 (D-5)
  std::span<const Choice> choices;
  std::string_view notes;
  uint16_t repeat = 1;
  uint16_t stride = 1;

  uint16_t last_address() const noexcept {
    return static_cast<uint16_t>(address + (repeat - 1) * stride + words - 1);
  }
};

/// Every row, holding registers first, in address order.
std::span<const Register> registers() noexcept;

/// The row holding `address` in `table`, or nullptr (a reserved address).
/// `index` receives the entry within a repeated block (segment number - 1);
/// `word` which word of a 32-bit value (0 = high).
const Register* find_register(Table table, uint16_t address, unsigned* index = nullptr,
                              unsigned* word = nullptr) noexcept;

/// The row named `key` (e.g. "work_mode"), or nullptr.
const Register* find_register(std::string_view key) noexcept;

/// Checks one value for a write: ok, or illegal_data_value (03) when outside
/// the row's writable range.
Errc check_write(const Register& reg, uint16_t value) noexcept;

/// Name of a choice value ("timer running") or empty when not listed.
std::string_view choice_name(const Register& reg, uint16_t value) noexcept;

/// A value as a person reads it: "80 %", "30:00", "timer running (8)",
/// "voltage, motor drive", "V1.2", "31.5 degC".
std::string format_value(const Register& reg, uint32_t raw);

/// mm:ss for a number of seconds ("30:00", "99:59").
std::string format_mm_ss(unsigned seconds);

/// Parses "mm:ss", "m:ss" or plain seconds ("1800"). Errors: invalid_argument
/// for text that is neither; the range (0..5999) is the caller's to check.
Result<uint32_t> parse_time(std::string_view text) noexcept;

/// The register reference as a Markdown table (docs/inverjet.md).
std::string registers_markdown();

// ---- names used by the state machine and the fault register ----

/// State machine values (0x0022).
enum class Phase : uint8_t { off, initial, starting, running, paused, ended, menu, fault };
enum class Family : uint8_t { none, free, timer, training };

/// Register value of a phase in a family (off = 0, menu = 16, fault = 17).
uint16_t state_value(Family family, Phase phase) noexcept;
/// Phase of a state value (0..17).
Phase phase_of(uint16_t state) noexcept;
/// Family of a state value (none for 0, 16, 17).
Family family_of(uint16_t state) noexcept;
std::string_view phase_name(Phase phase) noexcept;
std::string_view family_name(Family family) noexcept;

/// Fault bits of input register 0x0008.
inline constexpr uint16_t kFaultVoltage = 1U << 0;
inline constexpr uint16_t kFaultOverCurrent = 1U << 1;
inline constexpr uint16_t kFaultCurrentSensor = 1U << 2;
inline constexpr uint16_t kFaultMosfetTemperature = 1U << 3;
inline constexpr uint16_t kFaultEnclosureTemperature = 1U << 4;
inline constexpr uint16_t kFaultTemperatureSensor1 = 1U << 5;
inline constexpr uint16_t kFaultTemperatureSensor2 = 1U << 6;
inline constexpr uint16_t kFaultMotorDrive = 1U << 7;
inline constexpr uint16_t kFaultDriverCommunication = 1U << 8;
inline constexpr uint16_t kFaultDefinedBits = 0x01FF;

/// The fault bits' names (from the table's row for 0x0008).
std::span<const Choice> fault_names() noexcept;

// Addresses used by name in code (all described in the table).
namespace reg {
inline constexpr uint16_t kAddress = 0x0000;
inline constexpr uint16_t kBaud = 0x0001;
inline constexpr uint16_t kControlMask = 0x0002;
inline constexpr uint16_t kPairing = 0x0003;
inline constexpr uint16_t kPoleCount = 0x0004;
inline constexpr uint16_t kWorkMode = 0x0021;
inline constexpr uint16_t kState = 0x0022;
inline constexpr uint16_t kSpeed = 0x0023;
inline constexpr uint16_t kRunTime = 0x0024;
inline constexpr uint16_t kFreeSpeed = 0x0080;
inline constexpr uint16_t kFreeTime = 0x0081;
inline constexpr uint16_t kTimerSpeed = 0x0082;
inline constexpr uint16_t kTimerTime = 0x0083;
/// First register of plan `plan` (1..4): 0x0100, 0x0180, 0x0200, 0x0280.
constexpr uint16_t plan_base(unsigned plan) noexcept {
  return static_cast<uint16_t>(0x0100 + 0x80 * (plan - 1));
}

// Input registers.
inline constexpr uint16_t kDisplaySoftware = 0x0000;
inline constexpr uint16_t kFaults = 0x0008;
inline constexpr uint16_t kMosfetTemperature = 0x000A;
inline constexpr uint16_t kMotorTemperature = 0x000B;
inline constexpr uint16_t kMotorCurrent = 0x000C;
inline constexpr uint16_t kMotorSpeed = 0x000E;
inline constexpr uint16_t kBusVoltage = 0x0010;
inline constexpr uint16_t kInputCount = 0x0011;  ///< 0x0000..0x0010
}  // namespace reg

/// Baud code (0x0001) <-> baud rate (D-4: 4 = 19200). 0 for an unknown code.
uint32_t baud_of_code(uint16_t code) noexcept;
/// -1 when `baud` has no code.
int code_of_baud(uint32_t baud) noexcept;

}  // namespace rtukit::inverjet
