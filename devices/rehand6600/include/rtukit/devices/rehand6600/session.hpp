// Who may command the Rehand 6600, what, and for how long: the one place
// where the remote-control rules live (D-12, D-8, D-10, D-11 and the seed's
// "phone only while the local side is static"). Every front-end (the touch
// HMI, the phone page, the Bluetooth LE link, the CLI's `hold`) talks to the
// chair through a Session; none keeps a rule of its own.
//
// Sans-IO and pure: no thread, no clock (time is passed in), no bus. It
// answers "may this client do this now?" and says, for every hold-type
// command, the value the controller must hold (wanted()). The host controller
// (host.hpp) runs it on its bus worker and writes what it wants.
//
// The rules (docs/rehand6600.md, "Safety rules"):
//  - A hold is a *press*: the client names it with an id (new for each
//    pointer-down; a client's ids only grow). The press lives while renewals
//    of that id arrive within the lease (300 ms). A lapsed press ends for
//    good: a late renewal, or any renewal of an ended id, is refused and
//    never moves the chair. Only a new press does (D-12). Each accepted
//    press has a session-wide serial: the host writes a press's word once,
//    so a new serial is the only thing that can move the chair again.
//  - Losing a phone is a loss of control, not a release: a phone press whose
//    lease lapses, or whose client leaves, stops through the controller's
//    stop command (0x006A, emergency braking, D-9), held until the host
//    says the chair is still (two polls after the stop was confirmed). A
//    deliberate release, and any display press, stop normally.
//  - The display's STOP is the same emergency stop, latched: every press
//    ends, and nothing is pressed again (phone or display) until the
//    display lifts it.
//  - One phone drives at a time; it gives up the driver's seat when it has
//    held nothing for 2 s. A command held by one client cannot be taken by
//    another.
//  - Nothing starts under the error overlay (0x0026 or 1010), while a stop
//    is being held, or before the first poll after the link came back (the
//    rules never run on a reading from before an outage); an error ends
//    every press (D-8), and so does the controller stopping a press by
//    itself (the host sees it in table 1).
//  - Phone driving: not while charging or in push, not while the chair is
//    raised (D-10), only while the local side is static (joystick neutral
//    and the chair still) unless this phone is the one driving. Each of
//    these also ends a phone's drive press when it arises. No standing up
//    or raising the seat while charging (D-11).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/devices/rehand6600/reasons.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/snapshot.hpp"

namespace rtukit::rehand6600 {

/// What a client is. A display is on the chair (the touch HMI): postures,
/// anti-pinch, settings, the main light. A phone is remote: drive, horn,
/// lighting and turn signals only, and losing it is a loss of control. A
/// tool is a local program on the host (the CLI's `hold`, a test bench):
/// every command, under the same rules, its presses ending normally.
enum class ClientKind : uint8_t { display, phone, tool };

struct SessionOptions {
  std::chrono::milliseconds lease{300};  ///< a press lives this long after its last renewal
  std::chrono::milliseconds driver_idle{
      2000};                        ///< a phone holding nothing this long leaves the driver's seat
  uint16_t near_obstacle_mm = 500;  ///< closer than this while moving: the pages show the 360-degree view
};

/// The hold commands (table 2's hold rows) a kind of client may press: a
/// display the postures and anti-pinch, a phone drive and horn, a tool all of
/// them. The one statement of this rule: the Session checks every press with
/// it, and the host daemon's message parser asks it which commands a page may
/// name at all.
bool may_press(ClientKind kind, uint16_t command) noexcept;
/// The one-shot commands (pulses and settings) a kind of client may send: a
/// display the main light, drive mode and speed level, a phone its light and
/// turn signals, a tool all of them.
bool may_send(ClientKind kind, uint16_t command) noexcept;

/// Why a kind of control is disabled now ("" = allowed), as pages show it,
/// and the same as a number (reasons.hpp: Reason::none = allowed).
struct Disabled {
  std::string all;    ///< every command (the error overlay, a loss of control being stopped)
  std::string drive;  ///< phone driving
  std::string raise;  ///< standing up, raising the seat
  Reason all_reason = Reason::none, drive_reason = Reason::none, raise_reason = Reason::none;
};

class Session {
 public:
  using TimePoint = rtukit::TimePoint;
  using ClientId = uint64_t;
  using PressId = uint64_t;

  struct Press {
    ClientId client = 0;
    PressId id = 0;
    uint16_t command = 0;
    uint16_t value = 0;
    TimePoint until{};
    uint64_t serial = 0;  ///< session-wide, new for every accepted press
  };
  /// What the controller must hold at a hold-type command: the value and
  /// the press (or stop) it belongs to. A new serial is a new press.
  struct Hold {
    uint16_t value = 0;
    uint64_t serial = 0;
  };

  struct Event {
    enum class Type : uint8_t {
      press_ended,  ///< `press` of `client` on `command` ended (`reason`); `emergency`: by the stop command
      emergency_started,  ///< a loss of control: 0x006A is being held
      emergency_ended,    ///< the chair is still: 0x006A released
      driver_changed,     ///< `client` now drives (0: nobody)
    };
    Type type;
    ClientId client = 0;
    PressId press = 0;
    uint16_t command = 0;
    bool emergency = false;
    std::string reason;
  };

  explicit Session(SessionOptions options = {}) : options_(options) {}

  /// A client connected (a display page, an authenticated phone, a tool).
  /// Precondition: `client` is new for each connection (ids are never
  /// reused: a press id is new only within its client). Joining again with
  /// the same id while joined changes nothing.
  void join(ClientId client, ClientKind kind);
  /// The client is gone (socket closed, link dropped, forgotten). A phone's
  /// live presses are a loss of control (emergency stop); a display's end.
  void leave(ClientId client, TimePoint now);

  /// Starts press `id` of `client`: hold `command` (a hold row of table 2
  /// this kind of client may send) at `value` (non-zero, one the row lists).
  /// Errors: invalid_argument (not a command for this client, a value not
  /// listed, an id not newer than the client's last), refused (a rule, with
  /// the reason the user is shown).
  rtukit::Status press(ClientId client, uint16_t command, uint16_t value, PressId id, TimePoint now);
  /// Keeps press `id` alive for one more lease. Errors: refused (the press
  /// has ended: lapsed, released, stopped; never restarts), invalid_argument
  /// (no such press of this client).
  rtukit::Status renew(ClientId client, PressId id, TimePoint now);
  /// The finger lifted: the press ends (normal stop). No effect on an ended press.
  void release(ClientId client, PressId id, TimePoint now);
  /// The display's STOP: an emergency stop (0x006A), latched. Every press
  /// of every client ends at once; new presses and commands are refused
  /// until lift_stop().
  void stop_all(TimePoint now);
  /// The display lifts its STOP. 0x006A is released once the host says the
  /// chair is still (on_status); nothing that was held comes back.
  void lift_stop();
  /// The host is going away: every press ends; a phone's drive press is a
  /// loss of control (0x006A), as when its link drops.
  void shutdown(TimePoint now);
  /// May `client` send the one-shot command `command` = `value` now (a
  /// pulse: the light, turn signals; a setting: drive mode, speed level)?
  /// Errors as press().
  rtukit::Status check_command(ClientId client, uint16_t command, uint16_t value) const;

  /// Time passes: lapsed presses end, the driver's seat frees up.
  void tick(TimePoint now);
  /// What the controller looks like after a request (a poll's reading, or
  /// the link's state when it failed): `active_error` is 1010 while the link
  /// is down, else 0x0026; `stop_settled`: the host's stop command was
  /// confirmed and two polls since read the chair still (HostLogic). An
  /// error ends every press (D-8); a reading from before an outage is never
  /// acted on; a phone's drive press ends when charging, push, a raised
  /// seat or the joystick arise.
  void on_status(const Snapshot& snapshot, uint16_t active_error, TimePoint now, bool stop_settled = false);
  /// A press's write failed: it ends (any doubt about motion: stop).
  void on_write_failed(uint16_t command, TimePoint now);
  /// The controller is not (or no longer) doing what the press on `command`
  /// asked, as table 1 shows (it stopped by itself: an obstacle, the
  /// joystick, a button, its watchdog): the press ends; a new press is
  /// needed (D-8). `why` says what the host saw.
  void on_controller_stop(uint16_t command, const std::string& why, TimePoint now);

  /// The value the controller must hold at hold-type `command` now (0: none).
  uint16_t wanted(uint16_t command) const noexcept { return hold(command).value; }
  /// The value and its press's serial (0x006A during a stop: the stop's).
  Hold hold(uint16_t command) const noexcept;
  /// True while a stop command is held (0x006A at 1): a loss of control, or
  /// the display's STOP, until the chair is still (and STOP is lifted).
  bool emergency() const noexcept { return emergency_; }
  /// True from the display's STOP until it is lifted.
  bool stop_latched() const noexcept { return stop_latched_; }
  /// The next time tick() has something to do (a lease's end), or nullopt.
  std::optional<TimePoint> wake_at() const noexcept;
  Disabled disabled() const;
  std::optional<ClientId> driver() const noexcept { return driver_; }
  /// True when an obstacle is closer than near_obstacle_mm while the chair moves.
  bool near_obstacle() const noexcept;
  const std::vector<Press>& presses() const noexcept { return presses_; }
  std::vector<Event> take_events() { return std::exchange(events_, {}); }
  const SessionOptions& options() const noexcept { return options_; }

 private:
  struct Client {
    ClientId id = 0;
    ClientKind kind = ClientKind::display;
    PressId last_press = 0;
    TimePoint idle_since{};
  };
  Client* find(ClientId id);
  const Client* find(ClientId id) const;
  rtukit::Status check_rules(const Client& c, uint16_t command, uint16_t value) const;
  /// Why a phone may not drive the chair as `snapshot_` shows it (none = may).
  Reason drive_block() const;
  /// The snapshot is a reading taken after the last outage.
  bool fresh() const noexcept { return snapshot_.valid && snapshot_.sequence >= fresh_from_; }
  void start_emergency(TimePoint now, const std::string& reason,
                       std::optional<ClientId> phone = std::nullopt);
  /// Ends every press `which` selects, with `reason`; `emergency`: a loss of
  /// control (0x006A, and every other press ends too).
  void end_where(const std::function<bool(const Press&)>& which, const std::string& reason, bool emergency,
                 TimePoint now);

  SessionOptions options_;
  std::vector<Client> clients_;
  std::vector<Press> presses_;
  std::vector<Event> events_;
  std::optional<ClientId> driver_;
  Snapshot snapshot_{};
  uint16_t active_error_ = kMasterCommunicationError;  ///< nothing known yet: as if the link were down
  uint64_t fresh_from_ = 1;   ///< the first snapshot sequence read after the last outage
  uint64_t next_serial_ = 1;  ///< the next press's (or stop's) serial
  bool emergency_ = false;    ///< 0x006A is held
  uint64_t emergency_serial_ = 0;
  bool stop_latched_ = false;  ///< the display's STOP, until lifted
};

}  // namespace rtukit::rehand6600
