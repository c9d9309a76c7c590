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
//    never moves the chair. Only a new press does (D-12).
//  - Losing a phone is a loss of control, not a release: a phone press whose
//    lease lapses, or whose client leaves, stops through the controller's
//    stop command (0x006A, emergency braking, D-9), held until the chair is
//    still. A deliberate release, and any display press, stop normally.
//  - One phone drives at a time; it gives up the driver's seat when it has
//    held nothing for 2 s. A command held by one client cannot be taken by
//    another.
//  - Nothing starts under the error overlay (0x0026 or 1010) or while a loss
//    of control is being stopped; an error ends every press (D-8).
//  - Phone driving: not while charging or in push, not while the chair is
//    raised (D-10), only while the local side is static (joystick neutral
//    and the chair still) unless this phone is the one driving. No standing
//    up or raising the seat while charging (D-11).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/snapshot.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::rehand6600 {

/// What a client is. A display is on the chair (the touch HMI): postures,
/// anti-pinch, settings, the main light. A phone is remote: drive, horn,
/// lighting and turn signals only, and losing it is a loss of control. A
/// tool is a local program on the host (the CLI's `hold`, a test bench):
/// every command, under the same rules, its presses ending normally.
enum class ClientKind : uint8_t { display, phone, tool };

struct SessionOptions {
  std::chrono::milliseconds lease{300};         ///< a press lives this long after its last renewal
  std::chrono::milliseconds driver_idle{2000};  ///< a phone holding nothing this long leaves the driver's seat
  /// After a loss of control, 0x006A is held at least this many polls and
  /// until the chair reports it is still.
  unsigned emergency_min_polls = 2;
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

/// Why a kind of control is disabled now ("" = allowed), as pages show it.
struct Disabled {
  std::string all;    ///< every command (the error overlay, a loss of control being stopped)
  std::string drive;  ///< phone driving
  std::string raise;  ///< standing up, raising the seat
};

class Session {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;
  using ClientId = uint64_t;
  using PressId = uint64_t;

  struct Press {
    ClientId client = 0;
    PressId id = 0;
    uint16_t command = 0;
    uint16_t value = 0;
    TimePoint until{};
  };

  struct Event {
    enum class Type : uint8_t {
      press_ended,        ///< `press` of `client` on `command` ended (`reason`); `emergency`: by the stop command
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
  /// The display's Stop button: every press of every client ends at once.
  void stop_all(TimePoint now);
  /// May `client` send the one-shot command `command` = `value` now (a
  /// pulse: the light, turn signals; a setting: drive mode, speed level)?
  /// Errors as press().
  rtukit::Status check_command(ClientId client, uint16_t command, uint16_t value) const;

  /// Time passes: lapsed presses end, the driver's seat frees up.
  void tick(TimePoint now);
  /// What the controller looks like after a poll (or the link's state when
  /// a poll failed): `active_error` is 1010 while the link is down, else
  /// 0x0026. An error ends every press (D-8).
  void on_status(const Snapshot& snapshot, uint16_t active_error, TimePoint now);
  /// A press's write failed: it ends (any doubt about motion: stop).
  void on_write_failed(uint16_t command, TimePoint now);

  /// The value the controller must hold at hold-type `command` now (0: none).
  uint16_t wanted(uint16_t command) const noexcept;
  /// True while a loss of control is being stopped (0x006A held at 1).
  bool emergency() const noexcept { return emergency_; }
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
  bool emergency_ = false;
  unsigned emergency_polls_ = 0;
};

}  // namespace rtukit::rehand6600
