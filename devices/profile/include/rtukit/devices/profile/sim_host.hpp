// rtukit device profiles, host side: one simulator runtime for every device.
//
// `SimHost` serves a `Model` on a real link (pty, serial port, Modbus TCP,
// RTU over TCP) and does everything that is the same for every simulated
// device:
//  - device time = real time x time scale, passed to the model on every
//    request and every tick (so timers run while nobody polls);
//  - a new unit address or baud rate applied after the response to the
//    write that asked for it (LinkChange);
//  - the persisted rows loaded from the state file at start and saved
//    (atomically) whenever a request changed them;
//  - a console: rows of (verb, usage, help, handler); `help`, `status`,
//    `get KEY...`, `registers` and `quit` are built in, a device adds its own
//    (`fault motor-drive`, `joystick 0 100`).
//
// Everything runs on the io_context's thread: call `command` from there.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/status.hpp"
#include "rtukit/devices/profile/model.hpp"
#include "rtukit/driver/simulation.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit::profile {

/// One console verb. `run` gets the words after the verb and returns the
/// reply (may be several lines) or a Status whose reason is printed as
/// "error: ...". Runs on the io_context's thread.
struct ConsoleVerb {
  std::string_view verb;   ///< "fault"
  std::string_view usage;  ///< "fault NAME|BIT|0xMASK [on|off]"
  std::string_view help;   ///< "inject a machine fault (see 'registers' for the names)"
  std::function<Outcome<std::string>(std::span<const std::string> args)> run;
};

struct SimOptions {
  io::PortSpec listen;           ///< listening form
  std::optional<uint8_t> unit;   ///< overrides the stored / default address
  std::optional<uint32_t> baud;  ///< overrides the stored / default baud rate
  std::string state_file;        ///< empty: no state file (persisted rows live in memory)
  /// Replace a file at `state_file` that is not this device's state file.
  /// Without it, start() refuses such a file (Errc::refused) and leaves it alone.
  bool force_state = false;
  double time_scale = 1.0;  ///< device seconds per real second, (0, 100000]
  /// The time the device clock scales; nullptr: the steady clock. Must
  /// outlive the host. Tests pass a ManualClock and advance it.
  DriverClock* clock = nullptr;
  std::chrono::milliseconds tick{20};
  RequestLog log;                                ///< every request/response, for -v
  ServerOptions server;                          ///< connection limits, turnaround (slave_server.hpp)
  std::function<void(std::string_view)> notice;  ///< one-line notices (warnings, link changes)
};

/// What a device brings to the host: its model and its console verbs.
struct SimDevice {
  std::unique_ptr<Model> model;
  std::vector<ConsoleVerb> verbs;
  /// Lines appended to the console's `status` (which prints the device time
  /// and every readable single row, decoded), e.g. "plan segment 3 of 5".
  std::function<std::string()> status_extra = {};
  /// Appended to the start-up line, e.g. ", watchdog 500 ms".
  std::string banner = {};
};

class SimHost {
 public:
  /// Loads the state file into the model's image, applies the options'
  /// unit and baud (through Model::override_link), starts listening and
  /// ticking. Errors: invalid_argument (a bad option, with the reason),
  /// io_error (the port: busy, permission, address in use).
  static Outcome<std::unique_ptr<SimHost>> start(asio::io_context& ctx, SimDevice device, SimOptions options);
  ~SimHost();
  SimHost(const SimHost&) = delete;
  SimHost& operator=(const SimHost&) = delete;

  /// Where masters connect (pty path, device, HOST:PORT).
  std::string where() const;
  uint8_t unit() const noexcept { return unit_; }
  /// The baud rate the link runs at now.
  uint32_t baud() const noexcept { return options_.listen.serial.baud; }
  /// The start-up line: "<title> simulator: unit 21, 9600 baud, time x1, state <file>\nlistening on <where>".
  std::string banner() const;
  uint64_t device_ms() const noexcept { return clock_.now_ms(); }
  /// The model, advanced to now. Only on the io_context's thread.
  Model& model();

  /// One console line -> its reply (empty for a blank line).
  std::string command(std::string_view line);
  bool quit_requested() const noexcept { return quit_; }
  /// The console's `help` text (generated from the verbs).
  std::string help() const;

 private:
  SimHost(SimDevice device, SimOptions options);
  void after_response();
  void save_if_changed();

  struct Bank;
  SimDevice device_;
  SimOptions options_;
  DeviceClock clock_;
  std::unique_ptr<Bank> bank_;
  SlaveEngine engine_;
  std::unique_ptr<SlaveListener> listener_;
  std::unique_ptr<PeriodicTimer> ticker_;
  std::vector<uint16_t> saved_;  ///< persisted words as last saved
  uint8_t unit_ = 1;
  bool quit_ = false;
};

}  // namespace rtukit::profile
