// The Inverjet register map (spec inverjet.md). Everything else reads this.
#include "rtukit/devices/inverjet/registers.hpp"

#include <fmt/core.h>

#include <array>
#include <charconv>

namespace rtukit::inverjet {
namespace {

constexpr Choice kBaudCodes[] = {{0, "1200"}, {1, "2400"}, {2, "4800"}, {3, "9600"}, {4, "19200"}};
constexpr Choice kMaskBits[] = {{0, "Bluetooth"}, {1, "Modbus-RS485"}, {2, "Wi-Fi"}};
constexpr Choice kPairing[] = {{0, "none"}, {1, "Wi-Fi pairing"}, {2, "remote-control pairing"}};
constexpr Choice kModes[] = {
    {0, "free & timer"}, {1, "plan P1"}, {2, "plan P2"}, {3, "plan P3"}, {4, "plan P4"}};
constexpr Choice kStates[] = {
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
constexpr Choice kFaultBits[] = {
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

constexpr Range kPercent{0, kMaxSpeed};
constexpr Range kTime{0, kMaxTime};
constexpr Range kAny{0, 0xFFFF};

// Shorthand for the rows below; fields in the order of `Register`.
constexpr Register holding(uint16_t address, std::string_view key, std::string_view title, Format format,
                           std::string_view unit, Range range, uint16_t default_value, bool persisted,
                           bool control, std::span<const Choice> choices = {}, std::string_view notes = {},
                           Range writable = {1, 0}) {
  return Register{Table::holding,
                  address,
                  1,
                  key,
                  title,
                  true,
                  format,
                  unit,
                  1,
                  range,
                  writable.min > writable.max ? range : writable,
                  default_value,
                  default_value,
                  persisted,
                  control,
                  choices,
                  notes};
}

constexpr Register plan_row(unsigned plan, bool end_time) {
  constexpr std::string_view kSpeedKeys[] = {"p1_speed", "p2_speed", "p3_speed", "p4_speed"};
  constexpr std::string_view kEndKeys[] = {"p1_end", "p2_end", "p3_end", "p4_end"};
  constexpr std::string_view kSpeedTitles[] = {"P1 segment speed", "P2 segment speed", "P3 segment speed",
                                               "P4 segment speed"};
  constexpr std::string_view kEndTitles[] = {"P1 segment end time", "P2 segment end time",
                                             "P3 segment end time", "P4 segment end time"};
  Register r{Table::holding,
             static_cast<uint16_t>(reg::plan_base(plan) + (end_time ? 1 : 0)),
             1,
             end_time ? kEndKeys[plan - 1] : kSpeedKeys[plan - 1],
             end_time ? kEndTitles[plan - 1] : kSpeedTitles[plan - 1],
             true,
             end_time ? Format::seconds : Format::number,
             end_time ? "s" : "%",
             1,
             end_time ? kTime : kPercent,
             end_time ? kTime : kPercent,
             0,
             static_cast<uint16_t>(end_time ? 60 : 20),
             true,
             true,
             {},
             end_time
                 ? "segment k+1 at +2k; the plan ends at the first end time not greater than the previous "
                   "one (D-11: a fresh plan is 60 s at 20 %)"
                 : "segment k+1 at +2k, k = 0..49",
             kSegmentsPerPlan,
             2};
  return r;
}

constexpr Register input(uint16_t address, uint16_t words, std::string_view key, std::string_view title,
                         Format format, std::string_view unit, uint16_t scale,
                         std::span<const Choice> choices = {}, std::string_view notes = {}) {
  return Register{Table::input, address, words, key, title, false, format,  unit, scale,
                  kAny,         kAny,    0,     0,   false, false, choices, notes};
}

constexpr std::array kRegisters = {
    // ---- holding registers: configuration (never masked, D-5) ----
    holding(reg::kAddress, "address", "slave address", Format::number, "", {1, 254}, kDefaultAddress, true,
            false, {}, "takes effect after the response to the write"),
    holding(reg::kBaud, "baud", "baud rate code", Format::choice, "", {0, 4}, 3, true, false, kBaudCodes,
            "takes effect after the response to the write (D-4: 4 = 19200)"),
    holding(reg::kControlMask, "control_mask", "control mask", Format::bits, "", {0, 7}, 0, true, false,
            kMaskBits, "1 = that channel may not control; bit 1 set: control writes get exception 04 (D-5)"),
    holding(reg::kPairing, "pairing", "pairing mode", Format::choice, "", {0, 2}, 0, false, false, kPairing,
            "reads the active pairing window, 0 when none; a window closes after 60 s (D-6)"),
    holding(reg::kPoleCount, "pole_count", "motor pole count", Format::number, "", {0, 10}, 5, false, false,
            {}, "fixed: writing anything but 5 gets exception 03 (D-7)", Range{5, 5}),
    // ---- holding registers: control ----
    holding(reg::kWorkMode, "work_mode", "work mode", Format::choice, "", {0, 4}, 0, false, true, kModes),
    holding(reg::kState, "state", "state machine", Format::choice, "", {0, 17}, 0, false, true, kStates,
            "written phase applies to the mode's family (D-10); 17 is not writable (exception 03)",
            Range{0, 16}),
    holding(reg::kSpeed, "speed", "current motor speed", Format::number, "%", kPercent, 0, false, true),
    holding(reg::kRunTime, "run_time", "current run time", Format::seconds, "s", kTime, 0, false, true, {},
            "free and training modes count up, timer mode counts down"),
    // ---- holding registers: free/timer memory (flash) ----
    holding(reg::kFreeSpeed, "free_speed", "free-mode speed", Format::number, "%", kPercent, 50, true, true),
    holding(reg::kFreeTime, "free_time", "free-mode time", Format::seconds, "s", kTime, 0, true, true),
    holding(reg::kTimerSpeed, "timer_speed", "timer-mode speed", Format::number, "%", kPercent, 50, true,
            true),
    holding(reg::kTimerTime, "timer_time", "timer-mode time", Format::seconds, "s", kTime, 1800, true, true),
    // ---- holding registers: training plans ----
    plan_row(1, false),
    plan_row(1, true),
    plan_row(2, false),
    plan_row(2, true),
    plan_row(3, false),
    plan_row(3, true),
    plan_row(4, false),
    plan_row(4, true),
    // ---- input registers (read only) ----
    input(0x0000, 2, "display_software", "display board software version", Format::version, "", 1),
    input(0x0002, 2, "display_hardware", "display board hardware version", Format::version, "", 1),
    input(0x0004, 2, "driver_software", "driver board software version", Format::version, "", 1),
    input(0x0006, 2, "driver_hardware", "driver board hardware version", Format::version, "", 1),
    input(reg::kFaults, 1, "faults", "machine fault bits", Format::bits, "", 1, kFaultBits,
          "any bit set: fault screen (state 17), motor stops"),
    input(0x0009, 1, "driver_faults", "driver board fault", Format::number, "", 1, {}, "unused, reads 0"),
    input(reg::kMosfetTemperature, 1, "mosfet_temperature", "MOSFET temperature", Format::scaled, "degC", 10),
    input(reg::kMotorTemperature, 1, "motor_temperature", "motor temperature", Format::scaled, "degC", 10),
    input(reg::kMotorCurrent, 2, "motor_current", "motor current", Format::scaled, "A", 100),
    input(reg::kMotorSpeed, 2, "motor_speed", "motor speed x pole count", Format::number, "rpm", 1, {},
          "rpm multiplied by the pole count"),
    input(reg::kBusVoltage, 1, "bus_voltage", "DC bus voltage", Format::scaled, "V", 10),
};

}  // namespace

std::span<const Register> registers() noexcept {
  return kRegisters;
}

const Register* find_register(Table table, uint16_t address, unsigned* index, unsigned* word) noexcept {
  for (const Register& r : kRegisters) {
    if (r.table != table || address < r.address || address > r.last_address()) continue;
    const unsigned offset = address - r.address;
    if (offset % r.stride >= r.words) continue;  // the gap between repeated entries (another row)
    if (index) *index = offset / r.stride;
    if (word) *word = offset % r.stride;
    return &r;
  }
  return nullptr;
}

const Register* find_register(std::string_view key) noexcept {
  for (const Register& r : kRegisters) {
    if (r.key == key) return &r;
  }
  return nullptr;
}

Errc check_write(const Register& reg, uint16_t value) noexcept {
  if (!reg.writable) return Errc::illegal_data_address;
  return value < reg.writable_range.min || value > reg.writable_range.max ? Errc::illegal_data_value
                                                                          : Errc::ok;
}

std::string_view choice_name(const Register& reg, uint16_t value) noexcept {
  for (const Choice& c : reg.choices) {
    if (c.value == value) return c.name;
  }
  return {};
}

std::string format_mm_ss(unsigned seconds) {
  return fmt::format("{:02}:{:02}", seconds / 60, seconds % 60);
}

Result<uint32_t> parse_time(std::string_view text) noexcept {
  const auto number = [](std::string_view t, uint32_t* out) {
    if (t.empty()) return false;
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), *out);
    return ec == std::errc{} && end == t.data() + t.size();
  };
  const size_t colon = text.find(':');
  uint32_t a = 0, b = 0;
  if (colon == std::string_view::npos) {
    if (!number(text, &a)) return Errc::invalid_argument;
    return a;
  }
  const std::string_view sec = text.substr(colon + 1);
  if (!number(text.substr(0, colon), &a) || sec.size() != 2 || !number(sec, &b) || b > 59)
    return Errc::invalid_argument;
  return a * 60 + b;
}

std::string format_value(const Register& reg, uint32_t raw) {
  switch (reg.format) {
    case Format::number:
      return reg.unit.empty() ? fmt::format("{}", raw) : fmt::format("{} {}", raw, reg.unit);
    case Format::seconds:
      return format_mm_ss(raw);
    case Format::choice: {
      const std::string_view name = choice_name(reg, static_cast<uint16_t>(raw));
      return name.empty() ? fmt::format("unknown ({})", raw) : fmt::format("{} ({})", name, raw);
    }
    case Format::bits: {
      if (raw == 0) return "none";
      std::string out;
      for (unsigned bit = 0; bit < 16; ++bit) {
        if (!(raw & (1U << bit))) continue;
        std::string_view name = choice_name(reg, static_cast<uint16_t>(bit));
        if (!out.empty()) out += ", ";
        out += name.empty() ? fmt::format("bit {}", bit) : std::string(name);
      }
      return out;
    }
    case Format::version:
      return fmt::format("V{}.{}", raw >> 16, raw & 0xFFFF);
    case Format::scaled: {
      const unsigned decimals = reg.scale >= 100 ? 2 : reg.scale >= 10 ? 1 : 0;
      return fmt::format("{:.{}f} {}", static_cast<double>(raw) / reg.scale, decimals, reg.unit);
    }
  }
  return fmt::format("{}", raw);
}

std::string registers_markdown() {
  std::string out;
  for (const Table table : {Table::holding, Table::input}) {
    out += fmt::format("### {} registers ({})\n\n", table == Table::holding ? "Holding" : "Input",
                       table == Table::holding ? "FC03 read, FC06/FC10 write" : "FC04, read only");
    out += "| address | key | name | access | unit | range | default | persisted | values / notes |\n";
    out += "|---|---|---|---|---|---|---|---|---|\n";
    for (const Register& r : kRegisters) {
      if (r.table != table) continue;
      std::string address = fmt::format("0x{:04X}", r.address);
      if (r.repeat > 1)
        address = fmt::format("0x{:04X} + {}k (k = 0..{})", r.address, r.stride, r.repeat - 1);
      else if (r.words > 1)
        address = fmt::format("0x{:04X}..0x{:04X}", r.address, r.last_address());
      std::string range = "-";
      std::string default_text = "-";
      if (r.writable) {
        range = fmt::format("{}..{}", r.range.min, r.range.max);
        if (r.writable_range.min != r.range.min || r.writable_range.max != r.range.max)
          range += fmt::format(" (writes {}..{})", r.writable_range.min, r.writable_range.max);
        default_text = r.repeat > 1 ? fmt::format("{} (segment 1: {})", r.default_value, r.default_first)
                                    : fmt::format("{}", r.default_value);
      } else if (r.words == 2) {
        range = "u32, high word first";
      }
      std::string notes;
      for (const Choice& c : r.choices) {
        if (!notes.empty()) notes += ", ";
        notes += r.format == Format::bits ? fmt::format("bit{} {}", c.value, c.name)
                                          : fmt::format("{} {}", c.value, c.name);
      }
      if (!r.notes.empty()) notes += (notes.empty() ? "" : "; ") + std::string(r.notes);
      if (r.control)
        notes += notes.empty() ? "masked by control-mask bit 1" : "; masked by control-mask bit 1";
      std::string unit(r.unit);
      if (r.format == Format::scaled) unit = fmt::format("{} {}", r.scale == 10 ? "0.1" : "0.01", r.unit);
      out += fmt::format("| {} | `{}` | {} | {} | {} | {} | {} | {} | {} |\n", address, r.key, r.title,
                         r.writable ? "RW" : "R", unit.empty() ? "-" : unit, range, default_text,
                         r.persisted ? "yes" : "no", notes.empty() ? "-" : notes);
    }
    out += "\n";
  }
  out += "Every address not listed is reserved: a read or write touching it gets exception 02 (D-8).\n";
  return out;
}

uint16_t state_value(Family family, Phase phase) noexcept {
  if (phase == Phase::off) return 0;
  if (phase == Phase::menu) return 16;
  if (phase == Phase::fault) return 17;
  const uint16_t base = family == Family::timer ? 6 : family == Family::training ? 11 : 1;
  return static_cast<uint16_t>(base + static_cast<uint16_t>(phase) - static_cast<uint16_t>(Phase::initial));
}

Phase phase_of(uint16_t state) noexcept {
  if (state == 0) return Phase::off;
  if (state == 16) return Phase::menu;
  if (state >= 17) return Phase::fault;
  return static_cast<Phase>(static_cast<uint16_t>(Phase::initial) + (state - 1) % 5);
}

Family family_of(uint16_t state) noexcept {
  if (state >= 1 && state <= 5) return Family::free;
  if (state >= 6 && state <= 10) return Family::timer;
  if (state >= 11 && state <= 15) return Family::training;
  return Family::none;
}

std::string_view phase_name(Phase phase) noexcept {
  constexpr std::string_view kNames[] = {"off",    "initial", "starting",       "running",
                                         "paused", "ended",   "operation menu", "fault screen"};
  return kNames[static_cast<size_t>(phase)];
}

std::string_view family_name(Family family) noexcept {
  constexpr std::string_view kNames[] = {"none", "free", "timer", "training"};
  return kNames[static_cast<size_t>(family)];
}

std::span<const Choice> fault_names() noexcept {
  return kFaultBits;
}

uint32_t baud_of_code(uint16_t code) noexcept {
  constexpr uint32_t kRates[] = {1200, 2400, 4800, 9600, 19200};
  return code < 5 ? kRates[code] : 0;
}

int code_of_baud(uint32_t baud) noexcept {
  for (uint16_t c = 0; c < 5; ++c) {
    if (baud_of_code(c) == baud) return c;
  }
  return -1;
}

}  // namespace rtukit::inverjet
