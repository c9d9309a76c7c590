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
//    host writes what the session wants by the write rules below (D-8,
//    D-12; docs/rehand6600.md, "How the host writes"). Pulses write 1 then
//    0; settings: drive mode, speed level, host fault.
//  - The write rules. The command registers are write-only: a normal answer
//    is the only confirmation the controller gives.
//     * A stop is written until it is confirmed: 0 to every hold-type
//       command the controller may hold (a press ended, a write whose answer
//       was lost, anything a link loss or an earlier run may have left), and
//       0x006A = 1 while a stop is held. Stops go before everything else,
//       polls included, survive 1010 (tried at the poll rate while the link
//       is down, and first after every handshake), and a newer word of the
//       same command replaces an older one, so no old word overtakes a new one.
//     * A press's word is written once. Nothing is written again after a
//       poll: when the controller stops by itself (its watchdog, an
//       obstacle, the joystick, a button, a fault), table 1 shows it, the
//       press ends, and only a new press moves the chair.
//     * 0x006A goes back to 0 only after two polls, sent after its 1 was
//       confirmed, read the chair still; never in the middle of a stop,
//       not even by stop().
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

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/session.hpp"
#include "rtukit/devices/rehand6600/snapshot.hpp"
#include "rtukit/driver/bus_worker.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/link.hpp"

namespace rtukit::rehand6600 {

struct HostOptions {
  UnitId unit{kDefaultAddress};
  double poll_hz = 20;
  /// Consecutive requests without an answer that make a communication error (1010).
  unsigned failures_to_error = 3;
  std::chrono::milliseconds lease{300};
  std::chrono::milliseconds handshake_retry{1000};
  std::chrono::milliseconds response_timeout{100};
  /// How long after its word was confirmed a press must show in table 1
  /// (moving, or at its end) before the host ends it as not started: long
  /// enough for the chair to brake to a stop before it changes direction
  /// (1.8 s from 7.2 km/h at 4 km/h/s).
  std::chrono::milliseconds start_timeout{2500};
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
    write_failed,       ///< a write to `address` failed (`reason`): a one-shot, or a press's word
    chair_stopped,      ///< table 1 shows the press on `address` is not (or no longer) done (`reason`)
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
/// and what each result means, by the write rules above. What the controller
/// must hold comes from the Session (set_target); this type writes it. Not
/// thread-safe (Host locks it).
class HostLogic {
 public:
  using TimePoint = rtukit::TimePoint;
  /// One-shot writes waiting at most; more are refused (the web thread
  /// never waits for the bus).
  static constexpr size_t kQueueLimit = 16;
  /// After begin_shutdown(), how often each stop is tried at most.
  static constexpr unsigned kShutdownAttempts = 3;

  /// A request the logic wants sent.
  struct Request {
    enum class Kind : uint8_t {
      read_device_id,  ///< FC03 0x0000 x1
      poll,            ///< FC03 0x0000 x48 (table 1)
      write,           ///< FC06 `address` = `value` (boot complete, commands, one-shots)
    };
    Kind kind;
    uint16_t address = 0;
    uint16_t value = 0;
    uint64_t ticket = 0;  ///< a one-shot write's ticket (0: not one)
    bool target = false;  ///< a hold-type command's word (a stop, or a press's word)
  };

  /// Every hold-type command starts as "may hold": a host that starts does
  /// not know what an earlier run (or another host) left on the controller.
  explicit HostLogic(const HostOptions& options);

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
  /// What the controller must hold at hold-type `command`: `value` for the
  /// press (or stop) `serial` (Session::hold). A press's word is written
  /// once per serial; a stop (0, or 0x006A = 1) until it is confirmed.
  void set_target(uint16_t command, uint16_t value, uint64_t serial);
  uint16_t target(uint16_t command) const { return commands_[index(command)].want; }
  /// True while the controller may hold hold-type `command` at a word that
  /// is not 0: its target is not 0, or no 0 has been confirmed since the
  /// last word that was (or, unanswered, may have been) executed.
  bool may_hold(uint16_t command) const {
    const Command& c = commands_[index(command)];
    return c.want != 0 || c.maybe;
  }
  /// True when the controller is known to hold `value` at `command`: its
  /// last write there was answered normally, with no link loss since.
  bool confirmed(uint16_t command, uint16_t value) const {
    const Command& c = commands_[index(command)];
    return c.known && c.confirmed == value;
  }
  /// True once the stop command's 1 was confirmed (or since the start) and
  /// the two polls since read the chair still: the Session may end a stop,
  /// and only then is 0x006A = 0 written.
  bool stop_settled() const noexcept;
  /// Queues a one-shot write (a pulse's edge, a setting), sent after the
  /// stops and the presses' words. False: kQueueLimit writes wait already,
  /// or the link is down (nothing would be written). Its outcome comes back
  /// from take_results().
  bool enqueue(uint16_t address, uint16_t value, uint64_t ticket);
  /// Finished one-shot writes: (ticket, error) in order.
  std::vector<std::pair<uint64_t, Error>> take_results() { return std::exchange(results_, {}); }
  /// The host is stopping: from now on next() returns only stops (each
  /// tried kShutdownAttempts times at most), never a poll, a press's word
  /// or a one-shot; nullopt when none is left to try.
  void begin_shutdown();

  // ---- what the controller looks like ----
  const Snapshot& snapshot() const noexcept { return snapshot_; }
  bool connected() const noexcept { return connected_; }
  /// 1010 while the link is down, else 0x0026; 0 = none.
  uint16_t active_error() const noexcept;
  const rtukit::Status& last_failure() const noexcept { return last_failure_; }

 private:
  enum class Phase : uint8_t { read_id, write_ready, poll };
  /// A press's word and what the polls since show of it.
  enum class Watch : uint8_t { none, starting, running };
  struct Command {
    uint16_t want = 0;        ///< the session's value now
    uint64_t serial = 0;      ///< the press (or stop) it belongs to
    uint64_t written = 0;     ///< the serial whose word has been sent (once)
    bool maybe = false;       ///< the controller may hold a word that is not 0
    bool known = false;       ///< `confirmed` is what the controller holds
    uint16_t confirmed = 0;   ///< the last word answered normally
    unsigned attempts = 0;    ///< tries of the stop owed now (for shutdown)
    bool after_poll = false;  ///< the stop was answered with an exception: tried again after a poll
    Watch watch = Watch::none;
    TimePoint deadline{};  ///< Watch::starting: the press must show by then
  };
  static size_t index(uint16_t command) { return command - reg::kCommandFirst; }
  /// The stop owed at `command` (0, or 1 at 0x006A), or nullopt.
  std::optional<uint16_t> stop_owed(uint16_t command) const;
  bool stops_owed() const;
  std::optional<Request> next_stop();
  std::optional<Request> next_press();
  TimePoint::duration period() const noexcept;
  void on_write(TimePoint now, const Request& done, Error e);
  void on_poll(TimePoint now, Error e, std::span<const uint16_t> words);
  void watch_presses(TimePoint now);
  /// A request went unanswered (or was answered wrongly): 1010 after `failures_to_error` in a row.
  void count_failure(Error e, const std::string& what);
  void raise_comm_error(Error cause, const std::string& reason);
  void fail_queued(Error e);

  HostOptions options_;
  Phase phase_ = Phase::read_id;
  TimePoint next_at_{};     ///< when the next poll (or handshake) is due
  TimePoint sent_at_{};     ///< when the last poll (or device-ID read) was sent
  TimePoint stop_retry_{};  ///< while the link is down: the next try of a stop
  std::optional<Request> in_flight_;
  std::deque<Request> oneshots_;
  std::vector<std::pair<uint64_t, Error>> results_;
  std::vector<Event> events_;
  bool connected_ = false;
  bool identified_ = false;  ///< the last device-ID read found a Rehand 6600: stops may be written
  bool comm_error_ = false;
  bool shutting_down_ = false;
  unsigned failures_ = 0;
  unsigned still_polls_ = 0;  ///< polls in a row reading the chair still since 0x006A's 1 was confirmed
  size_t stop_cursor_ = 0;    ///< where the search for the next stop starts (each gets its turn)
  rtukit::Status last_failure_;
  Snapshot snapshot_{};
  std::array<Command, reg::kCommandCount> commands_{};
};

/// What the host knows at one instant, taken at once (Host::state() under
/// its one lock), so no reader sees a press without its driver or an error
/// without the snapshot it came with. The state document's chair part is
/// built from this alone (views.hpp, state_view).
struct HostState {
  Snapshot snapshot;
  bool connected = false;     ///< handshake done, link up
  uint16_t active_error = 0;  ///< the overlay's error: 1010 while the link is down, else 0x0026; 0 = none
  std::vector<Session::Press> presses;
  Disabled disabled;
  std::optional<Session::ClientId> driver;  ///< who holds the driver's seat (a phone), if anyone
  bool emergency = false;                   ///< a phone's emergency stop is being held
  bool near_obstacle = false;
  bool stop_latched = false;  ///< the display's STOP
  uint16_t speed_level = 1;   ///< written to the controller: 1 while a phone drives (D-14)
  uint16_t chosen_speed = 1;  ///< the display's (or a tool's) last speed level (D-7: 1 until chosen)
  uint16_t drive_mode = 1;    ///< the last drive mode chosen (D-7: 1, normal, until chosen)
};

/// The host's decisions and rules together, sans-IO and single-threaded:
/// HostLogic (what goes on the wire) and the Session (who may do what),
/// joined exactly as the Host joins them on its bus thread. The Host adds a
/// thread, a lock and a Master; the deterministic simulation
/// (tests/simulation/) drives this object with the chair model on a
/// ManualClock. Not thread-safe.
class HostCore {
 public:
  using TimePoint = HostLogic::TimePoint;

  explicit HostCore(const HostOptions& options)
      : logic_(options), session_(SessionOptions{.lease = options.lease}) {}

  HostLogic& logic() noexcept { return logic_; }
  const HostLogic& logic() const noexcept { return logic_; }
  Session& session() noexcept { return session_; }
  const Session& session() const noexcept { return session_; }

  /// Time passes to `now` (leases lapse) and what the session wants becomes
  /// the logic's targets. Call after any session call from outside (a
  /// press, STOP) so its write is the next request.
  void sync(TimePoint now);
  /// sync(now), then the request to send now, or nullopt.
  std::optional<HostLogic::Request> next(TimePoint now);
  /// The outcome of the request next() returned last (HostLogic::on_result),
  /// told to the session: the controller's state and errors, a press whose
  /// write failed, a press the controller stopped by itself.
  void on_result(TimePoint now, Error e, std::span<const uint16_t> words = {});
  /// When next() has something to do: the logic's wake-up or a lease's end.
  TimePoint wake_at() const;
  /// Events since the last call: the logic's, then the session's, in order.
  std::vector<Event> take_events();
  /// The host is stopping: every press ends (a driving phone loses control),
  /// and from now on next() returns only the stops still owed.
  void begin_shutdown(TimePoint now);

  /// A one-shot command of `client` (a pulse: two writes, 1 then 0; a
  /// setting: one write), checked by the session and queued; `ticket` names
  /// its outcome in take_results() (a pulse's is its last write's).
  /// Errors: the session's (Session::check_command); refused: the speed
  /// level while a phone drives (D-14), the controller's queue is full, no
  /// communication with the controller.
  rtukit::Status queue(Session::ClientId client, uint16_t command, uint16_t value, uint64_t ticket);
  /// The outcomes of queued writes since the last call, (ticket, error).
  std::vector<std::pair<uint64_t, Error>> take_results();
  /// The speed level the controller is held at: 1 while a phone holds the
  /// driver's seat (D-14), else the level the display (or a tool) chose
  /// last (1 until one does: the controller's power-on level, D-7).
  uint16_t speed_level() const noexcept { return session_.driver() ? 1 : chosen_speed_; }
  /// Everything at once (HostState); the time is the last sync()'s.
  HostState state() const;

 private:
  // D-14: while someone holds the driver's seat the controller is set to
  // speed level 1 first; no drive word is written until it confirmed that
  // write. `asked`: the write is queued or on the wire.
  enum class Slow : uint8_t { no, asked, yes };
  static constexpr uint64_t kSlowTicket = ~uint64_t{0} - 1;     ///< the write of level 1
  static constexpr uint64_t kRestoreTicket = ~uint64_t{0} - 2;  ///< the display's level put back
  void absorb_results(TimePoint now);

  HostLogic logic_;
  Session session_;
  std::vector<Event> events_;                        ///< the logic's events already told to the session
  std::vector<std::pair<uint64_t, Error>> results_;  ///< the queued writes' outcomes not yet taken
  uint16_t chosen_speed_ = 1;                        ///< the display's (or a tool's) last speed level
  uint16_t chosen_drive_mode_ = 1;                   ///< the last drive mode queued (D-7: 1 until one is)
  Slow slow_ = Slow::no;
  TimePoint slow_retry_at_{};  ///< after a failed write of level 1: not tried again before
  TimePoint now_{};            ///< the time of the last sync() or on_result()
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
  ~Host();  ///< stop()
  Host(const Host&) = delete;
  Host& operator=(const Host&) = delete;

  /// Called on the host's thread for every event. Set before start().
  void on_event(std::function<void(const Event&)> handler);
  void start();
  /// Stops the thread, then writes the stops still owed (each at most
  /// HostLogic::kShutdownAttempts times): 0 to every command the controller
  /// may hold; a phone that was driving loses control (0x006A = 1, left
  /// held: never released in the middle of a stop). Idempotent.
  void stop();

  /// Everything the state document shows, under one lock (HostState).
  HostState state() const;
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
  /// The display's STOP: an emergency stop (0x006A), latched; every press
  /// of every client ends and nothing is pressed again until lift_stop().
  void stop_all();
  /// The display lifts its STOP (0x006A is released once the chair is still).
  void lift_stop();
  bool stop_latched() const;
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
  /// HostCore::speed_level(): 1 while a phone drives (D-14), else the display's level.
  uint16_t speed_level() const;
  Error set_host_fault(uint16_t code);  ///< 0 = none; allowed during an overlay; waits

  const HostOptions& options() const noexcept { return options_; }
  std::string describe() const { return master_.describe(); }

 private:
  /// The bus worker's step: one request, or the time the logic next wants one.
  HostLogic::TimePoint step();
  /// Something changed (a press, a command): waiters and the worker look again.
  void notify();
  void emit(const Event& e);
  std::vector<Event>
  collect();  ///< under the lock: the core's events; one-shot outcomes kept for wait_ticket
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
  HostCore core_;
  uint64_t next_ticket_ = 1;
  std::deque<std::pair<uint64_t, Error>> finished_;        ///< the last one-shot outcomes, for wait_ticket
  std::array<PressId, reg::kCommandCount> local_press_{};  ///< kLocalClient's press per command (0: none)
  PressId local_last_ = 0;
  /// The thread on the bus (driver/bus_worker.hpp), between start() and stop().
  /// Last: it ends before anything it uses.
  BusWorker worker_;
};

}  // namespace rtukit::rehand6600
