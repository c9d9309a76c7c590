// The Rehand 6600 controller as a behaviour model: a pure step function over
// an injected clock (device milliseconds), no I/O, no threads.
//
// Modbus side: a profile::Model. The register map (registers.hpp) makes the
// tables strict (D-3: table 1 read-only, table 2 write-only, the gap and
// values not listed refused); table 2 lives in the model's Image, table 1 is
// put there before each read. This class adds the behaviour: the fault
// lock-out (D-6), the phone rules, pulses on the rising edge, the
// communication watchdog (D-5, D-5a: only a request the controller executes
// feeds it; when none came for `watchdog_ms`, every hold-type motion command
// is reset to 0 and the chair stops), and the safety rules:
//  - D-8: after a stop nobody asked for (watchdog trip, fault, anti-pinch,
//    obstacle, a physical button overriding a UI command) the hold-type
//    motion commands are cleared; motion needs a new rising edge, and the
//    joystick must be neutral once before the chair drives again;
//  - D-9: such a stop brakes at `emergency_decel_kmh_per_s` (8 km/h/s), a
//    release at `decel_kmh_per_s` (4 km/h/s);
//  - D-10: not fully seated -> at most `raised_limit_kmh`, no phone driving;
//  - D-11: after a handshake a deflected joystick must be neutral once;
//    while charging nothing drives, stands up or raises the seat.
//
// Physical side (the simulator's console, or a test): joystick, physical
// posture buttons (they outrank UI commands), charger, clutch, obstacle
// distances, battery, joystick buttons, error codes, actuator over-current.
//
// Decisions where the spec is silent are listed in docs/rehand6600.md (R-n).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/profile/model.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"

namespace rtukit::rehand6600 {

struct ChairModel {
  double full_stroke_s = 10.0;  ///< an actuator from 0 to 1000 per-mille
  double accel_kmh_per_s = 2.0;
  double decel_kmh_per_s = 4.0;            ///< a release (D-9)
  double emergency_decel_kmh_per_s = 8.0;  ///< watchdog, fault, anti-pinch, obstacle (D-9)
  double raised_limit_kmh = 1.2;           ///< not fully seated (D-10)
  double drain_pct_per_s = 0.05;           ///< battery while moving
  double charge_pct_per_s = 0.1;
  uint16_t stop_distance_mm = 300;     ///< an obstacle closer than this stops motion towards it
  uint16_t software_version = 0x0102;  ///< V1.2
};

class Chair final : private profile::ImageStorage<kMap.image_size()>, public profile::Model {
 public:
  static constexpr unsigned kActuators = 6;

  /// Power-on (D-7), at device time `now_ms`. `watchdog_ms` 0 disables D-5.
  explicit Chair(uint64_t now_ms = 0, uint32_t watchdog_ms = 500, const ChairModel& model = {}) noexcept;

  // ---- clock ----
  void advance_to(uint64_t now_ms) noexcept override;
  uint64_t now_ms() const noexcept { return now_; }

  // ---- Modbus side ----
  /// A request the controller executed (feeds the watchdog, D-5a). Requests
  /// answered with an exception, bad CRCs and other units' frames do not.
  void frame_received() noexcept { last_frame_ = now_; }
  using Model::read;
  using Model::write;
  /// FC03: table 1 only. Errors: 02 for table 2, the gap, or past 0x007F.
  Errc read(uint16_t address, std::span<uint16_t> out) { return read(Space::holding, address, out); }
  /// FC06/FC10: table 2 only. Errors: 02 (table 1, gap), 03 (value not
  /// listed), 04 (a motion command during a local fault, D-6; a phone drive
  /// command while the joystick is used or the chair moves under local
  /// control). All or nothing.
  Errc write(uint16_t address, std::span<const uint16_t> values) {
    return write(Space::holding, address, values);
  }
  /// As the bus sees them: only an executed request feeds the watchdog (D-5a).
  Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    const Errc e = read(address, out);
    if (e == Errc::ok) frame_received();
    return e;
  }
  Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    const Errc e = write(address, values);
    if (e == Errc::ok) frame_received();
    return e;
  }

  // ---- physical side ----
  /// Joystick deflection, -100..100 each (x: right positive, y: forward positive).
  void set_joystick(int x, int y) noexcept;
  /// A physical posture button: `command` is a posture register (0x0062..0x0068),
  /// `value` its direction (1/2), 0 releases. Outranks UI commands while held.
  void press_button(uint16_t command, uint16_t value) noexcept;
  void set_charging(bool on) noexcept { charging_ = on; }
  void set_clutch_drive(bool drive) noexcept { clutch_drive_ = drive; }
  void set_distance(unsigned side, uint16_t mm) noexcept;  ///< 0 front, 1 rear, 2 left, 3 right
  void set_battery(double percent) noexcept;
  /// A local fault (table 3), 0 clears it. Raising one is an emergency stop
  /// that clears every hold (D-8, D-9); clearing one moves nothing.
  void set_error(uint16_t code) noexcept;
  void set_actuator_overcurrent(unsigned actuator, bool on) noexcept;  ///< actuator 1..6
  void set_horn_button(bool on) noexcept { horn_button_ = on; }
  void set_view_button(bool on) noexcept { view_button_ = on; }
  /// The device ID register (0x68; another value simulates a wrong device).
  void set_device_id(uint16_t id) noexcept { device_id_ = id; }

  // ---- state ----
  /// A table-1 register's value (0x0000..0x002F).
  uint16_t status(uint16_t address) const noexcept;
  /// A table-2 register's value as last written (or reset by the watchdog).
  uint16_t command(uint16_t address) const noexcept {
    return image().words()[kCommandSlot + address - reg::kCommandFirst];
  }
  double speed_kmh() const noexcept { return speed_; }
  double actuator(unsigned i) const noexcept { return position_[i - 1]; }  ///< 1..6, per-mille
  /// Times the watchdog has reset the motion commands.
  unsigned watchdog_trips() const noexcept { return watchdog_trips_; }
  /// Stops nobody asked for (D-8), watchdog trips included.
  unsigned safety_stops() const noexcept { return safety_stops_; }
  /// The joystick is locked until it has been neutral once (D-8, D-11).
  bool joystick_locked() const noexcept { return joystick_locked_; }
  /// Braking at the emergency rate until the chair stands (D-9).
  bool emergency_braking() const noexcept { return emergency_; }
  /// Seat lift, whole-seat tilt (and so stand/sit) at their seated end (D-10).
  bool seated() const noexcept { return position_[0] < 1.0 && position_[2] < 1.0; }

 protected:
  void refresh(Space space) noexcept override;
  Error apply_write(Space space, uint16_t address, std::span<const uint16_t> values) noexcept override;

 private:
  // Table 2 is one row per register, in address order: its image slots are consecutive.
  static constexpr size_t kCommandSlot = kMap.slot_of(*find_register(reg::kCommandFirst));
  static_assert(kMap.slot_of(*find_register(reg::kCommandFirst + reg::kCommandCount - 1)) ==
                kCommandSlot + reg::kCommandCount - 1);
  void set_command(uint16_t address, uint16_t value) noexcept {
    image().words()[kCommandSlot + address - reg::kCommandFirst] = value;
  }
  struct Drive {
    uint16_t motion = 1;   ///< table 1 motion code
    double target = 0;     ///< km/h
    bool blocked = false;  ///< an obstacle stopped a demand (D-8)
    bool phone = false;    ///< the demand comes from the phone
  };
  /// A stop nobody asked for: every hold-type motion command cleared, the
  /// joystick locked until neutral, emergency braking (D-8, D-9).
  void safety_stop() noexcept;
  void clear_motion_holds() noexcept;
  Drive drive_demand() const noexcept;
  void step(uint32_t dt_ms) noexcept;
  void move_actuators(double dt) noexcept;
  bool joystick_neutral() const noexcept {
    return joy_x_ > -10 && joy_x_ < 10 && joy_y_ > -10 && joy_y_ < 10;
  }
  bool phone_driving() const noexcept;

  ChairModel model_;
  uint64_t now_ = 0;
  uint64_t last_frame_ = 0;
  uint32_t watchdog_ms_;
  unsigned watchdog_trips_ = 0;
  unsigned safety_stops_ = 0;
  bool joystick_locked_ = false;  ///< D-8, D-11 (neutral at power-on, D-7)
  bool emergency_ = false;        ///< D-9

  int joy_x_ = 0, joy_y_ = 0;
  uint16_t button_command_ = 0, button_value_ = 0;
  bool charging_ = false;
  bool clutch_drive_ = true;
  std::array<uint16_t, 4> distance_{2000, 2000, 2000, 2000};
  double battery_ = 80;
  uint16_t error_ = 0;
  bool horn_button_ = false, view_button_ = false;
  uint16_t device_id_ = kDeviceId;

  bool main_light_ = false, left_signal_ = false, right_signal_ = false;
  double speed_ = 0;
  uint16_t motion_ = 1;
  bool local_control_ = false;  ///< the current motion comes from the joystick
  std::array<double, kActuators> position_{};
  std::array<uint16_t, kActuators> actuator_state_{};  ///< 0x001B..0x0020
  std::array<bool, kActuators> overcurrent_{};
  std::array<uint16_t, 5> posture_status_{};  ///< 0x0010..0x0014
};

}  // namespace rtukit::rehand6600
