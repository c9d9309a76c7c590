// The Inverjet behaviour model. Why things are as they are: the spec's D-n
// decisions, and the B-n decisions of docs/inverjet.md where the spec is silent.
#include "rtukit/devices/inverjet/machine.hpp"

#include <algorithm>
#include <cmath>

namespace rtukit::inverjet {

unsigned plan_length(const Plan& plan) noexcept {
  unsigned n = 0;
  uint16_t previous = 0;
  for (const Segment& s : plan) {
    if (s.end <= previous) break;
    previous = s.end;
    ++n;
  }
  return n;
}

Plan default_plan() noexcept {
  Plan p{};
  const Row& speed = kMap.row(reg::plan_speed(1));
  const Row& end = kMap.row(reg::plan_end(1));
  for (unsigned k = 0; k < kSegmentsPerPlan; ++k)
    p[k] = Segment{static_cast<uint16_t>(speed.default_of(k)), static_cast<uint16_t>(end.default_of(k))};
  return p;
}

// A write to the control registers 0x0021..0x0024, then what it means.
struct Machine::Control {
  std::optional<uint16_t> mode, state, speed, time;
  enum class Action : uint8_t { adjust, off, menu, start, resume, skip_delay, pause, end, fault_hold };
  Action action = Action::adjust;
  Family family = Family::none;
  Phase phase = Phase::off;
  uint16_t new_mode = 0;
};

Machine::Machine(uint64_t now_ms, const MotorModel& motor, const Versions& versions) noexcept
    : Model(kProfile, words),
      motor_(motor),
      versions_(versions),
      now_(now_ms),
      mosfet_c_(motor.ambient_c),
      motor_c_(motor.ambient_c),
      mains_v_(motor.mains_bus_v) {}

Plan Machine::plan(unsigned n) const noexcept {
  Plan p{};
  for (unsigned k = 0; k < kSegmentsPerPlan; ++k)
    p[k] = Segment{stored(reg::plan_speed(n), k), stored(reg::plan_end(n), k)};
  return p;
}

// ---------------------------------------------------------------- reads

// The live values the image shows: the state machine's registers and the
// input registers (versions, faults, the motor and thermal model).
void Machine::refresh(Space space) noexcept {
  profile::Image& im = image();
  if (space == Space::holding) {
    im.set(reg::pairing, pairing_);
    im.set(reg::work_mode, mode_);
    im.set(reg::state, state());
    im.set(reg::speed, speed_);
    im.set(reg::run_time, time_s_);
    return;
  }
  const auto clamp16 = [](double v) { return std::clamp(std::lround(v), 0L, 0xFFFFL); };
  im.set(reg::display_software, versions_.display_software);
  im.set(reg::display_hardware, versions_.display_hardware);
  im.set(reg::driver_software, versions_.driver_software);
  im.set(reg::driver_hardware, versions_.driver_hardware);
  im.set(reg::faults, faults());
  im.set(reg::mosfet_temperature, clamp16(mosfet_c_ * 10));
  im.set(reg::motor_temperature, clamp16(motor_c_ * 10));
  im.set(reg::motor_current, std::lround(motor_current() * 100));
  im.set(reg::motor_speed, std::lround(motor_pct_ / 100.0 * motor_.full_speed_rpm * stored(reg::pole_count)));
  im.set(reg::bus_voltage, clamp16(bus_voltage() * 10));
}

double Machine::motor_current() const noexcept {
  if (motor_pct_ <= 0) return 0;
  const double p = motor_pct_ / 100.0;
  return motor_.idle_current_a + (motor_.full_current_a - motor_.idle_current_a) * p * p;
}

double Machine::bus_voltage() const noexcept {
  return mains_v_ - motor_.bus_sag_v_per_a * motor_current();
}

// ---------------------------------------------------------------- writes

// The map has checked every address and value (02, 03); what is left is
// behaviour, decided in full before anything changes (all or nothing).
Error Machine::apply_write(Space space, uint16_t address, std::span<const uint16_t> values) noexcept {
  Control c;
  bool masked = false;
  const auto written = [&](profile::Handle h) -> std::optional<uint16_t> {
    const uint16_t a = reg::at(h);
    if (a < address || a >= address + values.size()) return std::nullopt;
    return values[a - address];
  };
  for (size_t i = 0; i < values.size(); ++i)
    masked = masked || kMap.at(space, static_cast<uint16_t>(address + i)).row->has(kMasked);
  if (masked && (stored(reg::control_mask) & 0x2))
    return Error(Errc::server_device_failure, "control is masked (control mask bit 1, D-5)");
  c.mode = written(reg::work_mode);
  c.state = written(reg::state);
  c.speed = written(reg::speed);
  c.time = written(reg::run_time);
  const bool has_control = c.mode || c.state || c.speed || c.time;
  if (has_control) {
    if (Errc e = plan_control(c, &c); e != Errc::ok) return e;
  }

  // Apply: stored registers take the values; the rest is behaviour.
  if (const auto p = written(reg::pairing)) {  // D-6
    pairing_ = *p;
    pairing_until_ = *p ? now_ + kPairingWindowMs : 0;
  }
  image().write(space, address, values);
  if (has_control) apply_control(c);
  // B-17: the running plan rewritten takes effect at once (its segment and
  // speed now, its end if the time is already past it), never a second
  // later with a segment the plan no longer has (found by the simulation).
  if (!has_control && family_ == Family::training && mode_ >= 1 && mode_ <= kPlanCount) {
    const size_t first = address, end = first + values.size();
    const size_t plan_first = reg::plan_base(mode_), plan_end = plan_first + 2 * size_t{kSegmentsPerPlan};
    if (first < plan_end && end > plan_first) update_plan_speed();
  }
  return Errc::ok;
}

// Decides what a control write means, without changing anything.
Errc Machine::plan_control(const Control& c, Control* out) const noexcept {
  Control r = c;
  r.new_mode = c.mode.value_or(mode_);
  if (phase_ == Phase::fault) {
    // Fault screen: nothing may start the motor; other writes are taken but
    // the screen stays until the faults clear (B-3).
    if (c.state) {
      const Phase p = phase_of(*c.state);
      if (p == Phase::initial || p == Phase::starting || p == Phase::running)
        return Errc::server_device_failure;
    }
    r.action = Control::Action::fault_hold;
    *out = r;
    return Errc::ok;
  }
  if (!c.state && !c.mode) {
    r.action = Control::Action::adjust;
    *out = r;
    return Errc::ok;
  }
  // D-10: the written (or current) state's phase applies to the mode's family.
  const uint16_t s = c.state ? *c.state : state();
  if (c.state && r.new_mode == 0 && family_of(s) == Family::training)
    return Errc::illegal_data_value;  // B-2: a training state needs a plan (mode 1..4)
  const Phase p = phase_of(s);
  const Family f = r.new_mode >= 1                 ? Family::training
                   : family_of(s) == Family::timer ? Family::timer
                                                   : Family::free;
  const bool same_run = active() && family_ == f && r.new_mode == mode_;
  r.family = f;
  r.phase = p;
  switch (p) {
    case Phase::off:
      r.action = Control::Action::off;
      break;
    case Phase::menu:
      r.action = Control::Action::menu;
      break;
    case Phase::initial:
      r.action = Control::Action::start;
      break;
    case Phase::starting:
    case Phase::running:
      if (same_run && phase_ == Phase::paused) {
        r.action = Control::Action::resume;
      } else if (same_run && phase_ == Phase::initial) {
        r.action = Control::Action::skip_delay;
      } else if (same_run) {
        r.action = Control::Action::adjust;
      } else {
        r.action = Control::Action::start;
        r.phase = Phase::starting;  // B-1: 2 and 3 both start now; the motor ramps in "starting"
      }
      break;
    case Phase::paused:
      if (!same_run) return Errc::server_device_failure;  // B-4: nothing of that family runs
      r.action = Control::Action::pause;
      break;
    case Phase::ended:
      r.action = Control::Action::end;
      break;
    case Phase::fault:
      return Errc::illegal_data_value;  // not writable (table)
  }
  *out = r;
  return Errc::ok;
}

void Machine::apply_control(const Control& c) noexcept {
  mode_ = c.new_mode;
  // Speed/time written with the state: time first (it may move a training run
  // to another segment), then speed (it overrides the segment it lands in).
  const auto adjust = [&] {
    if (c.time) {
      time_s_ = *c.time;
      second_ms_ = 0;
      if (family_ == Family::training) update_plan_speed();
    }
    if (c.speed) {
      speed_ = *c.speed;
      if (family_ == Family::training && active()) override_segment_ = static_cast<int>(segment_);
    }
    if (counting()) {
      if (family_ == Family::timer && time_s_ == 0) enter(Phase::ended);
    }
  };
  using A = Control::Action;
  switch (c.action) {
    case A::fault_hold:
      if (c.speed) speed_ = *c.speed;
      if (c.time) time_s_ = *c.time;
      break;
    case A::adjust:
      adjust();
      break;
    case A::off:
      enter(Phase::off);
      break;
    case A::menu:
      enter(Phase::menu);
      break;
    case A::start:
      start(c.family, c.phase, c);
      break;
    case A::resume:
      adjust();
      if (phase_ == Phase::paused) enter(Phase::starting);
      break;
    case A::skip_delay:
      adjust();
      if (phase_ == Phase::initial) enter(Phase::starting);
      break;
    case A::pause:
      adjust();
      if (active()) enter(Phase::paused);
      break;
    case A::end:
      family_ = c.family;
      adjust();
      enter(Phase::ended);
      break;
  }
  // Flash memory rule (seed 3.2.3.4): mode 0, state initial after the write,
  // and the write carried speed/time -> they become that mode's memory.
  if (mode_ == 0 && phase_ == Phase::initial && (c.speed || c.time)) {
    const bool timer = family_ == Family::timer;
    if (family_ == Family::free || timer) {
      if (c.speed) image().set(timer ? reg::timer_speed : reg::free_speed, *c.speed);
      if (c.time) image().set(timer ? reg::timer_time : reg::free_time, *c.time);
    }
  }
}

void Machine::start(Family family, Phase phase, const Control& c) noexcept {
  family_ = family;
  initial_ms_ = 0;
  second_ms_ = 0;
  override_segment_ = -1;
  switch (family) {
    case Family::timer:
      time_s_ = c.time.value_or(stored(reg::timer_time));
      speed_ = c.speed.value_or(stored(reg::timer_speed));
      break;
    case Family::training:
      time_s_ = c.time.value_or(0);  // "start P1 at 12:00"
      segment_ = 0;
      phase_ = phase;
      update_plan_speed();
      if (c.speed) {
        speed_ = *c.speed;
        override_segment_ = static_cast<int>(segment_);
      }
      break;
    default:
      time_s_ = c.time.value_or(stored(reg::free_time));
      speed_ = c.speed.value_or(stored(reg::free_speed));
      break;
  }
  enter(phase);
}

void Machine::enter(Phase phase) noexcept {
  phase_ = phase;
  switch (phase) {
    case Phase::off:
    case Phase::menu:
      family_ = Family::none;
      speed_ = 0;
      time_s_ = 0;
      segment_ = 0;
      override_segment_ = -1;
      break;
    case Phase::initial:
      initial_ms_ = 0;
      break;
    case Phase::starting:
      // A run with nothing left to do ends at once.
      if (family_ == Family::timer && time_s_ == 0) phase_ = Phase::ended;
      if (family_ == Family::training) update_plan_speed();
      break;
    default:
      break;
  }
}

// Training: the segment whose end time has not passed decides the speed.
void Machine::update_plan_speed() noexcept {
  if (mode_ < 1 || mode_ > kPlanCount) return;
  const Plan current = plan(mode_);
  const unsigned length = plan_length(current);
  unsigned seg = 0;
  while (seg < length && current[seg].end <= time_s_) ++seg;
  if (seg != segment_) {
    segment_ = seg;
    override_segment_ = -1;
  }
  if (seg >= length) {
    if (phase_ == Phase::starting || phase_ == Phase::running) phase_ = Phase::ended;
    return;
  }
  if (override_segment_ != static_cast<int>(seg)) speed_ = current[seg].speed;
}

// ---------------------------------------------------------------- time

void Machine::advance_to(uint64_t now_ms) noexcept {
  while (now_ < now_ms) {
    // Slices end at every event (end of the initial delay, a run-time second,
    // a pairing window) so events happen at exact device times; at most
    // 100 ms so the motor and thermal model integrate smoothly.
    uint64_t dt = std::min<uint64_t>(now_ms - now_, 100);
    if (phase_ == Phase::initial) dt = std::min<uint64_t>(dt, kInitialDelayMs - initial_ms_);
    if (counting()) dt = std::min<uint64_t>(dt, 1000 - second_ms_);
    if (pairing_ && pairing_until_ > now_) dt = std::min<uint64_t>(dt, pairing_until_ - now_);
    dt = std::max<uint64_t>(dt, 1);
    now_ += dt;
    step(static_cast<uint32_t>(dt));
  }
}

void Machine::step(uint32_t dt_ms) noexcept {
  if (phase_ == Phase::initial) {
    initial_ms_ += dt_ms;
    if (initial_ms_ >= kInitialDelayMs) {
      second_ms_ = 0;
      enter(Phase::starting);
    }
  } else if (counting()) {
    second_ms_ += dt_ms;
    if (second_ms_ >= 1000) {
      second_ms_ -= 1000;
      on_second();
    }
  }
  if (pairing_ && now_ >= pairing_until_) pairing_ = 0;

  // Motor: ramps towards the set speed while a run counts, else coasts to 0.
  const double dt = dt_ms / 1000.0;
  const double target = counting() ? speed_ : 0.0;
  if (motor_pct_ < target)
    motor_pct_ = std::min(target, motor_pct_ + motor_.ramp_up_pct_per_s * dt);
  else
    motor_pct_ = std::max(target, motor_pct_ - motor_.ramp_down_pct_per_s * dt);
  if (phase_ == Phase::starting && motor_pct_ >= speed_) phase_ = Phase::running;

  // Temperatures: first-order lag towards an equilibrium set by the current.
  const double amps = motor_current();
  mosfet_c_ += (motor_.ambient_c + motor_.mosfet_c_per_a * amps - mosfet_c_) *
               (1 - std::exp(-dt / motor_.mosfet_tau_s));
  motor_c_ +=
      (motor_.ambient_c + motor_.motor_c_per_a * amps - motor_c_) * (1 - std::exp(-dt / motor_.motor_tau_s));
  update_faults();
}

void Machine::on_second() noexcept {
  switch (family_) {
    case Family::timer:
      if (time_s_ > 0) --time_s_;
      if (time_s_ == 0) enter(Phase::ended);
      break;
    case Family::training:
      if (time_s_ < kMaxTime) ++time_s_;
      update_plan_speed();
      break;
    default:
      if (time_s_ < kMaxTime) ++time_s_;  // B-5: free mode holds at 99:59 and keeps running
      break;
  }
}

// ---------------------------------------------------------------- physical side

void Machine::update_faults() noexcept {
  uint16_t derived = derived_faults_;
  if (mosfet_c_ >= motor_.mosfet_trip_c) derived |= kFaultMosfetTemperature;
  if (mosfet_c_ < motor_.mosfet_reset_c) derived &= static_cast<uint16_t>(~kFaultMosfetTemperature);
  const double bus = bus_voltage();
  if (bus < motor_.bus_min_v || bus > motor_.bus_max_v)
    derived |= kFaultVoltage;
  else
    derived &= static_cast<uint16_t>(~kFaultVoltage);
  derived_faults_ = derived;
  if (faults() != 0 && phase_ != Phase::fault) {
    phase_ = Phase::fault;  // the motor target becomes 0 (not counting)
  } else if (faults() == 0 && phase_ == Phase::fault) {
    mode_ = 0;
    enter(Phase::off);  // B-3: cleared faults leave the machine off
  }
}

void Machine::set_injected_faults(uint16_t bits) noexcept {
  injected_faults_ = bits & kFaultDefinedBits;
  update_faults();
}

void Machine::set_mosfet_temperature(double celsius) noexcept {
  mosfet_c_ = celsius;
  update_faults();
}

void Machine::set_motor_temperature(double celsius) noexcept {
  motor_c_ = celsius;
  update_faults();
}

void Machine::set_mains_voltage(double volts) noexcept {
  mains_v_ = volts;
  update_faults();
}

}  // namespace rtukit::inverjet

namespace rtukit::inverjet {

std::string_view Machine::device_object(uint8_t id) {
  refresh(profile::Space::input);  // the versions live in the input registers
  const auto version = [this](profile::Handle h) {
    // "V1.2" from the version register pair (major in the high word).
    const auto raw = static_cast<uint32_t>(image().get(h));
    const auto put = [](char* p, uint32_t v) {
      char digits[10];
      size_t n = 0;
      do {
        digits[n++] = static_cast<char>('0' + v % 10);
        v /= 10;
      } while (v);
      for (size_t i = 0; i < n; ++i) p[i] = digits[n - 1 - i];
      return n;
    };
    size_t at = 0;
    object_text_[at++] = 'V';
    at += put(&object_text_[at], raw >> 16);
    object_text_[at++] = '.';
    at += put(&object_text_[at], raw & 0xFFFF);
    return std::string_view(object_text_.data(), at);
  };
  switch (id) {
    case 2:
    case 0x80:
      return version(reg::display_software);
    case 0x81:
      return version(reg::display_hardware);
    case 0x82:
      return version(reg::driver_software);
    case 0x83:
      return version(reg::driver_hardware);
    default:
      return Model::device_object(id);
  }
}

}  // namespace rtukit::inverjet
