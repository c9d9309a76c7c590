// The simulated Rehand 6600 controller on a real link: the chair model
// (chair.hpp) served by the slave engine, device time = real time x
// time_scale, and a console (`command`) for the physical side: joystick,
// physical buttons, charger, clutch, distances, battery, faults.
//
// Everything runs on the io_context's thread; call `command` from there.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "rtukit/core/slave.hpp"
#include "rtukit/devices/rehand6600/chair.hpp"
#include "rtukit/driver/simulation.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/port.hpp"

namespace asio {
class io_context;
}

namespace rtukit::rehand6600 {

/// The chair as a RegisterBank: every request advances the model to the
/// clock's device time and feeds the watchdog (a valid frame for us).
class ChairBank final : public RegisterBank {
 public:
  using Clock = std::function<uint64_t()>;  ///< device time, ms
  ChairBank(Chair& chair, Clock clock) : chair_(chair), clock_(std::move(clock)) {}
  Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    chair_.advance_to(clock_());
    chair_.frame_received();
    return chair_.read(address, out);
  }
  Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    chair_.advance_to(clock_());
    chair_.frame_received();
    return chair_.write(address, values);
  }

 private:
  Chair& chair_;
  Clock clock_;
};

struct SimulatorOptions {
  io::PortSpec listen;  ///< listening form
  uint8_t unit = kDefaultAddress;
  uint32_t watchdog_ms = 500;  ///< D-5; 0 disables
  double time_scale = 1.0;
  RequestLog log;
};

class Simulator {
 public:
  /// Errors: invalid_argument or io_error, with the reason in `why`.
  static Result<std::unique_ptr<Simulator>> start(asio::io_context& ctx, SimulatorOptions options,
                                                  std::string* why);
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  std::string where() const;
  uint64_t device_ms() const { return clock_.now_ms(); }
  Chair& chair();  ///< advanced to now

  /// One console line -> its reply. Commands: help, status, joystick X Y,
  /// button POSTURE up|down|stand|sit|release, charger on|off, clutch
  /// push|drive, distance front|rear|left|right MM, battery PCT, error
  /// CODE|clear, overcurrent N on|off, horn on|off, view on|off, id 0xNN, quit.
  std::string command(std::string_view line);
  bool quit_requested() const noexcept { return quit_; }
  std::string status_text();

 private:
  explicit Simulator(SimulatorOptions options);

  SimulatorOptions options_;
  DeviceClock clock_;
  Chair chair_;
  std::unique_ptr<ChairBank> bank_;
  SlaveEngine engine_;
  std::unique_ptr<SlaveListener> listener_;
  std::unique_ptr<PeriodicTimer> ticker_;
  bool quit_ = false;
};

}  // namespace rtukit::rehand6600
