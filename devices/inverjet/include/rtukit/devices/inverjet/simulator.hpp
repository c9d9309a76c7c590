// The simulated Inverjet on a real link: the behaviour model (machine.hpp)
// served by the slave engine on a pty, serial port or TCP, with
//  - device time = real time x time_scale (a 30-minute run in 30 s at 60),
//  - the new address and baud rate applied after the response to the write,
//  - persisted settings saved to the state file after each change,
//  - a console (`command`) to inject faults, set temperatures, print status.
//
// Everything runs on the io_context's thread: call `command` from there
// (asio::post) when another thread reads the console.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "rtukit/core/slave.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/driver/simulation.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/port.hpp"

namespace asio {
class io_context;
}

namespace rtukit::inverjet {

/// The machine as a RegisterBank: each request first advances the model to
/// the clock's device time. `after` runs once the response has been sent.
class MachineBank final : public RegisterBank {
 public:
  using Clock = std::function<uint64_t()>;  ///< device time, ms
  MachineBank(Machine& machine, Clock clock, std::function<void()> after = {})
      : machine_(machine), clock_(std::move(clock)), after_(std::move(after)) {}

  Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    machine_.advance_to(clock_());
    return machine_.read_holding(address, out);
  }
  Errc read_input_registers(uint16_t address, std::span<uint16_t> out) override {
    machine_.advance_to(clock_());
    return machine_.read_input(address, out);
  }
  Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    machine_.advance_to(clock_());
    return machine_.write_holding(address, values);
  }
  void after_response() override {
    if (after_) after_();
  }

 private:
  Machine& machine_;
  Clock clock_;
  std::function<void()> after_;
};

struct SimulatorOptions {
  io::PortSpec listen;           ///< listening form (pty, serial device, tcp://, rtu+tcp://)
  std::optional<uint8_t> unit;   ///< overrides the persisted address
  std::optional<uint32_t> baud;  ///< overrides the persisted baud rate (1200..19200 with a code)
  std::string state_file;        ///< empty: settings live in memory only
  double time_scale = 1.0;       ///< device seconds per real second (> 0)
  RequestLog log;                ///< every request/response, for -v
  std::function<void(std::string_view)> notice;  ///< one-line notices (warnings, address changes)
};

class Simulator {
 public:
  /// Loads the state file, builds the machine, starts listening. Errors:
  /// invalid_argument (bad option) or io_error, with the reason in `why`.
  static Result<std::unique_ptr<Simulator>> start(asio::io_context& ctx, SimulatorOptions options,
                                                  std::string* why);
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  std::string where() const;
  uint8_t unit() const noexcept { return unit_; }
  /// Device time now (ms).
  uint64_t device_ms() const { return clock_.now_ms(); }
  /// The model, advanced to now. Only on the io_context's thread.
  Machine& machine();

  /// One console line -> its reply (may be several lines; empty for blank input).
  /// Commands: help, status, fault NAME|BIT|0xMASK [on|off], fault clear,
  /// temp mosfet|motor C, mains V, quit (returns "bye" and sets quit_requested()).
  std::string command(std::string_view line);
  bool quit_requested() const noexcept { return quit_; }
  /// Status as the console prints it.
  std::string status_text();

 private:
  explicit Simulator(SimulatorOptions options);
  void after_response();
  void save();

  SimulatorOptions options_;
  DeviceClock clock_;
  Machine machine_;
  std::unique_ptr<MachineBank> bank_;
  SlaveEngine engine_;
  std::unique_ptr<SlaveListener> listener_;
  std::unique_ptr<PeriodicTimer> ticker_;
  uint8_t unit_ = kDefaultAddress;
  bool quit_ = false;
};

}  // namespace rtukit::inverjet
