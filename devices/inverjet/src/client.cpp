#include "rtukit/devices/inverjet/client.hpp"

#include <fmt/core.h>

#include <array>

namespace rtukit::inverjet {

std::string_view Status::state_name() const noexcept {
  const std::string_view name = choice_name(*find_register(Table::holding, reg::kState), state);
  return name.empty() ? std::string_view("unknown") : name;
}

std::vector<std::string_view> Status::fault_names() const {
  std::vector<std::string_view> out;
  for (const Choice& c : inverjet::fault_names()) {
    if (faults & (1U << c.value)) out.push_back(c.name);
  }
  return out;
}

Error validate_plan(std::span<const Segment> segments, std::string* why) {
  const auto bad = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return Error(Errc::invalid_argument);
  };
  if (segments.empty()) return bad("a plan needs at least one segment");
  if (segments.size() > kSegmentsPerPlan)
    return bad(fmt::format("{} segments; a plan holds at most 50", segments.size()));
  uint16_t previous = 0;
  for (size_t i = 0; i < segments.size(); ++i) {
    const Segment& s = segments[i];
    if (s.speed > kMaxSpeed)
      return bad(fmt::format("segment {}: speed {} % is out of range 0..100", i + 1, s.speed));
    if (s.end > kMaxTime)
      return bad(
          fmt::format("segment {}: end time {} s is out of range (at most 5999 s = 99:59)", i + 1, s.end));
    if (s.end <= previous)
      return bad(fmt::format("segment {}: end {} is not after {}", i + 1, format_mm_ss(s.end),
                             format_mm_ss(previous)));
    previous = s.end;
  }
  return {};
}

Error Client::write(uint16_t address, std::span<const uint16_t> values) {
  if (values.size() == 1) return master_.write_single_register(unit_, address, values[0]);
  return master_.write_multiple_registers(unit_, address, values);
}

Result<Status> Client::status() {
  std::array<uint16_t, 4> control{};
  if (Error e = master_.read_holding_registers(unit_, reg::kWorkMode, control)) return e;
  std::array<uint16_t, reg::kInputCount> in{};
  if (Error e = master_.read_input_registers(unit_, 0, in)) return e;
  const auto u32 = [&](size_t i) { return (uint32_t{in[i]} << 16) | in[i + 1]; };
  Status s;
  s.mode = control[0];
  s.state = control[1];
  s.speed = control[2];
  s.run_time = control[3];
  s.display_software = u32(0);
  s.display_hardware = u32(2);
  s.driver_software = u32(4);
  s.driver_hardware = u32(6);
  s.faults = in[reg::kFaults];
  s.mosfet_c = in[reg::kMosfetTemperature] / 10.0;
  s.motor_c = in[reg::kMotorTemperature] / 10.0;
  s.current_a = u32(reg::kMotorCurrent) / 100.0;
  s.rpm_x_poles = u32(reg::kMotorSpeed);
  s.rpm = s.rpm_x_poles / 5;  // D-7: the pole count is fixed at 5
  s.bus_v = in[reg::kBusVoltage] / 10.0;
  return s;
}

Result<Config> Client::config() {
  std::array<uint16_t, 5> head{};
  if (Error e = master_.read_holding_registers(unit_, reg::kAddress, head)) return e;
  std::array<uint16_t, 4> memory{};
  if (Error e = master_.read_holding_registers(unit_, reg::kFreeSpeed, memory)) return e;
  return Config{head[0], head[1], head[2], head[3], head[4], memory[0], memory[1], memory[2], memory[3]};
}

Error Client::start_free(uint16_t speed, bool remember) {
  if (speed > kMaxSpeed) return Errc::invalid_argument;
  const std::array<uint16_t, 3> v{0, state_value(Family::free, remember ? Phase::initial : Phase::running),
                                  speed};
  return write(reg::kWorkMode, v);
}

Error Client::start_free_from_memory() {
  const std::array<uint16_t, 2> v{0, state_value(Family::free, Phase::running)};
  return write(reg::kWorkMode, v);
}

Error Client::start_timer(uint16_t speed, uint16_t duration_s, bool remember) {
  if (speed > kMaxSpeed || duration_s == 0 || duration_s > kMaxTime) return Errc::invalid_argument;
  const std::array<uint16_t, 4> v{0, state_value(Family::timer, remember ? Phase::initial : Phase::running),
                                  speed, duration_s};
  return write(reg::kWorkMode, v);
}

Error Client::start_plan(unsigned plan, uint16_t from_s) {
  if (plan < 1 || plan > kPlanCount || from_s > kMaxTime) return Errc::invalid_argument;
  const uint16_t running = state_value(Family::training, Phase::running);
  if (from_s == 0) {
    const std::array<uint16_t, 2> v{static_cast<uint16_t>(plan), running};
    return write(reg::kWorkMode, v);
  }
  // Mode, state, speed, time are consecutive: to start part-way in, send the
  // speed of the segment we land in (the plan's own speed, so no override).
  Result<std::vector<Segment>> segments = read_plan(plan);
  if (!segments.ok()) return segments.error();
  for (const Segment& s : *segments) {
    if (s.end > from_s) {
      const std::array<uint16_t, 4> v{static_cast<uint16_t>(plan), running, s.speed, from_s};
      return write(reg::kWorkMode, v);
    }
  }
  return Errc::invalid_argument;  // at or after the plan's end
}

Error Client::pause() {
  std::array<uint16_t, 1> state{};
  if (Error e = master_.read_holding_registers(unit_, reg::kState, state)) return e;
  if (phase_of(state[0]) == Phase::paused) return {};
  const Family f = family_of(state[0]);
  return master_.write_single_register(unit_, reg::kState,
                                       state_value(f == Family::none ? Family::free : f, Phase::paused));
}

Error Client::resume() {
  std::array<uint16_t, 1> state{};
  if (Error e = master_.read_holding_registers(unit_, reg::kState, state)) return e;
  if (phase_of(state[0]) != Phase::paused) return Errc::invalid_argument;
  return master_.write_single_register(unit_, reg::kState, state_value(family_of(state[0]), Phase::running));
}

Error Client::stop() {
  return master_.write_single_register(unit_, reg::kState, 0);
}

Error Client::set_speed(uint16_t speed) {
  if (speed > kMaxSpeed) return Errc::invalid_argument;
  return master_.write_single_register(unit_, reg::kSpeed, speed);
}

Result<std::vector<Segment>> Client::read_plan(unsigned plan) {
  if (plan < 1 || plan > kPlanCount) return Errc::invalid_argument;
  std::array<uint16_t, 2 * kSegmentsPerPlan> regs{};
  if (Error e = master_.read_holding_registers(unit_, reg::plan_base(plan), regs)) return e;
  Plan p{};
  for (unsigned k = 0; k < kSegmentsPerPlan; ++k) p[k] = Segment{regs[2 * k], regs[2 * k + 1]};
  return std::vector<Segment>(p.begin(), p.begin() + plan_length(p));
}

Error Client::write_plan(unsigned plan, std::span<const Segment> segments) {
  if (plan < 1 || plan > kPlanCount) return Errc::invalid_argument;
  if (Error e = validate_plan(segments)) return e;
  std::vector<uint16_t> regs;
  for (const Segment& s : segments) {
    regs.push_back(s.speed);
    regs.push_back(s.end);
  }
  if (segments.size() < kSegmentsPerPlan) {  // the end marker: end time 0 is not after the last one
    regs.push_back(0);
    regs.push_back(0);
  }
  return master_.write_multiple_registers(unit_, reg::plan_base(plan), regs);
}

Error Client::clear_plan(unsigned plan) {
  if (plan < 1 || plan > kPlanCount) return Errc::invalid_argument;
  const Plan factory = Settings::default_plans()[0];
  std::array<uint16_t, 2 * kSegmentsPerPlan> regs{};
  for (unsigned k = 0; k < kSegmentsPerPlan; ++k) {
    regs[2 * k] = factory[k].speed;
    regs[2 * k + 1] = factory[k].end;
  }
  return master_.write_multiple_registers(unit_, reg::plan_base(plan), regs);
}

Error Client::set_address(uint8_t address) {
  if (address < 1 || address > 254) return Errc::invalid_argument;
  if (Error e = master_.write_single_register(unit_, reg::kAddress, address)) return e;
  unit_ = UnitId{address};
  return {};
}

Error Client::set_baud(uint32_t baud) {
  const int code = code_of_baud(baud);
  if (code < 0) return Errc::invalid_argument;
  return master_.write_single_register(unit_, reg::kBaud, static_cast<uint16_t>(code));
}

Error Client::set_control_mask(uint16_t mask) {
  if (mask > 7) return Errc::invalid_argument;
  return master_.write_single_register(unit_, reg::kControlMask, mask);
}

Error Client::set_pairing(uint16_t mode) {
  if (mode > 2) return Errc::invalid_argument;
  return master_.write_single_register(unit_, reg::kPairing, mode);
}

}  // namespace rtukit::inverjet
