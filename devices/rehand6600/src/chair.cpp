// The Rehand 6600 controller model. Safety first: any doubt about motion
// (no host, a fault, an obstacle, a conflict) means the chair stops.
#include "rtukit/devices/rehand6600/chair.hpp"

#include <algorithm>
#include <cmath>

#include "rtukit/devices/rehand6600/motion.hpp"

namespace rtukit::rehand6600 {
namespace {

// Hold-type motion commands the watchdog and every safety stop reset (D-5, D-8).
constexpr uint16_t kWatchdogHolds[] = {reg::kStandSit,  reg::kSeatLift,     reg::kBackrest,
                                       reg::kSeatTilt,  reg::kLegRotate,    reg::kLegExtend,
                                       reg::kPlateTilt, reg::kPhoneForward, reg::kPhoneReverse,
                                       reg::kPhoneLeft, reg::kPhoneRight,   reg::kPhoneHorn};

// The combined motion codes of table 1 (the single ones are in motion.hpp).
constexpr uint16_t kFwdLeft = 6, kFwdRight = 7, kRevLeft = 8, kRevRight = 9;

uint16_t motion_of(int x, int y) {  // x, y in {-1, 0, 1}
  if (y > 0) return x < 0 ? kFwdLeft : x > 0 ? kFwdRight : kForward;
  if (y < 0) return x < 0 ? kRevLeft : x > 0 ? kRevRight : kReverse;
  return x < 0 ? kSpinLeft : x > 0 ? kSpinRight : kStatic;
}

}  // namespace

Chair::Chair(uint64_t now_ms, uint32_t watchdog_ms, const ChairModel& model) noexcept
    : Model(kProfile, words), model_(model), now_(now_ms), last_frame_(now_ms), watchdog_ms_(watchdog_ms) {}

// Table 1 as the controller shows it now.
void Chair::refresh(Space) noexcept {
  for (uint16_t a = 0; a < reg::kStatusCount; ++a) image().set(*find_register(a), status(a));
}

// ---------------------------------------------------------------- Modbus side

uint16_t Chair::status(uint16_t address) const noexcept {
  switch (address) {
    case reg::kDeviceId:
      return device_id_;
    case reg::kBattery:
      return static_cast<uint16_t>(std::clamp(std::floor(battery_), 0.0, 100.0));
    case reg::kCharging:
      return charging_;
    case reg::kSpeed:
      return static_cast<uint16_t>(std::lround(speed_));
    case reg::kClutch:
      return clutch_drive_;
    case reg::kMotion:
      return motion_;
    case reg::kJoystickX:
      return static_cast<uint16_t>(static_cast<int16_t>(joy_x_));
    case reg::kJoystickY:
      return static_cast<uint16_t>(static_cast<int16_t>(joy_y_));
    case reg::kMainLight:
      return main_light_;
    case reg::kLeftSignal:
      return left_signal_;
    case reg::kRightSignal:
      return right_signal_;
    case reg::kMotor1State:
    case reg::kMotor2State:
      return speed_ > 0 ? 1 : 0;
    case reg::kHornButton:
      return horn_button_;
    case reg::kViewButton:
      return view_button_;
    case reg::kSoftwareVersion:
      return model_.software_version;
    case reg::kErrorCode:
      return error_;
    default:
      break;
  }
  if (address >= reg::kDistanceFront && address < reg::kDistanceFront + 4)
    return distance_[address - reg::kDistanceFront];
  if (address >= reg::kSeatLiftStatus && address <= reg::kLegRestStatus)
    return posture_status_[address - reg::kSeatLiftStatus];
  if (address >= reg::kActuatorPosition && address < reg::kActuatorPosition + kActuators)
    return static_cast<uint16_t>(std::lround(position_[address - reg::kActuatorPosition]));
  if (address >= reg::kActuatorState && address < reg::kActuatorState + kActuators)
    return actuator_state_[address - reg::kActuatorState];
  return 0;  // joystick Z, reserved
}

bool Chair::phone_driving() const noexcept {
  for (uint16_t r = reg::kPhoneForward; r <= reg::kPhoneRight; ++r) {
    if (command(r)) return true;
  }
  return false;
}

// The map has checked the tables and the values (02, 03); the device's own
// rules are checked for the whole request before anything changes.
Error Chair::apply_write(Space, uint16_t address, std::span<const uint16_t> values) noexcept {
  for (size_t i = 0; i < values.size(); ++i) {
    const Row& r = *find_register(static_cast<uint16_t>(address + i));
    if (values[i] == 0) continue;  // releasing is always allowed
    if (r.has(kMotion) && error_ != 0)
      return Error(Errc::server_device_failure, "a local fault is active (D-6)");
    const bool phone_drive = r.address >= reg::kPhoneForward && r.address <= reg::kPhoneRight;
    if (phone_drive && (!joystick_neutral() || (local_control_ && speed_ > 0)))
      return Error(Errc::server_device_failure, "the local user has the chair");
    if (phone_drive && !seated())
      return Error(Errc::server_device_failure, "no phone driving while not fully seated (D-10)");
    if (phone_drive && (charging_ || !clutch_drive_))
      return Error(Errc::server_device_failure, "no driving while charging or in push (R-2)");
    const bool raising = (r.address == reg::kStandSit || r.address == reg::kSeatLift) && values[i] == 1;
    if (raising && charging_)
      return Error(Errc::server_device_failure, "no standing up or raising the seat while charging (D-11)");
  }
  for (size_t i = 0; i < values.size(); ++i) {
    const auto a = static_cast<uint16_t>(address + i);
    const bool rising = command(a) == 0 && values[i] != 0;
    set_command(a, values[i]);
    if (!rising) continue;
    // Pulse commands act on the rising edge only.
    switch (a) {
      case reg::kHostReady:  // a handshake: a deflected joystick must be neutral once (D-11)
        if (!joystick_neutral()) joystick_locked_ = true;
        break;
      case reg::kAntiPinch:  // an emergency stop of everything (D-8, D-9)
        safety_stop();
        break;
      case reg::kLight:
      case reg::kPhoneLight:
        main_light_ = !main_light_;
        break;
      case reg::kPhoneLeftSignal:
        left_signal_ = !left_signal_;
        if (left_signal_) right_signal_ = false;
        break;
      case reg::kPhoneRightSignal:
        right_signal_ = !right_signal_;
        if (right_signal_) left_signal_ = false;
        break;
      default:
        break;
    }
  }
  return Errc::ok;
}

// ---------------------------------------------------------------- physical side

void Chair::set_joystick(int x, int y) noexcept {
  joy_x_ = std::clamp(x, -100, 100);
  joy_y_ = std::clamp(y, -100, 100);
  // Local input overrides the phone at once.
  if (!joystick_neutral()) {
    for (uint16_t r = reg::kPhoneForward; r <= reg::kPhoneRight; ++r) set_command(r, 0);
  }
}

void Chair::press_button(uint16_t command, uint16_t value) noexcept {
  if (command < reg::kStandSit || command > reg::kPlateTilt || value > 2) return;
  button_command_ = value ? command : 0;
  button_value_ = value;
  // The button outranks the UI; the UI's postures do not come back when it
  // is released (D-8).
  if (value) {
    for (uint16_t r = reg::kStandSit; r <= reg::kPlateTilt; ++r) set_command(r, 0);
  }
}

void Chair::set_error(uint16_t code) noexcept {
  const bool raised = code != 0 && error_ == 0;
  error_ = code;
  if (raised) safety_stop();
}

void Chair::clear_motion_holds() noexcept {
  for (uint16_t r : kWatchdogHolds) set_command(r, 0);
}

void Chair::safety_stop() noexcept {
  clear_motion_holds();
  joystick_locked_ = !joystick_neutral();
  emergency_ = speed_ > 0;
  ++safety_stops_;
}

void Chair::set_distance(unsigned side, uint16_t mm) noexcept {
  if (side < distance_.size()) distance_[side] = mm;
}

void Chair::set_battery(double percent) noexcept {
  battery_ = std::clamp(percent, 0.0, 100.0);
}

void Chair::set_actuator_overcurrent(unsigned actuator, bool on) noexcept {
  if (actuator >= 1 && actuator <= kActuators) overcurrent_[actuator - 1] = on;
}

// ---------------------------------------------------------------- time

void Chair::advance_to(uint64_t now_ms) noexcept {
  while (now_ < now_ms) {
    // 50 ms slices, cut at the watchdog deadline so it trips at the exact time.
    uint64_t dt = std::min<uint64_t>(now_ms - now_, 50);
    if (watchdog_ms_ && last_frame_ + watchdog_ms_ > now_)
      dt = std::min<uint64_t>(dt, last_frame_ + watchdog_ms_ - now_);
    now_ += dt;
    step(static_cast<uint32_t>(dt));
  }
}

Chair::Drive Chair::drive_demand() const noexcept {
  if (!clutch_drive_ || charging_ || error_ != 0) return {};  // no driving (R-2, D-6, D-11)
  int x = 0, y = 0;
  const bool phone = joystick_neutral();
  if (!phone) {
    if (joystick_locked_) return {};  // not neutral since the last stop (D-8, D-11)
    x = joy_x_ <= -10 ? -1 : joy_x_ >= 10 ? 1 : 0;
    y = joy_y_ <= -10 ? -1 : joy_y_ >= 10 ? 1 : 0;
  } else {
    const bool f = command(reg::kPhoneForward), b = command(reg::kPhoneReverse);
    const bool l = command(reg::kPhoneLeft), r = command(reg::kPhoneRight);
    if ((f && b) || (l && r)) return {};  // contradicting commands: stop
    x = l ? -1 : r ? 1 : 0;
    y = f ? 1 : b ? -1 : 0;
  }
  const uint16_t motion = motion_of(x, y);
  if (motion == kStatic) return {};
  if (phone && !seated()) return {.blocked = true, .phone = true};  // D-10
  // Obstacles closer than the stop distance block motion towards them.
  if ((y > 0 && distance_[0] < model_.stop_distance_mm) || (y < 0 && distance_[1] < model_.stop_distance_mm))
    return {.blocked = true, .phone = phone};
  const uint16_t mode = command(reg::kDriveMode);
  const double factor = mode == 2 ? 0.6 : mode == 3 ? 1.2 : 1.0;  // indoor < normal < outdoor
  const double base = command(reg::kSpeedLevel) * 1.2 * factor;   // level 5 normal: 6 km/h
  double target = y > 0 ? base : y < 0 ? base / 2 : base / 3;
  if (!seated()) target = std::min(target, model_.raised_limit_kmh);  // D-10
  return {.motion = motion, .target = target, .phone = phone};
}

void Chair::step(uint32_t dt_ms) noexcept {
  const double dt = dt_ms / 1000.0;
  if (joystick_neutral()) joystick_locked_ = false;
  // A demand an obstacle (or D-10) refuses is a stop nobody asked for: it
  // does not resume when the obstacle goes (D-8).
  if (drive_demand().blocked) safety_stop();
  // Driving: a change of direction first brings the chair to a stop.
  const Drive d = drive_demand();
  double target = d.target;
  if (speed_ > 0 && d.motion != motion_) target = 0;
  if (speed_ <= 0) {
    motion_ = d.motion;
    local_control_ = d.motion != kStatic && !joystick_neutral();
  }
  if (emergency_) target = 0;
  if (speed_ < target)
    speed_ = std::min(target, speed_ + model_.accel_kmh_per_s * dt);
  else
    speed_ = std::max(target,
                      speed_ - (emergency_ ? model_.emergency_decel_kmh_per_s : model_.decel_kmh_per_s) * dt);
  if (speed_ <= 0) emergency_ = false;
  if (speed_ <= 0 && d.motion == kStatic) motion_ = kStatic;

  if (charging_)
    battery_ = std::min(100.0, battery_ + model_.charge_pct_per_s * dt);
  else if (speed_ > 0)
    battery_ = std::max(0.0, battery_ - model_.drain_pct_per_s * dt);

  move_actuators(dt);

  // D-5: no frame for the watchdog time -> every hold-type motion command off.
  if (watchdog_ms_ && now_ >= last_frame_ + watchdog_ms_) {
    bool held = false;
    for (uint16_t r : kWatchdogHolds) held = held || command(r) != 0;
    if (held) {
      ++watchdog_trips_;
      safety_stop();
    }
  }
}

void Chair::move_actuators(double dt) noexcept {
  std::array<int, kActuators> dir{};
  posture_status_ = {};
  actuator_state_ = {};
  struct Active {
    uint16_t command, value;
  };
  std::array<Active, 7> active{};
  size_t n = 0;
  // A physical button outranks every UI command while it is held.
  if (button_command_ != 0) {
    active[n++] = {button_command_, button_value_};
  } else {
    for (uint16_t r = reg::kStandSit; r <= reg::kPlateTilt; ++r) {
      if (command(r)) active[n++] = {r, command(r)};
    }
  }
  const bool blocked = command(reg::kAntiPinch) != 0 || error_ != 0;
  for (size_t i = 0; i < n && !blocked; ++i) {
    const int d = active[i].value == 1 ? 1 : -1;
    // D-11: while charging, standing up and raising the seat do not start
    // (lowering and sitting down stay allowed).
    if (charging_ && d > 0 && (active[i].command == reg::kStandSit || active[i].command == reg::kSeatLift)) {
      active[i].value = 0;
      continue;
    }
    for (uint8_t a : find_posture(active[i].command)->driven()) dir[a - 1] = d;
  }
  const double rate = 1000.0 / model_.full_stroke_s;
  std::array<bool, kActuators> moved{};
  for (unsigned a = 0; a < kActuators; ++a) {
    if (overcurrent_[a]) {
      actuator_state_[a] = kOverCurrent;
      continue;
    }
    if (dir[a] == 0) continue;
    const double before = position_[a];
    position_[a] = std::clamp(position_[a] + dir[a] * rate * dt, 0.0, 1000.0);
    moved[a] = position_[a] != before;
    // Pushed against a limit: that limit.
    actuator_state_[a] = moved[a] ? kActuatorMoving : dir[a] > 0 ? kUpperLimit : kLowerLimit;
  }
  // Posture status registers: what is moving, by the command that moves it.
  for (size_t i = 0; i < n && !blocked; ++i) {
    const Posture& p = *find_posture(active[i].command);
    if (p.status == 0) continue;  // the seat-plate tilt shows only in its actuator's state
    bool any = false;
    for (uint8_t a : p.driven()) any = any || moved[a - 1];
    if (any) posture_status_[p.status - reg::kSeatLiftStatus] = p.moving_status(active[i].value);
  }
}

}  // namespace rtukit::rehand6600
