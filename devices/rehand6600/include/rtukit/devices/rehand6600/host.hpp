// The RK3588 host's side of the Rehand 6600 protocol, as a library: one
// object owns the link and runs the host protocol on its own thread.
//
//  - Handshake: read 0x0000; an answer other than 0x68 (or none) raises Master
//    error 1010 and is retried every `handshake_retry`; on success, write
//    0x006B = 1 (boot complete) and start polling.
//  - Polling: table 1 (48 registers, one FC03) at `poll_hz`; each poll gives a
//    consistent Snapshot and change events. `failures_to_error` consecutive
//    failures raise 1010 and go back to the handshake; recovery clears it.
//  - Commands: every client (the HMI, a phone, the CLI) speaks through the
//    Session (session.hpp), the one place of the rules: presses under a
//    300-ms lease, loss of a phone = emergency stop, the UI rules, D-8. The
//    host writes what the session wants: a change at once, every held value
//    again after each poll (so the controller's watchdog, D-5, never sees a
//    stale hold). Pulses write 1 then 0; settings: drive mode, speed level,
//    host fault.
//  - The web thread never waits for the bus: press(), send() and the rest
//    check with the session under a short lock and return; the bus worker
//    writes. One-shot writes wait in a bounded queue (a full one refuses).
//
//   rtukit::rehand6600::Host host(rtukit::io::make_link(spec));
//   host.on_event([](const rtukit::rehand6600::Event& e) { ... });  // on the host's thread
//   host.start();
//   if (rtukit::Status e = host.hold(rtukit::rehand6600::reg::kSeatLift, 1)) { ... e.reason() ... }
//
// The decisions (handshake and its retry, polling, 1010 after N failures,
// writing targets, events) are `HostLogic`, sans-IO: it says which request to send
// when and what each result means, on whatever clock the caller passes, so
// it is tested on virtual time. `Host` is the thin thread that runs it over
// a Master.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rtukit/core/error.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/session.hpp"
#include "rtukit/devices/rehand6600/snapshot.hpp"
#include "rtukit/driver/bus_worker.hpp"
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
  /// The clock of the poll schedule, the leases and the master's deadlines;
  /// nullptr: the steady clock. Must outlive the Host.
  DriverClock* clock = nullptr;
};

struct Event {
  enum class Type : uint8_t {
    connected,      ///< handshake succeeded
    changed,        ///< a table-1 register changed (address, before, value)
    horn,           ///< rising edge of 0x0023: play the horn
    view,           ///< rising edge of 0x0024: show the 360-degree view
    error_raised,   ///< code = the error (local 0x0026 or 1010)
    error_cleared,  ///< code = the error that went away
    released,  ///< press `press` of `client` on `address` ended (`reason`; `emergency`: by the stop command)
    emergency_started,  ///< a phone lost control: the controller's stop command (0x006A) is held
    emergency_ended,    ///< the chair is still: 0x006A released
    driver_changed,     ///< `client` drives now (0: nobody)
    write_failed,       ///< a one-shot write (pulse, setting) to `address` failed (`reason`)
  };
  Event(Type t, uint16_t address_ = 0, uint16_t before_ = 0, uint16_t value_ = 0, uint16_t code_ = 0,
        std::string reason_ = {})
      : type(t), address(address_), before(before_), value(value_), code(code_), reason(std::move(reason_)) {}
  Type type;
  uint16_t address = 0;
  uint16_t before = 0;
  uint16_t value = 0;
  uint16_t code = 0;
  std::string reason;   ///< for error_raised: why (e.g. "device ID 0x69, expected 0x68", "timeout")
  uint64_t client = 0;  ///< released, driver_changed: the session's client
  uint64_t press = 0;   ///< released: the press
  bool emergency = false;
};

/// The host controller's bus decisions, sans-IO: when to send which request
/// and what each result means. What the controller must hold comes from the
/// Session (set_target); this type writes it. Not thread-safe (Host locks it).
class HostLogic {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;
  /// One-shot writes waiting at most; more are refused (the web thread
  /// never waits for the bus).
  static constexpr size_t kQueueLimit = 16;

  /// A request the logic wants sent.
  struct Request {
    enum class Kind : uint8_t {
      read_device_id,  ///< FC03 0x0000 x1
      poll,            ///< FC03 0x0000 x48 (table 1)
      write,           ///< FC06 `address` = `value` (boot complete, held commands, one-shots)
    };
    Kind kind;
    uint16_t address = 0;
    uint16_t value = 0;
    uint64_t ticket = 0;  ///< a one-shot write's ticket (0: not one)
    bool target = false;  ///< a change of a target, written at once
  };

  explicit HostLogic(const HostOptions& options) : options_(options) {}

  /// The request to send at `now`, or nullopt: nothing to do before wake_at().
  std::optional<Request> next(TimePoint now);
  /// The outcome of the request next() returned last: `e`, and for reads the
  /// words read (1 for the device ID, 48 for a poll).
  void on_result(TimePoint now, Error e, std::span<const uint16_t> words = {});
  /// When next() has something to do again.
  TimePoint wake_at() const noexcept;
  /// Events since the last call, in order.
  std::vector<Event> take_events() { return std::exchange(events_, {}); }

  // ---- what the controller holds ----
  /// The value the controller must hold at hold-type `command` (the
  /// Session's wanted()). A change is written at once, before the next poll;
  /// every non-zero target is written again after each poll, so the
  /// controller holds exactly what the session wants even after its
  /// watchdog fired. A target write that fails raises write_failed (the
  /// session ends that press) and 0 is written after the next poll: a lost
  /// answer may follow an executed write, and any doubt about motion: stop.
  void set_target(uint16_t command, uint16_t value);
  uint16_t target(uint16_t command) const { return targets_[command - reg::kCommandFirst].value; }
  /// True while the controller may hold hold-type `command`: its target is
  /// not 0, or the last target word it was sent was not 0 (a release not yet
  /// written, or one whose write failed). Whoever stops the host writes 0
  /// to each of these: a release queued but never sent must not be lost.
  bool may_hold(uint16_t command) const {
    const Target& t = targets_[command - reg::kCommandFirst];
    return t.value != 0 || t.sent != 0;
  }
  /// Queues a one-shot write (a pulse's edge, a setting), sent after the
  /// pending target changes. False: kQueueLimit writes wait already, or the
  /// link is down (nothing would be written). Its outcome comes back from
  /// take_results().
  bool enqueue(uint16_t address, uint16_t value, uint64_t ticket);
  /// Finished one-shot writes: (ticket, error) in order.
  std::vector<std::pair<uint64_t, Error>> take_results() { return std::exchange(results_, {}); }

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
  void fail_queued(Error e);

  HostOptions options_;
  Phase phase_ = Phase::read_id;
  TimePoint next_at_{};
  TimePoint cycle_start_{};
  std::optional<Request> in_flight_;
  std::vector<Request> queue_;  ///< the held commands of this cycle, to write again
  std::deque<Request> urgent_;  ///< target changes, then one-shots: before the next poll
  std::vector<std::pair<uint64_t, Error>> results_;
  std::vector<Event> events_;
  bool connected_ = false;
  bool comm_error_ = false;
  unsigned failures_ = 0;
  rtukit::Status last_failure_;
  Snapshot snapshot_{};
  struct Target {
    uint16_t value = 0;
    bool zero_pending = false;  ///< a target write failed: 0 is written after the next poll
    uint16_t sent = 0;          ///< the last word written (a failed write of 0 keeps the one before)
  };
  std::array<Target, reg::kCommandCount> targets_{};
};

/// The host controller: HostLogic and the Session on one bus worker thread.
/// Every public function is thread-safe and none waits for the bus except
/// the ones that say so (the CLI's blocking helpers): commands are checked
/// by the session at once and written by the worker.
class Host {
 public:
  using ClientId = Session::ClientId;
  using PressId = Session::PressId;
  /// The client the blocking helpers (hold, release, pulse, set_*) speak as: a tool.
  static constexpr ClientId kLocalClient = ~ClientId{0};

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

  // ---- the session (session.hpp): never waits for the bus ----
  void join(ClientId client, ClientKind kind);
  void leave(ClientId client);
  /// Session::press; the write follows at once on the bus worker.
  rtukit::Status press(ClientId client, uint16_t command, uint16_t value, PressId id);
  rtukit::Status renew(ClientId client, PressId id);
  void release_press(ClientId client, PressId id);
  /// Every press of every client ends (the display's Stop button).
  void stop_all();
  /// A pulse (1 then 0; 2 for 0x0075 as the seed does) or a setting from
  /// `client`, checked by the session and queued for the bus worker.
  /// Errors: the session's (invalid_argument, refused), busy (the queue is
  /// full: refused with the reason). A write that fails later raises
  /// Event::write_failed.
  rtukit::Status send(ClientId client, uint16_t command, uint16_t value);
  Disabled disabled() const;
  std::vector<Session::Press> presses() const;
  std::optional<ClientId> driver() const;
  bool emergency() const;
  bool near_obstacle() const;

  // ---- blocking helpers for local tools (the CLI), as kLocalClient ----
  /// Holds a hold-type command at `value` for one lease: the first call
  /// presses, later calls renew. A press the session ended (a lapse, an
  /// error, D-8) is refused until release(). Errors: invalid_argument,
  /// refused, with their reason.
  rtukit::Status hold(uint16_t command, uint16_t value);
  /// Releases a hold (the finger lifted). Always allowed.
  Error release(uint16_t command);
  /// A pulse command (0x0061, 0x0072, 0x0073, 0x0075), waiting for both writes.
  rtukit::Status pulse(uint16_t command);
  rtukit::Status set_drive_mode(uint16_t mode);    ///< 1 normal, 2 indoor, 3 outdoor; waits for the write
  rtukit::Status set_speed_level(uint16_t level);  ///< 1..5; waits for the write
  Error set_host_fault(uint16_t code);             ///< 0 = none; allowed during an overlay; waits

  const HostOptions& options() const noexcept { return options_; }
  std::string describe() const { return master_.describe(); }

 private:
  /// The bus worker's step: one request, or the time the logic next wants one.
  HostLogic::TimePoint step();
  /// Something changed (a press, a command): waiters and the worker look again.
  void notify();
  void emit(const Event& e);
  void sync(HostLogic::TimePoint now);  ///< under the lock: the session's wanted values become targets
  std::vector<Event> collect();         ///< under the lock: the logic's and the session's events
  rtukit::Status queue(ClientId client, uint16_t command, uint16_t value, uint64_t* ticket);
  rtukit::Status wait_ticket(uint64_t ticket);
  rtukit::Status set_setting(uint16_t address, uint16_t value);
  Error write_command(uint16_t address, uint16_t value);

  HostOptions options_;
  DriverClock& clock_;
  Master master_;
  std::function<void(const Event&)> handler_;

  mutable std::mutex mutex_;  ///< guards everything below
  mutable std::condition_variable cv_;
  bool stopping_ = false;
  HostLogic logic_;
  Session session_;
  uint64_t next_ticket_ = 1;
  std::deque<std::pair<uint64_t, Error>> finished_;        ///< the last one-shot outcomes, for wait_ticket
  std::array<PressId, reg::kCommandCount> local_press_{};  ///< kLocalClient's press per command (0: none)
  PressId local_last_ = 0;
  /// The thread on the bus (driver/bus_worker.hpp), between start() and stop().
  /// Last: it ends before anything it uses.
  BusWorker worker_;
};

}  // namespace rtukit::rehand6600
