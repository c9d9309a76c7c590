// Why the key rules are what they are: see ble_remote.hpp. Every hold goes
// through a press id of its own, so a release or a late renewal can never
// be mistaken for another press by the session.
#include "rtukit/devices/rehand6600/ble_remote.hpp"

#include <fmt/core.h>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"

namespace rtukit::rehand6600::ble {

std::string_view RemoteKeys::help() {
  return "hold w/a/s/d or the arrows to drive, h the horn; q/e turn signals, l the light; "
         "space stops, x or Ctrl-C quits";
}

Command RemoteKeys::next(Op op, Function f, uint32_t press) {
  return Command{.op = op, .function = f, .value = 1, .press = press, .sequence = ++sequence_};
}

std::optional<Function> RemoteKeys::held() const {
  if (held_ && !held_->ended) return held_->function;
  return std::nullopt;
}

void RemoteKeys::release_held(std::vector<Command>& out) {
  if (held_ && !held_->ended) out.push_back(next(Op::release, held_->function, held_->press));
  held_.reset();
}

std::vector<Command> RemoteKeys::release_all() {
  std::vector<Command> out;
  release_held(out);
  return out;
}

std::optional<Function> RemoteKeys::key_function(uint8_t byte) {
  // Arrow keys: ESC [ A (up) B (down) C (right) D (left).
  if (escape_ == 1) {
    escape_ = byte == '[' ? 2 : 0;
    return std::nullopt;
  }
  if (escape_ == 2) {
    escape_ = 0;
    switch (byte) {
      case 'A':
        return Function::forward;
      case 'B':
        return Function::reverse;
      case 'C':
        return Function::right;
      case 'D':
        return Function::left;
      default:
        return std::nullopt;
    }
  }
  switch (byte) {
    case 0x1B:
      escape_ = 1;
      return std::nullopt;
    case 'w':
    case 'W':
      return Function::forward;
    case 's':
    case 'S':
      return Function::reverse;
    case 'a':
    case 'A':
      return Function::left;
    case 'd':
    case 'D':
      return Function::right;
    case 'h':
    case 'H':
      return Function::horn;
    case 'q':
    case 'Q':
      return Function::left_signal;
    case 'e':
    case 'E':
      return Function::right_signal;
    case 'l':
    case 'L':
      return Function::light;
    default:
      return std::nullopt;
  }
}

std::vector<Command> RemoteKeys::on_byte(uint8_t byte, TimePoint now) {
  std::vector<Command> out;
  if (escape_ == 0 && (byte == 0x03 || byte == 0x04 || byte == 'x' || byte == 'X')) {
    quit_ = true;
    release_held(out);
    return out;
  }
  if (escape_ == 0 && byte == ' ') {
    release_held(out);
    return out;
  }
  const std::optional<Function> f = key_function(byte);
  if (!f) return out;
  if (!is_hold(*f)) {
    // The terminal repeats a held key: one pulse per press of the key.
    const bool repeat =
        last_pulse_ && last_pulse_->first == *f && now - last_pulse_->second < options_.key_gap;
    last_pulse_ = {*f, now};
    if (!repeat) {
      out.push_back(next(Op::pulse, *f, 0));  // a pulse has no press id
      last_pulse_sequence_ = out.back().sequence;
    }
    return out;
  }
  if (held_ && held_->function == *f) {
    held_->last_byte = now;  // still held (ended or not: a new press needs the key let go)
    return out;
  }
  release_held(out);  // another key: the first one is let go
  held_ = Held{*f, ++last_press_, now, now};
  out.push_back(next(Op::press, *f, held_->press));
  held_->first_sequence = out.back().sequence;
  return out;
}

std::vector<Command> RemoteKeys::due(TimePoint now) {
  std::vector<Command> out;
  if (!held_) return out;
  if (now - held_->last_byte >= options_.key_gap) {
    release_held(out);
  } else if (!held_->ended && now - held_->last_sent >= options_.renew_every) {
    held_->last_sent = now;
    out.push_back(next(Op::renew, held_->function, held_->press));
  }
  return out;
}

std::optional<RemoteKeys::TimePoint> RemoteKeys::wake_at() const {
  if (!held_) return std::nullopt;
  const TimePoint let_go = held_->last_byte + options_.key_gap;
  if (held_->ended) return let_go;
  return std::min(let_go, held_->last_sent + options_.renew_every);
}

void RemoteKeys::on_result(const Result& r) {
  if (!held_ || held_->ended || r.code == ResultCode::accepted) return;
  // About the held press: its press and renewals carry the sequences from
  // the press's own on (a release of an earlier press is older; a pulse
  // sent meanwhile is known). Sequences wrap: compare by distance.
  const auto since = static_cast<uint16_t>(r.sequence - held_->first_sequence);
  const auto sent = static_cast<uint16_t>(sequence_ - held_->first_sequence);
  if (since > sent || r.sequence == last_pulse_sequence_) return;
  held_->ended = true;  // refused or ended: no more renewals until the key is let go
}

std::string describe(const State& s) {
  if (!s.link) return fmt::format("no controller (1010)  battery {} %", s.battery);
  const Row* motion = find_register(reg::kMotion);
  std::string line = fmt::format("battery {} %  {} km/h  {}  light {}", s.battery, s.speed_kmh,
                                 motion ? profile::format_value(*motion, s.motion) : std::to_string(s.motion),
                                 s.main_light ? "on" : "off");
  if (s.left_signal) line += "  <- signal";
  if (s.right_signal) line += "  signal ->";
  if (s.charging) line += "  charging";
  if (!s.clutch_drive) line += "  clutch in push";
  if (s.driving) line += "  a phone drives";
  if (s.emergency) line += "  EMERGENCY STOP";
  // The chair's reason in full (a code: the state has no room for words).
  if (s.all_disabled)
    line += fmt::format("  (nothing may move: {})",
                        s.all_reason != Reason::none ? reason_text(s.all_reason) : "see the display");
  else if (s.drive_disabled)
    line += fmt::format("  (no phone driving now: {})",
                        s.drive_reason != Reason::none ? reason_text(s.drive_reason) : "see the display");
  line += "  error ";
  line += s.active_error ? error_text(s.active_error) : std::string("none");
  return line;
}

}  // namespace rtukit::rehand6600::ble
