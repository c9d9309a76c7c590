// Inverjet register map, as data: the single source of truth. The model
// validates and stores with it, the typed client, the CLI and the
// simulator's console decode with it, the state file keeps its persisted
// rows, and `rtukit inverjet registers` prints the reference in
// docs/inverjet.md from it. Read it like the device manual
// (docs/spec/inverjet.md, the seed's section 3).
//
// Adding a register is one row here (plus the model line that uses it, if
// it has behaviour); a persisted setting is one row with `kPersisted`.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/profile/register_map.hpp"

namespace rtukit::inverjet {

using profile::Encoding;
using profile::Named;
using profile::Role;
using profile::Row;
using profile::Space;

/// Default link settings (spec D-1, D-2).
inline constexpr uint8_t kDefaultAddress = 21;
inline constexpr unsigned kPlanCount = 4;
inline constexpr unsigned kSegmentsPerPlan = 50;
inline constexpr uint16_t kMaxTime = 5999;  ///< seconds (99:59), every time register
inline constexpr uint16_t kMaxSpeed = 100;  ///< percent
/// Screens ask before a start or a change above this speed (percent): a
/// rule of ours for people, not the machine's (docs/inverjet.md, "Pool panel").
inline constexpr uint16_t kFastSpeed = 80;

/// The Inverjet's own row flag: masked by control-mask bit 1 (D-5).
inline constexpr profile::Flags kMasked = 1U << 1;

namespace detail {
inline constexpr Named kBaudCodes[] = {{0, "1200"}, {1, "2400"}, {2, "4800"}, {3, "9600"}, {4, "19200"}};
inline constexpr Named kMaskBits[] = {{0, "Bluetooth"}, {1, "Modbus-RS485"}, {2, "Wi-Fi"}};
// Short names: they are what people type (`set pairing wifi`, `config pairing wifi`).
inline constexpr Named kPairing[] = {{0, "off"}, {1, "wifi"}, {2, "remote"}};
inline constexpr Named kModes[] = {
    {0, "free & timer"}, {1, "plan P1"}, {2, "plan P2"}, {3, "plan P3"}, {4, "plan P4"}};
inline constexpr Named kStates[] = {
    {0, "off"},
    {1, "free initial"},
    {2, "free starting"},
    {3, "free running"},
    {4, "free paused"},
    {5, "free ended"},
    {6, "timer initial"},
    {7, "timer starting"},
    {8, "timer running"},
    {9, "timer paused"},
    {10, "timer ended"},
    {11, "training initial"},
    {12, "training starting"},
    {13, "training running"},
    {14, "training paused"},
    {15, "training ended"},
    {16, "operation menu"},
    {17, "fault screen"},
};
inline constexpr Named kFaultBits[] = {
    {0, "voltage"},
    {1, "output over-current"},
    {2, "current-sensor bias"},
    {3, "MOSFET over-temperature"},
    {4, "enclosure over-temperature"},
    {5, "temperature sensor 1"},
    {6, "temperature sensor 2"},
    {7, "motor drive"},
    {8, "driver-board communication"},
};
// What the swimmer or the pool staff does about each fault bit (same bits as
// kFaultBits): the panel, the bridge's state and `inverjet status` show it.
inline constexpr Named kFaultAdvice[] = {
    {0, "mains voltage out of range: check the supply; the machine restarts when it is back in range"},
    {1, "the motor drew too much current: check the propeller for a blockage, then start again"},
    {2, "current-sensor fault: switch the machine off and on; call service if it comes back"},
    {3, "the drive is too hot: let it cool down and check the cooling water flow"},
    {4, "the enclosure is too hot: check the ventilation of the technical room"},
    {5, "temperature sensor fault: call service"},
    {6, "temperature sensor fault: call service"},
    {7,
     "motor drive fault: switch off, check the motor cable, then start again; call service if it comes back"},
    {8, "the display lost the driver board: check the cable between them"},
};
inline constexpr profile::Range kPercent{0, kMaxSpeed};
inline constexpr profile::Range kTime{0, kMaxTime};
inline constexpr profile::Flags kSaved = profile::kPersisted;
inline constexpr std::string_view kSpeedNotes = "segment k+1 at +2k, k = 0..49";
inline constexpr std::string_view kEndNotes =
    "segment k+1 at +2k; the plan ends at the first end time not greater than the previous one (D-11: a "
    "fresh "
    "plan is 60 s at 20 %)";

// The two rows of training plan `plan` (1..4): 50 segments of speed, end time.
constexpr Row plan_speed(unsigned plan, std::string_view key, std::string_view title) {
  return {.space = Space::holding,
          .address = static_cast<uint16_t>(0x0100 + 0x80 * (plan - 1)),
          .key = key,
          .title = title,
          .unit = "%",
          .range = kPercent,
          .default_value = 0,
          .default_first = 20,
          .flags = kSaved | kMasked,
          .notes = kSpeedNotes,
          .repeat = kSegmentsPerPlan,
          .stride = 2};
}
constexpr Row plan_end(unsigned plan, std::string_view key, std::string_view title) {
  return {.space = Space::holding,
          .address = static_cast<uint16_t>(0x0101 + 0x80 * (plan - 1)),
          .key = key,
          .title = title,
          .encoding = Encoding::duration,
          .unit = "s",
          .range = kTime,
          .default_value = 0,
          .default_first = 60,
          .flags = kSaved | kMasked,
          .notes = kEndNotes,
          .repeat = kSegmentsPerPlan,
          .stride = 2};
}
constexpr Row input(uint16_t address, std::string_view key, std::string_view title, Encoding encoding,
                    std::string_view unit = {}, uint16_t scale = 1, std::span<const Named> names = {},
                    std::string_view notes = {}) {
  return {.space = Space::input,
          .address = address,
          .key = key,
          .title = title,
          .role = Role::status,
          .encoding = encoding,
          .unit = unit,
          .scale = scale,
          .names = names,
          .notes = notes};
}
}  // namespace detail

/// Every row, holding registers first, in address order.
inline constexpr Row kRows[] = {
    // ---- holding registers: configuration (never masked, D-5) ----
    {.space = Space::holding,
     .address = 0x0000,
     .key = "address",
     .title = "slave address",
     .range = {1, 254},
     .default_value = kDefaultAddress,
     .flags = detail::kSaved | profile::kLinkAddress,
     .notes = "takes effect after the response to the write"},
    {.space = Space::holding,
     .address = 0x0001,
     .key = "baud",
     .title = "baud rate code",
     .encoding = Encoding::choice,
     .range = {0, 4},
     .default_value = 3,
     .flags = detail::kSaved | profile::kLinkBaud,
     .names = detail::kBaudCodes,
     .notes = "takes effect after the response to the write (D-4: 4 = 19200)"},
    {.space = Space::holding,
     .address = 0x0002,
     .key = "control_mask",
     .title = "control mask",
     .encoding = Encoding::bits,
     .range = {0, 7},
     .default_value = 0,
     .flags = detail::kSaved,
     .names = detail::kMaskBits,
     .notes = "1 = that channel may not control; bit 1 set: control writes get exception 04 (D-5)"},
    {.space = Space::holding,
     .address = 0x0003,
     .key = "pairing",
     .title = "pairing mode",
     .encoding = Encoding::choice,
     .range = {0, 2},
     .names = detail::kPairing,
     .notes = "reads the active pairing window, 0 when none; a window closes after 60 s (D-6)"},
    {.space = Space::holding,
     .address = 0x0004,
     .key = "pole_count",
     .title = "motor pole count",
     .range = {0, 10},
     .writable_range = {5, 5},
     .default_value = 5,
     .notes = "fixed: writing anything but 5 gets exception 03 (D-7)"},
    // ---- holding registers: control ----
    {.space = Space::holding,
     .address = 0x0021,
     .key = "work_mode",
     .title = "work mode",
     .role = Role::control,
     .encoding = Encoding::choice,
     .range = {0, 4},
     .flags = kMasked,
     .names = detail::kModes},
    {.space = Space::holding,
     .address = 0x0022,
     .key = "state",
     .title = "state machine",
     .role = Role::control,
     .encoding = Encoding::choice,
     .range = {0, 17},
     .writable_range = {0, 16},
     .flags = kMasked,
     .names = detail::kStates,
     .notes = "written phase applies to the mode's family (D-10); 17 is not writable (exception 03)"},
    {.space = Space::holding,
     .address = 0x0023,
     .key = "speed",
     .title = "current motor speed",
     .role = Role::control,
     .unit = "%",
     .range = detail::kPercent,
     .flags = kMasked},
    {.space = Space::holding,
     .address = 0x0024,
     .key = "run_time",
     .title = "current run time",
     .role = Role::control,
     .encoding = Encoding::duration,
     .unit = "s",
     .range = detail::kTime,
     .flags = kMasked,
     .notes = "free and training modes count up, timer mode counts down"},
    // ---- holding registers: free/timer memory (flash) ----
    {.space = Space::holding,
     .address = 0x0080,
     .key = "free_speed",
     .title = "free-mode speed",
     .unit = "%",
     .range = detail::kPercent,
     .default_value = 50,
     .flags = detail::kSaved | kMasked},
    {.space = Space::holding,
     .address = 0x0081,
     .key = "free_time",
     .title = "free-mode time",
     .encoding = Encoding::duration,
     .unit = "s",
     .range = detail::kTime,
     .default_value = 0,
     .flags = detail::kSaved | kMasked},
    {.space = Space::holding,
     .address = 0x0082,
     .key = "timer_speed",
     .title = "timer-mode speed",
     .unit = "%",
     .range = detail::kPercent,
     .default_value = 50,
     .flags = detail::kSaved | kMasked},
    {.space = Space::holding,
     .address = 0x0083,
     .key = "timer_time",
     .title = "timer-mode time",
     .encoding = Encoding::duration,
     .unit = "s",
     .range = detail::kTime,
     .default_value = 1800,
     .flags = detail::kSaved | kMasked},
    // ---- holding registers: training plans ----
    detail::plan_speed(1, "p1_speed", "P1 segment speed"),
    detail::plan_end(1, "p1_end", "P1 segment end time"),
    detail::plan_speed(2, "p2_speed", "P2 segment speed"),
    detail::plan_end(2, "p2_end", "P2 segment end time"),
    detail::plan_speed(3, "p3_speed", "P3 segment speed"),
    detail::plan_end(3, "p3_end", "P3 segment end time"),
    detail::plan_speed(4, "p4_speed", "P4 segment speed"),
    detail::plan_end(4, "p4_end", "P4 segment end time"),
    // ---- input registers (read only) ----
    detail::input(0x0000, "display_software", "display board software version", Encoding::version),
    detail::input(0x0002, "display_hardware", "display board hardware version", Encoding::version),
    detail::input(0x0004, "driver_software", "driver board software version", Encoding::version),
    detail::input(0x0006, "driver_hardware", "driver board hardware version", Encoding::version),
    detail::input(0x0008, "faults", "machine fault bits", Encoding::bits, {}, 1, detail::kFaultBits,
                  "any bit set: fault screen (state 17), motor stops"),
    detail::input(0x0009, "driver_faults", "driver board fault", Encoding::u16, {}, 1, {}, "unused, reads 0"),
    detail::input(0x000A, "mosfet_temperature", "MOSFET temperature", Encoding::u16, "degC", 10),
    detail::input(0x000B, "motor_temperature", "motor temperature", Encoding::u16, "degC", 10),
    detail::input(0x000C, "motor_current", "motor current", Encoding::u32, "A", 100),
    detail::input(0x000E, "motor_speed", "motor speed x pole count", Encoding::u32, "rpm", 1, {},
                  "rpm multiplied by the pole count"),
    detail::input(0x0010, "bus_voltage", "DC bus voltage", Encoding::u16, "V", 10),
};

inline constexpr profile::FlagName kFlagNames[] = {{profile::kPersisted, "persisted"},
                                                   {kMasked, "masked-by-control-mask"}};

inline constexpr profile::Profile kProfile{
    .name = "inverjet",
    .title = "Inverjet counter-current swimming machine",
    .vendor = "Inverjet",
    .rows = kRows,
    .flag_names = kFlagNames,
    .link = {.parity = 'N', .stop_bits = 1},  // address and baud: the link rows 0x0000, 0x0001
    .quirks = {.fc10_without_byte_count = true},
};

inline constexpr profile::RegisterMap kMap{kRows};
/// The factory baud rate: the baud row's default (code 3).
inline constexpr uint32_t kDefaultBaud = profile::link_defaults(kProfile).baud;
static_assert(kDefaultBaud == 9600);

/// Registers used by name in code: compile-time handles (a typo does not compile).
namespace reg {
using profile::Handle;
inline constexpr Handle address = kMap.handle("address");
inline constexpr Handle baud = kMap.handle("baud");
inline constexpr Handle control_mask = kMap.handle("control_mask");
inline constexpr Handle pairing = kMap.handle("pairing");
inline constexpr Handle pole_count = kMap.handle("pole_count");
inline constexpr Handle work_mode = kMap.handle("work_mode");
inline constexpr Handle state = kMap.handle("state");
inline constexpr Handle speed = kMap.handle("speed");
inline constexpr Handle run_time = kMap.handle("run_time");
inline constexpr Handle free_speed = kMap.handle("free_speed");
inline constexpr Handle free_time = kMap.handle("free_time");
inline constexpr Handle timer_speed = kMap.handle("timer_speed");
inline constexpr Handle timer_time = kMap.handle("timer_time");
inline constexpr Handle display_software = kMap.handle("display_software");
inline constexpr Handle display_hardware = kMap.handle("display_hardware");
inline constexpr Handle driver_software = kMap.handle("driver_software");
inline constexpr Handle driver_hardware = kMap.handle("driver_hardware");
inline constexpr Handle faults = kMap.handle("faults");
inline constexpr Handle mosfet_temperature = kMap.handle("mosfet_temperature");
inline constexpr Handle motor_temperature = kMap.handle("motor_temperature");
inline constexpr Handle motor_current = kMap.handle("motor_current");
inline constexpr Handle motor_speed = kMap.handle("motor_speed");
inline constexpr Handle bus_voltage = kMap.handle("bus_voltage");
/// Speed and end-time rows of plan `plan` (1..4).
constexpr Handle plan_speed(unsigned plan) noexcept {
  return Handle{static_cast<uint16_t>(kMap.handle_of(*kMap.find("p1_speed")).row + 2 * (plan - 1))};
}
constexpr Handle plan_end(unsigned plan) noexcept {
  return Handle{static_cast<uint16_t>(plan_speed(plan).row + 1)};
}

/// Raw addresses, for code that speaks Modbus directly (the client's requests).
constexpr uint16_t at(Handle h) noexcept {
  return kMap.row(h).address;
}
inline constexpr uint16_t kAddress = at(address);
inline constexpr uint16_t kBaud = at(baud);
inline constexpr uint16_t kControlMask = at(control_mask);
inline constexpr uint16_t kPairing = at(pairing);
inline constexpr uint16_t kPoleCount = at(pole_count);
inline constexpr uint16_t kWorkMode = at(work_mode);
inline constexpr uint16_t kState = at(state);
inline constexpr uint16_t kSpeed = at(speed);
inline constexpr uint16_t kRunTime = at(run_time);
inline constexpr uint16_t kFreeSpeed = at(free_speed);
inline constexpr uint16_t kFreeTime = at(free_time);
inline constexpr uint16_t kTimerSpeed = at(timer_speed);
inline constexpr uint16_t kTimerTime = at(timer_time);
inline constexpr uint16_t kFaults = at(faults);
inline constexpr uint16_t kMosfetTemperature = at(mosfet_temperature);
inline constexpr uint16_t kMotorTemperature = at(motor_temperature);
inline constexpr uint16_t kMotorCurrent = at(motor_current);
inline constexpr uint16_t kMotorSpeed = at(motor_speed);
inline constexpr uint16_t kBusVoltage = at(bus_voltage);
inline constexpr uint16_t kInputCount = kMap.row(bus_voltage).last_address() + 1;  ///< 0x0000..0x0010
/// First register of plan `plan` (1..4): 0x0100, 0x0180, 0x0200, 0x0280.
constexpr uint16_t plan_base(unsigned plan) noexcept {
  return at(plan_speed(plan));
}
static_assert(kWorkMode == 0x0021 && kRunTime == 0x0024 && kInputCount == 0x0011 && plan_base(4) == 0x0280);
}  // namespace reg

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

/// The fault bits' names (the row of 0x0008).
constexpr std::span<const Named> fault_names() noexcept {
  return kMap.row(reg::faults).names;
}

/// Baud code (0x0001) <-> baud rate (D-4: 4 = 19200). 0 for an unknown code.
uint32_t baud_of_code(uint16_t code) noexcept;
/// -1 when `baud` has no code.
int code_of_baud(uint32_t baud) noexcept;

// ---- lookups by the names the rest of the code grew up with ----

/// The row holding `address` in `space`, or nullptr (a reserved address).
/// `index` receives the entry within a repeated block (segment number - 1).
inline const Row* find_register(Space space, uint16_t address, unsigned* index = nullptr) noexcept {
  const profile::Slot s = kMap.at(space, address);
  if (s && index) *index = s.index;
  return s.row;
}
/// The row named `key` (e.g. "work_mode"), or nullptr.
inline const Row* find_register(std::string_view key) noexcept {
  return kMap.find(key);
}
using Table = Space;  ///< holding or input

}  // namespace rtukit::inverjet
