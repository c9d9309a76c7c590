// The reference BLE client's decisions (`rtukit rehand6600 remote --ble`),
// pure: which command a key asks for, when a held key's press is renewed,
// when it counts as let go, and the state as one line. Time is passed in;
// the client's D-Bus side (programs/rehand_host/ble_remote.hpp) only carries
// bytes and keys.
//
// A terminal reports no key-up: a held key arrives as the terminal's
// auto-repeat (a first repeat after 250..660 ms, then every 30..40 ms). A
// hold key presses at its first byte; the press is renewed every 100 ms
// (well within the chair's 300 ms lease) while the key keeps repeating, and
// released when no repeat came for `key_gap` (longer than the first
// repeat's delay), when another key is pressed, or at space. A press the
// chair ended (a lapse, a refusal, an emergency stop) is never pressed
// again by the same held key: the key must be let go and pressed anew.
#pragma once
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/devices/rehand6600/ble_gatt.hpp"

namespace rtukit::rehand6600::ble {

class RemoteKeys {
 public:
  using TimePoint = rtukit::TimePoint;
  struct Options {
    std::chrono::milliseconds renew_every{100};
    std::chrono::milliseconds key_gap{700};  ///< no repeat for this long: the key was let go
  };
  explicit RemoteKeys(Options options) : options_(options) {}

  /// What the keys do, for the client's help line.
  static std::string_view help();

  /// One byte from the terminal at `now` (arrow keys are ESC [ A..D). The
  /// commands to write now, in order. Ctrl-C, Ctrl-D and 'x' ask to quit
  /// (quit() is true; everything held is released).
  std::vector<Command> on_byte(uint8_t byte, TimePoint now);
  /// The commands due at `now`: renewals of the held press, or its release
  /// when its key stopped repeating.
  std::vector<Command> due(TimePoint now);
  /// When due() has something to do next (nullopt: nothing is held).
  std::optional<TimePoint> wake_at() const;
  /// Releases whatever is held (the client is ending).
  std::vector<Command> release_all();
  /// The chair's answer to a command: a refusal or an end of the held press
  /// stops its renewals until its key is let go.
  void on_result(const Result& r);
  bool quit() const { return quit_; }
  /// The function held now, if any.
  std::optional<Function> held() const;

 private:
  Command next(Op op, Function f, uint32_t press);
  void release_held(std::vector<Command>& out);
  std::optional<Function> key_function(uint8_t byte);

  Options options_;
  uint32_t last_press_ = 0;
  uint16_t sequence_ = 0;
  struct Held {
    Function function;
    uint32_t press;
    TimePoint last_byte, last_sent;
    bool ended = false;           ///< the chair ended it: wait for the key to be let go
    uint16_t first_sequence = 0;  ///< its press's
  };
  std::optional<Held> held_;
  std::optional<std::pair<Function, TimePoint>> last_pulse_;  ///< a pulse key's repeats do nothing
  uint16_t last_pulse_sequence_ = 0;
  uint8_t escape_ = 0;  ///< 1 after ESC, 2 after ESC [
  bool quit_ = false;
};

/// The state on one line: "link up  battery 80 %  0 km/h  static  light off
/// ...  error none", with what a phone may not do now.
std::string describe(const State& s);

}  // namespace rtukit::rehand6600::ble
