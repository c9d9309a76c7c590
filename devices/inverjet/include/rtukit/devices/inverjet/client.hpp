// The typed master API for the Inverjet (host side). Wraps an rtukit::Master:
// each call is one or two Modbus transactions, and every failure comes back
// as a Status value (the error and its reason):
//  - a Modbus exception the machine answered (is_exception(): 02 reserved
//    address, 03 value out of range, 04 with the Inverjet's reason for it:
//    control masked, the fault screen, or nothing to pause),
//  - timeout / io_error / not_connected from the link,
//  - invalid_argument when the call's own arguments are wrong, checked
//    against the register table before anything is sent, so nothing is
//    half-applied ("speed: 120 is outside 0..100 %").
// Values are decoded through the register table (scales, word order): the
// client restates none of them.
//
//   rtukit::Master master(rtukit::io::make_link(spec));
//   rtukit::inverjet::Client jet(master);            // unit 21
//   if (rtukit::Status s = jet.start_timer(80, 30 * 60)) { ... s.reason() ... }
//   auto s = jet.status();  // s->state_name(), s->run_time, s->fault_names()
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/driver/master.hpp"

namespace rtukit::inverjet {

/// How the client's refusals begin, so the device layer can say which kind
/// a failure is (verbs.hpp, classify_failure) without a second copy of them:
/// the three causes of exception 04 (Client::explain) and a resume with
/// nothing paused.
inline constexpr std::string_view kFaultScreenReason = "the machine shows a fault";
inline constexpr std::string_view kMaskedReason = "Modbus control is masked";
inline constexpr std::string_view kWrongStateReason = "not possible while";
inline constexpr std::string_view kNothingPausedReason = "nothing is paused";

struct MachineStatus {
  uint16_t mode = 0;      ///< 0 free & timer, 1..4 plan P1..P4
  uint16_t state = 0;     ///< 0..17
  uint16_t speed = 0;     ///< set speed, %
  uint16_t run_time = 0;  ///< s; counts down in timer mode
  uint16_t faults = 0;    ///< input register 0x0008
  double mosfet_c = 0;
  double motor_c = 0;
  double current_a = 0;
  uint32_t rpm = 0;  ///< mechanical rpm (register value / pole count)
  uint32_t rpm_x_poles = 0;
  double bus_v = 0;
  uint32_t display_software = 0, display_hardware = 0, driver_software = 0, driver_hardware = 0;

  Phase phase() const noexcept { return phase_of(state); }
  Family family() const noexcept { return family_of(state); }
  /// "timer running", "fault screen", ...
  std::string_view state_name() const noexcept;
  /// Names of the fault bits set ("voltage", "motor drive"); empty when none.
  std::vector<std::string_view> fault_names() const;
};

/// The configuration: every holding register whose role is `setting`
/// (address, baud, control mask, pairing, pole count, free/timer memory), in
/// table order, with its raw value.
struct ConfigValue {
  const Row* row;
  int64_t raw;
};
using Config = std::vector<ConfigValue>;

/// Checks a plan for write_plan: 1..50 segments, speeds and end times within
/// the plan rows' ranges, end times strictly increasing. Errors:
/// invalid_argument naming the segment ("segment 3: end 00:50 is not after 01:00").
rtukit::Status validate_plan(std::span<const Segment> segments);

class Client {
 public:
  /// `master` must outlive the client. Units 1..254 (the Inverjet's range).
  explicit Client(Master& master, UnitId unit = UnitId{kDefaultAddress}) noexcept
      : master_(master), unit_(unit) {}

  UnitId unit() const noexcept { return unit_; }

  /// Mode, state, speed, time (FC03 0x0021 x4) and the input registers (FC04 0x0000 x17).
  Result<MachineStatus> status();
  Result<Config> config();

  /// Free mode at `speed` % (0..100), counting up from the free-mode memory
  /// time. `remember`: start through "initial" (3 s delay) so the machine
  /// saves the speed as free-mode memory (seed 3.2.3.4); else start now.
  rtukit::Status start_free(uint16_t speed, bool remember = false);
  /// Free mode with the speed and time in the machine's memory.
  rtukit::Status start_free_from_memory();
  /// Timer mode: `duration_s` (1..5999) counting down at `speed` %.
  rtukit::Status start_timer(uint16_t speed, uint16_t duration_s, bool remember = false);
  /// Training plan `plan` (1..4) from `from_s` into the plan (0..5999); the
  /// plan decides the speed. Errors: invalid_argument when the plan is empty
  /// or `from_s` is at or after its end (nothing would run).
  rtukit::Status start_plan(unsigned plan, uint16_t from_s = 0);
  /// Pauses the run (any family). The machine answers 04 when nothing runs.
  rtukit::Status pause();
  /// Resumes a paused run. invalid_argument when nothing is paused.
  rtukit::Status resume();
  /// Stops the motor and turns the machine off (state 0).
  rtukit::Status stop();
  /// The running speed, 0..100 %.
  rtukit::Status set_speed(uint16_t speed);

  /// The plan's valid segments (up to the first non-increasing end time).
  Outcome<std::vector<Segment>> read_plan(unsigned plan);
  /// Writes `segments` (validate_plan) plus a terminating 0/0 segment when
  /// fewer than 50, in one FC10 (at most 100 registers: within the 123 limit).
  rtukit::Status write_plan(unsigned plan, std::span<const Segment> segments);
  /// Back to the factory plan (one minute at 20 %, D-11), all 50 segments.
  rtukit::Status clear_plan(unsigned plan);

  /// New slave address 1..254. The machine answers from the old address,
  /// then moves; on success this client follows it.
  rtukit::Status set_address(uint8_t address);
  /// New baud rate (1200, 2400, 4800, 9600, 19200). The machine switches after
  /// answering; the caller must reopen its link at the new rate.
  rtukit::Status set_baud(uint32_t baud);
  /// Control mask 0..7 (bit0 Bluetooth, bit1 Modbus-RS485, bit2 Wi-Fi).
  rtukit::Status set_control_mask(uint16_t mask);
  /// Pairing window: 0 none, 1 Wi-Fi, 2 remote control (closes after 60 s).
  rtukit::Status set_pairing(uint16_t mode);

 private:
  rtukit::Status write(uint16_t address, std::span<const uint16_t> values);
  /// A failed request, with the Inverjet's reason for an exception 04 (one more look says which).
  rtukit::Status explain(Error e);
  Master& master_;
  UnitId unit_;
};

}  // namespace rtukit::inverjet
