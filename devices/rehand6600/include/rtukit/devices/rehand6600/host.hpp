// The RK3588 host's side of the Rehand 6600 protocol, as a library: one
// object owns the link and runs the host protocol on its own thread.
//
//  - Handshake: read 0x0000; an answer other than 0x68 (or none) raises Master
//    error 1010 and is retried every `handshake_retry`; on success, write
//    0x006B = 1 (boot complete) and start polling.
//  - Polling: table 1 (48 registers, one FC03) at `poll_hz`; each poll gives a
//    consistent Snapshot and change events. `failures_to_error` consecutive
//    failures raise 1010 and go back to the handshake; recovery clears it.
//  - Commands: hold(command, value) keeps a hold-type command active under a
//    lease: the UI must renew it (call hold again) within `lease`, else the
//    library releases it (writes 0) by itself. The held value is rewritten
//    every poll, so the controller's watchdog (D-5) never sees a stale hold.
//    pulse() writes 1 then 0. Settings: drive mode, speed level, host fault.
//  - UI rules, enforced with a reason: no driving while charging or in push,
//    phone drive only while static, nothing but releasing (and reporting a
//    host fault) while an error overlay is active (local 0x0026 or 1010).
//  - D-8: raising an error drops every hold; a dropped hold is refused until
//    the UI releases it, so nothing restarts when the error clears.
//
//   rtukit::rehand6600::Host host(rtukit::io::make_link(spec));
//   host.on_event([](const rtukit::rehand6600::Event& e) { ... });  // on the host's thread
//   host.start();
//   if (rtukit::Status e = host.hold(rtukit::rehand6600::reg::kSeatLift, 1)) { ... e.reason() ... }
//
// The decisions (handshake and its retry, polling, 1010 after N failures,
// leases, events) are `HostLogic`, sans-IO: it says which request to send
// when and what each result means, on whatever clock the caller passes, so
// it is tested on virtual time. `Host` is the thin thread that runs it over
// a Master.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::rehand6600 {

struct HostOptions {
  UnitId unit{kDefaultAddress};
  double poll_hz = 20;
  unsigned failures_to_error = 3;
  std::chrono::milliseconds lease{300};
  std::chrono::milliseconds handshake_retry{1000};
  std::chrono::milliseconds response_timeout{100};
  /// Each frame on the wire (MasterOptions::trace); empty: none.
  std::function<void(const TraceEvent&)> trace;
};

/// Table 1 as one consistent reading.
struct Snapshot {
  std::array<uint16_t, reg::kStatusCount> regs{};
  bool valid = false;  ///< false until the first successful poll
  uint64_t sequence = 0;

  uint16_t operator[](uint16_t address) const noexcept { return regs[address]; }
  unsigned battery() const noexcept { return regs[reg::kBattery]; }
  bool charging() const noexcept { return regs[reg::kCharging] != 0; }
  unsigned speed_kmh() const noexcept { return regs[reg::kSpeed]; }
  double speed_mph() const noexcept { return regs[reg::kSpeed] * 0.621371; }
  bool clutch_drive() const noexcept { return regs[reg::kClutch] == 1; }
  uint16_t motion() const noexcept { return regs[reg::kMotion]; }
  bool is_static() const noexcept { return regs[reg::kMotion] == 1 && regs[reg::kSpeed] == 0; }
  uint16_t error_code() const noexcept { return regs[reg::kErrorCode]; }
};

struct Event {
  enum class Type : uint8_t {
    connected,      ///< handshake succeeded
    changed,        ///< a table-1 register changed (address, before, value)
    horn,           ///< rising edge of 0x0023: play the horn
    view,           ///< rising edge of 0x0024: show the 360-degree view
    error_raised,   ///< code = the error (local 0x0026 or 1010)
    error_cleared,  ///< code = the error that went away
    released,       ///< the library released a hold whose lease ran out (address)
  };
  Event(Type t, uint16_t address_ = 0, uint16_t before_ = 0, uint16_t value_ = 0, uint16_t code_ = 0,
        std::string reason_ = {})
      : type(t), address(address_), before(before_), value(value_), code(code_), reason(std::move(reason_)) {}
  Type type;
  uint16_t address = 0;
  uint16_t before = 0;
  uint16_t value = 0;
  uint16_t code = 0;
  std::string reason;  ///< for error_raised: why (e.g. "device ID 0x69, expected 0x68", "timeout")
};

/// The host controller's decisions, sans-IO. Not thread-safe (Host locks it).
class HostLogic {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;

  /// A request the logic wants sent.
  struct Request {
    enum class Kind : uint8_t {
      read_device_id,  ///< FC03 0x0000 x1
      poll,            ///< FC03 0x0000 x48 (table 1)
      write,           ///< FC06 `address` = `value` (boot complete, held commands)
    };
    Kind kind;
    uint16_t address = 0;
    uint16_t value = 0;
  };

  explicit HostLogic(const HostOptions& options) : options_(options) {}

  /// The request to send at `now`, or nullopt: nothing to do before wake_at().
  std::optional<Request> next(TimePoint now);
  /// The outcome of the request next() returned last: `e`, and for reads the
  /// words read (1 for the device ID, 48 for a poll).
  void on_result(TimePoint now, Error e, std::span<const uint16_t> words = {});
  /// When next() has something to do again.
  TimePoint wake_at() const noexcept { return next_at_; }
  /// Events since the last call, in order.
  std::vector<Event> take_events() { return std::exchange(events_, {}); }

  // ---- leases (hold-type commands the UI keeps alive) ----
  /// Holds `command` at `value` until `now` + lease. True when the value
  /// changed (the caller writes it at once).
  bool hold(uint16_t command, uint16_t value, TimePoint now);
  /// The write of a new press (hold() returned true) finished, `written` or
  /// not. True: write 0 to `command` now, because the lease was dropped by a
  /// stop (D-8) or released while the write was on the bus, so the
  /// controller would hold a value nobody holds. A write that failed drops
  /// the press as a stop does (refused until the UI releases it: a finger
  /// that stayed down never presses again by itself) and, since a lost
  /// answer may follow an executed write, 0 is written after the next poll:
  /// any doubt about motion, stop. (A press the UI released while its write
  /// was on the bus is not dropped: the UI already let go.)
  bool press_settled(uint16_t command, uint16_t value, bool written);
  /// Releases a hold, and lets a hold dropped by a stop be pressed again.
  void release(uint16_t command);
  uint16_t held(uint16_t command) const { return holds_[command - reg::kCommandFirst].value; }
  /// D-8: every hold is dropped when an error (local or 1010) is raised; a
  /// dropped hold is refused until the UI releases it (a new press).
  bool dropped(uint16_t command) const { return holds_[command - reg::kCommandFirst].dropped; }

  // ---- what the controller looks like ----
  const Snapshot& snapshot() const noexcept { return snapshot_; }
  bool connected() const noexcept { return connected_; }
  /// 1010 while the link is down, else 0x0026; 0 = none.
  uint16_t active_error() const noexcept;
  const rtukit::Status& last_failure() const noexcept { return last_failure_; }

 private:
  enum class Phase : uint8_t { read_id, write_ready, poll, holds };
  TimePoint::duration period() const noexcept;
  void raise_comm_error(Error cause, const std::string& reason);
  void on_poll(TimePoint now, Error e, std::span<const uint16_t> words);

  HostOptions options_;
  Phase phase_ = Phase::read_id;
  TimePoint next_at_{};
  TimePoint cycle_start_{};
  bool in_flight_ = false;
  std::vector<Request> queue_;  ///< the held commands of this cycle, to write
  std::vector<Event> events_;
  bool connected_ = false;
  bool comm_error_ = false;
  unsigned failures_ = 0;
  rtukit::Status last_failure_;
  Snapshot snapshot_{};
  struct Lease {
    uint16_t value = 0;
    TimePoint until{};
    bool dropped = false;
    bool zero_pending = false;  ///< a press whose write failed: 0 is written after the next poll
  };
  void drop_holds(bool write_zero);
  std::array<Lease, reg::kCommandCount> holds_{};
};

class Host {
 public:
  /// Takes the link (opened by the host's thread).
  explicit Host(std::unique_ptr<io::Link> link, HostOptions options = {});
  ~Host();  ///< stops the thread (releasing every hold first)
  Host(const Host&) = delete;
  Host& operator=(const Host&) = delete;

  /// Called on the host's thread for every event. Set before start().
  void on_event(std::function<void(const Event&)> handler);
  void start();
  /// Releases every hold, then stops the thread. Idempotent.
  void stop();

  Snapshot snapshot() const;
  bool connected() const;
  /// The error the overlay shows: 1010 while the link is down, else 0x0026; 0 = none.
  uint16_t active_error() const;
  /// Why the last handshake or poll failed: the error (timeout, io_error,
  /// refused for another device) and its reason ("handshake: device ID 0x69, expected 0x68").
  rtukit::Status last_failure() const;
  /// Blocks until connected or `timeout`; true when connected.
  bool wait_connected(std::chrono::milliseconds timeout) const;
  /// Blocks until a poll newer than the current snapshot arrived (or timeout).
  bool wait_poll(std::chrono::milliseconds timeout) const;

  /// Holds a hold-type command (posture 0x0062..0x0068, anti-pinch, phone
  /// drive 0x006E..0x0071, phone horn, SOS) at `value` for one lease; call
  /// again to renew. Errors, with their reason: invalid_argument (not a hold
  /// command, a value not listed), refused (a UI rule: the error overlay,
  /// charging, the chair moving), or the write's error.
  rtukit::Status hold(uint16_t command, uint16_t value);
  /// Releases a hold now (writes 0). Always allowed.
  Error release(uint16_t command);
  /// A pulse command (0x0061, 0x0072, 0x0073, 0x0075): writes 1 (2 for
  /// 0x0075, as the seed does), then 0.
  rtukit::Status pulse(uint16_t command);
  rtukit::Status set_drive_mode(uint16_t mode);    ///< 1 normal, 2 indoor, 3 outdoor
  rtukit::Status set_speed_level(uint16_t level);  ///< 1..5
  Error set_host_fault(uint16_t code);             ///< 0 = none; allowed during an overlay

  const HostOptions& options() const noexcept { return options_; }
  std::string describe() const { return master_.describe(); }

 private:
  void run();
  void emit(const Event& e);
  rtukit::Status check_ui_rules(const Register& r, uint16_t value) const;
  Error write_command(uint16_t address, uint16_t value);

  HostOptions options_;
  Master master_;
  std::function<void(const Event&)> handler_;
  std::thread thread_;

  mutable std::mutex mutex_;  ///< guards logic_ and stopping_
  mutable std::condition_variable cv_;
  bool stopping_ = false;
  HostLogic logic_;
};

}  // namespace rtukit::rehand6600
