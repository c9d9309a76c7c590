// The Inverjet behaviour model: what the machine does, as a pure step
// function over an injected clock. No I/O, no threads, no wall clock: the
// simulator (or a test) passes device time in milliseconds, so a 30-minute
// timer run is tested in microseconds of real time.
//
// Modbus side: a profile::Model. The register map (registers.hpp) decides
// which addresses exist and which values a row accepts (02, 03, all or
// nothing); the stored registers (settings, memories, plans) live in the
// model's Image; this class adds only behaviour: the state machine, the
// control mask (04), the flash rule, the pairing window, link changes, the
// motor and thermal model. Physical side: faults, temperatures and mains
// voltage are injected by the simulator's console.
//
// Decisions the spec left open are listed in docs/inverjet.md ("Behaviour
// decisions"); the code below cites them as B-n.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/profile/model.hpp"

namespace rtukit::inverjet {

struct Segment {
  uint16_t speed = 0;  ///< percent
  uint16_t end = 0;    ///< seconds since the plan's start
  friend bool operator==(const Segment&, const Segment&) = default;
};
using Plan = std::array<Segment, kSegmentsPerPlan>;

/// Number of segments that run: the list ends at the first end time that is
/// not greater than the previous one (the first must be > 0), or after 50.
unsigned plan_length(const Plan& plan) noexcept;
/// A plan as the table's defaults make it (D-11: one minute at 20 %).
Plan default_plan() noexcept;

/// Motor and thermal constants. Defaults make a plausible 3 kW pump.
struct MotorModel {
  double full_speed_rpm = 3000;     ///< mechanical rpm at 100 %
  double ramp_up_pct_per_s = 20;    ///< 0 -> 100 % in 5 s
  double ramp_down_pct_per_s = 50;  ///< coasting stop
  double idle_current_a = 0.4;      ///< while turning
  double full_current_a = 12.0;     ///< at 100 % (pump load grows with speed squared)
  double ambient_c = 25.0;
  double mosfet_c_per_a = 4.5;  ///< MOSFET equilibrium rise per amp
  double mosfet_tau_s = 60;
  double motor_c_per_a = 1.5;  ///< water-cooled motor
  double motor_tau_s = 300;
  double mains_bus_v = 311.0;  ///< rectified 220 V
  double bus_sag_v_per_a = 0.6;
  double mosfet_trip_c = 90.0;   ///< sets fault bit 3 ...
  double mosfet_reset_c = 80.0;  ///< ... cleared below this
  double bus_min_v = 260.0;      ///< outside: fault bit 0
  double bus_max_v = 360.0;
};

/// Versions reported in input registers 0x0000..0x0007.
struct Versions {
  uint32_t display_software = 0x00010002;  ///< V1.2, the seed's example
  uint32_t display_hardware = 0x00010000;
  uint32_t driver_software = 0x00010003;
  uint32_t driver_hardware = 0x00010000;
};

class Machine final : private profile::ImageStorage<kMap.image_size()>, public profile::Model {
 public:
  static constexpr uint32_t kInitialDelayMs = 3000;
  static constexpr uint32_t kPairingWindowMs = 60000;

  /// Power-on (D-12): off, mode 0, speed 0, time 0, at device time `now_ms`,
  /// every stored register at its default (load a state file into image()).
  explicit Machine(uint64_t now_ms = 0, const MotorModel& motor = {}, const Versions& versions = {}) noexcept;

  // ---- clock ----
  /// Runs the model up to `now_ms` (device time). Earlier times are ignored.
  void advance_to(uint64_t now_ms) noexcept override;
  uint64_t now_ms() const noexcept { return now_; }

  // ---- Modbus side (RegisterBank semantics: all or nothing) ----
  /// FC03. Errors: illegal_data_address for any reserved address in the range.
  Errc read_holding(uint16_t address, std::span<uint16_t> out) { return read(Space::holding, address, out); }
  /// FC04. Errors: illegal_data_address past 0x0010.
  Errc read_input(uint16_t address, std::span<uint16_t> out) { return read(Space::input, address, out); }
  /// FC06/FC10 at the current device time. Errors: 02 reserved address,
  /// 03 value out of range (or state 17, pole count other than 5, a training
  /// state with no plan selected), 04 control masked (D-5), start while
  /// faulted, pause when nothing runs. Nothing changes unless it returns ok.
  Errc write_holding(uint16_t address, std::span<const uint16_t> values) {
    return write(Space::holding, address, values);
  }

  // ---- physical side (console) ----
  /// Fault bits injected from outside (0 clears them). Bits 9..15 are ignored.
  void set_injected_faults(uint16_t bits) noexcept;
  uint16_t injected_faults() const noexcept { return injected_faults_; }
  void set_mosfet_temperature(double celsius) noexcept;
  void set_motor_temperature(double celsius) noexcept;
  /// Mains (unloaded DC bus) voltage.
  void set_mains_voltage(double volts) noexcept;

  // ---- what the registers show ----
  uint16_t mode() const noexcept { return mode_; }
  uint16_t state() const noexcept {
    return state_value(phase_ == Phase::fault ? Family::none : family_, phase_);
  }
  Phase phase() const noexcept { return phase_; }
  Family family() const noexcept { return family_; }
  uint16_t speed() const noexcept { return speed_; }
  uint16_t run_time() const noexcept { return time_s_; }
  uint16_t faults() const noexcept { return static_cast<uint16_t>(injected_faults_ | derived_faults_); }
  uint16_t pairing() const noexcept { return pairing_; }
  double motor_percent() const noexcept { return motor_pct_; }
  double motor_current() const noexcept;
  double mosfet_temperature() const noexcept { return mosfet_c_; }
  double motor_temperature() const noexcept { return motor_c_; }
  double bus_voltage() const noexcept;
  /// Segment (0-based) the training run is in; meaningful in the training family.
  unsigned segment() const noexcept { return segment_; }
  /// A stored register (setting, memory, plan entry), as the image holds it.
  uint16_t stored(profile::Handle h, unsigned index = 0) const noexcept { return image().u16(h, index); }
  /// Training plan `n` (1..4) as the image holds it.
  Plan plan(unsigned n) const noexcept;

  // The address and baud rate (0x0000, 0x0001) are link rows: the kit's
  // Model applies them after the response (take_link_change, stored_link).

 protected:
  void refresh(Space space) noexcept override;
  Error apply_write(Space space, uint16_t address, std::span<const uint16_t> values) noexcept override;

  /// Identification (FC2B/0E) from the profile, plus the board versions of
  /// the input registers: 0x80 display software, 0x81 display hardware, 0x82
  /// driver software, 0x83 driver hardware ("V1.2"); object 2, the revision,
  /// is the display software's (the board that speaks Modbus).
  std::string_view device_object(uint8_t id) override;

 private:
  struct Control;  // a decoded write to 0x0021..0x0024
  std::array<char, 16> object_text_{};
  Errc plan_control(const Control& c, Control* resolved) const noexcept;
  void apply_control(const Control& c) noexcept;
  void start(Family family, Phase phase, const Control& c) noexcept;
  void enter(Phase phase) noexcept;
  void step(uint32_t dt_ms) noexcept;
  void on_second() noexcept;
  void update_plan_speed() noexcept;
  void update_faults() noexcept;
  bool counting() const noexcept { return phase_ == Phase::starting || phase_ == Phase::running; }
  bool active() const noexcept {
    return phase_ == Phase::initial || phase_ == Phase::starting || phase_ == Phase::running ||
           phase_ == Phase::paused;
  }

  MotorModel motor_;
  Versions versions_;
  uint64_t now_ = 0;

  uint16_t mode_ = 0;
  Phase phase_ = Phase::off;
  Family family_ = Family::none;
  uint16_t speed_ = 0;         ///< register 0x0023: the set speed
  uint16_t time_s_ = 0;        ///< register 0x0024
  uint32_t second_ms_ = 0;     ///< run time within the current second
  uint32_t initial_ms_ = 0;    ///< time spent in `initial`
  unsigned segment_ = 0;       ///< training: current segment
  int override_segment_ = -1;  ///< training: a written speed holds until this segment ends

  uint16_t pairing_ = 0;
  uint64_t pairing_until_ = 0;

  uint16_t injected_faults_ = 0;
  uint16_t derived_faults_ = 0;
  double motor_pct_ = 0;
  double mosfet_c_;
  double motor_c_;
  double mains_v_;
};

}  // namespace rtukit::inverjet
