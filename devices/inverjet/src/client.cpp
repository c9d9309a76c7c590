// The Inverjet's typed client. Every value goes through the register table:
// ranges are checked with its rows, readings are decoded with its scales.
#include "rtukit/devices/inverjet/client.hpp"

#include <fmt/core.h>

#include <array>

#include "rtukit/devices/profile/text.hpp"

namespace rtukit::inverjet {
namespace {

// A caller's argument against the row it will be written to.
rtukit::Status argument(profile::Handle h, int64_t raw) {
  return profile::check_argument(kMap.row(h), raw);
}

// Decodes entry `h` from a block of words read from `first` on.
int64_t decode(profile::Handle h, std::span<const uint16_t> block, uint16_t first) {
  const Row& r = kMap.row(h);
  return profile::RegisterMap::decode(r, block.subspan(r.address - first, r.words()));
}
double number(profile::Handle h, std::span<const uint16_t> block, uint16_t first) {
  return profile::RegisterMap::to_number(kMap.row(h), decode(h, block, first));
}

}  // namespace

std::string_view MachineStatus::state_name() const noexcept {
  for (const Named& n : kMap.row(reg::state).names) {
    if (n.value == state) return n.name;
  }
  return "unknown";
}

std::vector<std::string_view> MachineStatus::fault_names() const {
  std::vector<std::string_view> out;
  for (const Named& c : inverjet::fault_names()) {
    if (faults & (1U << c.value)) out.push_back(c.name);
  }
  return out;
}

rtukit::Status validate_plan(std::span<const Segment> segments) {
  const auto bad = [](std::string reason) {
    return rtukit::Status(Errc::invalid_argument, std::move(reason));
  };
  if (segments.empty()) return bad("a plan needs at least one segment");
  if (segments.size() > kSegmentsPerPlan)
    return bad(fmt::format("{} segments; a plan holds at most {}", segments.size(), kSegmentsPerPlan));
  uint16_t previous = 0;
  for (size_t i = 0; i < segments.size(); ++i) {
    const Segment& s = segments[i];
    if (rtukit::Status e = argument(reg::plan_speed(1), s.speed))
      return bad(fmt::format("segment {}: {}", i + 1, e.reason()));
    if (rtukit::Status e = argument(reg::plan_end(1), s.end))
      return bad(fmt::format("segment {}: {}", i + 1, e.reason()));
    if (s.end <= previous)
      return bad(fmt::format("segment {}: end {} is not after {}", i + 1, profile::format_mm_ss(s.end),
                             profile::format_mm_ss(previous)));
    previous = s.end;
  }
  return {};
}

// Exception 04 has three causes on the Inverjet; one more look says which.
rtukit::Status Client::explain(Error e) {
  if (!e.is_exception() || e.exception_code() != 0x04) return e;
  Result<MachineStatus> st = status();
  std::array<uint16_t, 1> mask{};
  const Error mask_read = master_.read_holding_registers(unit_, reg::kControlMask, mask);
  if (st.ok() && st->phase() == Phase::fault) {
    std::string names;
    for (auto n : st->fault_names()) names += (names.empty() ? "" : ", ") + std::string(n);
    return rtukit::Status(e, fmt::format("{} ({})", kFaultScreenReason, names));
  }
  if (!mask_read && (mask[0] & 0x2))
    return rtukit::Status(e,
                          fmt::format("{} (control mask bit 1; `config mask 0` clears it)", kMaskedReason));
  if (st.ok()) return rtukit::Status(e, fmt::format("{} {}", kWrongStateReason, st->state_name()));
  return rtukit::Status(e, "control masked, fault screen, or nothing to pause");
}

rtukit::Status Client::write(uint16_t address, std::span<const uint16_t> values) {
  const Error e = values.size() == 1 ? master_.write_single_register(unit_, address, values[0])
                                     : master_.write_multiple_registers(unit_, address, values);
  return e ? explain(e) : rtukit::Status();
}

Result<MachineStatus> Client::status() {
  std::array<uint16_t, 4> control{};
  if (Error e = master_.read_holding_registers(unit_, reg::kWorkMode, control)) return e;
  std::array<uint16_t, reg::kInputCount> in{};
  if (Error e = master_.read_input_registers(unit_, 0, in)) return e;
  const auto held = [&](profile::Handle h) {
    return static_cast<uint16_t>(decode(h, control, reg::kWorkMode));
  };
  const auto word32 = [&](profile::Handle h) { return static_cast<uint32_t>(decode(h, in, 0)); };
  MachineStatus s;
  s.mode = held(reg::work_mode);
  s.state = held(reg::state);
  s.speed = held(reg::speed);
  s.run_time = held(reg::run_time);
  s.display_software = word32(reg::display_software);
  s.display_hardware = word32(reg::display_hardware);
  s.driver_software = word32(reg::driver_software);
  s.driver_hardware = word32(reg::driver_hardware);
  s.faults = static_cast<uint16_t>(decode(reg::faults, in, 0));
  s.mosfet_c = number(reg::mosfet_temperature, in, 0);
  s.motor_c = number(reg::motor_temperature, in, 0);
  s.current_a = number(reg::motor_current, in, 0);
  s.rpm_x_poles = word32(reg::motor_speed);
  s.rpm = s.rpm_x_poles / static_cast<uint32_t>(kMap.row(reg::pole_count).default_value);  // D-7: fixed
  s.bus_v = number(reg::bus_voltage, in, 0);
  return s;
}

Result<Config> Client::config() {
  Config out;
  for (const Row& r : kRows) {
    if (r.space != Space::holding || r.role != Role::setting || r.repeat > 1) continue;
    std::array<uint16_t, 2> w{};
    if (Error e = master_.read_holding_registers(unit_, r.address, std::span(w.data(), r.words()))) return e;
    out.push_back({&r, profile::RegisterMap::decode(r, w)});
  }
  return out;
}

rtukit::Status Client::start_free(uint16_t speed, bool remember) {
  if (rtukit::Status e = argument(reg::speed, speed)) return e;
  const std::array<uint16_t, 3> v{0, state_value(Family::free, remember ? Phase::initial : Phase::running),
                                  speed};
  return write(reg::kWorkMode, v);
}

rtukit::Status Client::start_free_from_memory() {
  const std::array<uint16_t, 2> v{0, state_value(Family::free, Phase::running)};
  return write(reg::kWorkMode, v);
}

rtukit::Status Client::start_timer(uint16_t speed, uint16_t duration_s, bool remember) {
  if (rtukit::Status e = argument(reg::speed, speed)) return e;
  if (rtukit::Status e = argument(reg::run_time, duration_s)) return e;
  if (duration_s == 0)
    return rtukit::Status(Errc::invalid_argument, "a timer run needs a duration of at least 1 s");
  const std::array<uint16_t, 4> v{0, state_value(Family::timer, remember ? Phase::initial : Phase::running),
                                  speed, duration_s};
  return write(reg::kWorkMode, v);
}

rtukit::Status Client::start_plan(unsigned plan, uint16_t from_s) {
  if (plan < 1 || plan > kPlanCount) return rtukit::Status(Errc::invalid_argument, "plans are numbered 1..4");
  if (rtukit::Status e = argument(reg::run_time, from_s)) return e;
  const uint16_t running = state_value(Family::training, Phase::running);
  if (from_s == 0) {
    const std::array<uint16_t, 2> v{static_cast<uint16_t>(plan), running};
    return write(reg::kWorkMode, v);
  }
  // Mode, state, speed, time are consecutive: to start part-way in, send the
  // speed of the segment we land in (the plan's own speed, so no override).
  Outcome<std::vector<Segment>> segments = read_plan(plan);
  if (!segments.ok()) return segments.error();
  for (const Segment& s : *segments) {
    if (s.end > from_s) {
      const std::array<uint16_t, 4> v{static_cast<uint16_t>(plan), running, s.speed, from_s};
      return write(reg::kWorkMode, v);
    }
  }
  return rtukit::Status(Errc::invalid_argument, fmt::format("plan P{} ends before {}: nothing would run",
                                                            plan, profile::format_mm_ss(from_s)));
}

rtukit::Status Client::pause() {
  std::array<uint16_t, 1> state{};
  if (Error e = master_.read_holding_registers(unit_, reg::kState, state)) return e;
  if (phase_of(state[0]) == Phase::paused) return {};
  const Family f = family_of(state[0]);
  const std::array<uint16_t, 1> v{state_value(f == Family::none ? Family::free : f, Phase::paused)};
  return write(reg::kState, v);
}

rtukit::Status Client::resume() {
  std::array<uint16_t, 1> state{};
  if (Error e = master_.read_holding_registers(unit_, reg::kState, state)) return e;
  if (phase_of(state[0]) != Phase::paused)
    return rtukit::Status(Errc::invalid_argument, std::string(kNothingPausedReason));
  const std::array<uint16_t, 1> v{state_value(family_of(state[0]), Phase::running)};
  return write(reg::kState, v);
}

rtukit::Status Client::stop() {
  const std::array<uint16_t, 1> v{state_value(Family::none, Phase::off)};
  return write(reg::kState, v);
}

rtukit::Status Client::set_speed(uint16_t speed) {
  if (rtukit::Status e = argument(reg::speed, speed)) return e;
  const std::array<uint16_t, 1> v{speed};
  return write(reg::kSpeed, v);
}

Outcome<std::vector<Segment>> Client::read_plan(unsigned plan) {
  if (plan < 1 || plan > kPlanCount) return rtukit::Status(Errc::invalid_argument, "plans are numbered 1..4");
  std::array<uint16_t, 2 * kSegmentsPerPlan> regs{};
  if (Error e = master_.read_holding_registers(unit_, reg::plan_base(plan), regs)) return rtukit::Status(e);
  Plan p{};
  for (unsigned k = 0; k < kSegmentsPerPlan; ++k) p[k] = Segment{regs[2 * k], regs[2 * k + 1]};
  return std::vector<Segment>(p.begin(), p.begin() + plan_length(p));
}

rtukit::Status Client::write_plan(unsigned plan, std::span<const Segment> segments) {
  if (plan < 1 || plan > kPlanCount) return rtukit::Status(Errc::invalid_argument, "plans are numbered 1..4");
  if (rtukit::Status e = validate_plan(segments)) return e;
  std::vector<uint16_t> regs;
  for (const Segment& s : segments) {
    regs.push_back(s.speed);
    regs.push_back(s.end);
  }
  if (segments.size() < kSegmentsPerPlan) {  // the end marker: end time 0 is not after the last one
    regs.push_back(0);
    regs.push_back(0);
  }
  return write(reg::plan_base(plan), regs);
}

rtukit::Status Client::clear_plan(unsigned plan) {
  if (plan < 1 || plan > kPlanCount) return rtukit::Status(Errc::invalid_argument, "plans are numbered 1..4");
  const Plan factory = default_plan();
  std::array<uint16_t, 2 * kSegmentsPerPlan> regs{};
  for (unsigned k = 0; k < kSegmentsPerPlan; ++k) {
    regs[2 * k] = factory[k].speed;
    regs[2 * k + 1] = factory[k].end;
  }
  return write(reg::plan_base(plan), regs);
}

rtukit::Status Client::set_address(uint8_t address) {
  if (rtukit::Status e = argument(reg::address, address)) return e;
  const std::array<uint16_t, 1> v{address};
  if (rtukit::Status e = write(reg::kAddress, v)) return e;
  unit_ = UnitId{address};
  return {};
}

rtukit::Status Client::set_baud(uint32_t baud) {
  const int code = code_of_baud(baud);
  if (code < 0)
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("baud {}: the Inverjet runs at 1200, 2400, 4800, 9600 or 19200", baud));
  const std::array<uint16_t, 1> v{static_cast<uint16_t>(code)};
  return write(reg::kBaud, v);
}

rtukit::Status Client::set_control_mask(uint16_t mask) {
  if (rtukit::Status e = argument(reg::control_mask, mask)) return e;
  const std::array<uint16_t, 1> v{mask};
  return write(reg::kControlMask, v);
}

rtukit::Status Client::set_pairing(uint16_t mode) {
  if (rtukit::Status e = argument(reg::pairing, mode)) return e;
  const std::array<uint16_t, 1> v{mode};
  return write(reg::kPairing, v);
}

}  // namespace rtukit::inverjet
