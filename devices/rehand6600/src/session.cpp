// The remote-control rules (session.hpp). Every decision is a function of
// the session's state, the last status and the time passed in, so the tests
// run it on virtual time and a fuzzer can drive it with any sequence.
#include "rtukit/devices/rehand6600/session.hpp"

#include <fmt/core.h>

#include <algorithm>

#include "rtukit/devices/rehand6600/reference.hpp"

namespace rtukit::rehand6600 {
namespace {

rtukit::Status refuse(std::string reason) {
  return rtukit::Status(Errc::refused, std::move(reason));
}
rtukit::Status bad(std::string reason) {
  return rtukit::Status(Errc::invalid_argument, std::move(reason));
}

bool is_posture(uint16_t a) {
  return a >= reg::kStandSit && a <= reg::kPlateTilt;
}

std::string key_of(uint16_t command) {
  const Register* r = find_register(command);
  return r ? std::string(r->key) : fmt::format("0x{:04X}", command);
}

}  // namespace

bool may_press(ClientKind kind, uint16_t command) noexcept {
  const bool local = is_posture(command) || command == reg::kAntiPinch;
  const bool remote = reg::is_phone_drive(command) || command == reg::kPhoneHorn;
  return kind == ClientKind::display ? local : kind == ClientKind::phone ? remote : local || remote;
}

bool may_send(ClientKind kind, uint16_t command) noexcept {
  const bool local = command == reg::kLight || command == reg::kDriveMode || command == reg::kSpeedLevel;
  const bool remote =
      command == reg::kPhoneLight || command == reg::kPhoneLeftSignal || command == reg::kPhoneRightSignal;
  return kind == ClientKind::display ? local : kind == ClientKind::phone ? remote : local || remote;
}

Session::Client* Session::find(ClientId id) {
  for (Client& c : clients_)
    if (c.id == id) return &c;
  return nullptr;
}

const Session::Client* Session::find(ClientId id) const {
  for (const Client& c : clients_)
    if (c.id == id) return &c;
  return nullptr;
}

void Session::join(ClientId client, ClientKind kind) {
  if (find(client)) return;
  clients_.push_back(Client{.id = client, .kind = kind});
}

void Session::leave(ClientId client, TimePoint now) {
  const Client* c = find(client);
  if (!c) return;
  const bool phone = c->kind == ClientKind::phone;
  // D-12: a phone lost while it drives is a loss of control.
  end_where([&](const Press& p) { return p.client == client && reg::is_phone_drive(p.command); },
            "the phone's connection was lost", phone, now);
  end_where([&](const Press& p) { return p.client == client; },
            phone ? "the phone's connection was lost" : "the client left", false, now);
  clients_.erase(
      std::find_if(clients_.begin(), clients_.end(), [&](const Client& x) { return x.id == client; }));
  if (driver_ == client) {
    driver_.reset();
    events_.push_back(Event{.type = Event::Type::driver_changed});
  }
}

Disabled Session::disabled() const {
  Disabled d;
  if (active_error_) {
    d.all_reason = active_error_ == kMasterCommunicationError ? Reason::no_controller : Reason::error_active;
    d.all = active_error_ == kMasterCommunicationError
                ? fmt::format("{}: {}", error_text(active_error_), reason_text(Reason::no_controller))
                : fmt::format("{}{}", error_text(active_error_), reason_text(Reason::error_active));
  } else if (stop_latched_) {
    d.all_reason = Reason::stop_latched;
  } else if (emergency_) {
    d.all_reason = Reason::stopping;
  } else if (!fresh()) {
    d.all_reason = Reason::waiting;
  }
  if (d.all.empty()) d.all = std::string(reason_text(d.all_reason));
  const Snapshot& s = snapshot_;
  d.drive_reason = d.all_reason;
  if (d.drive_reason == Reason::none) d.drive_reason = drive_block();
  if (d.drive_reason == Reason::none && !s.is_static() && !driver_) d.drive_reason = Reason::not_static;
  d.drive = d.all_reason != Reason::none ? d.all : std::string(reason_text(d.drive_reason));
  d.raise_reason = d.all_reason;
  if (d.raise_reason == Reason::none && s.charging()) d.raise_reason = Reason::raise_charging;
  d.raise = d.all_reason != Reason::none ? d.all : std::string(reason_text(d.raise_reason));
  return d;
}

Reason Session::drive_block() const {
  const Snapshot& s = snapshot_;
  if (s.charging()) return Reason::charging;
  if (!s.clutch_drive()) return Reason::push_mode;
  if (!s.seated()) return Reason::not_seated;
  if (!s.joystick_neutral()) return Reason::joystick;
  return Reason::none;
}

// The rules every new press and one-shot command passes, with the reason
// the user reads.
rtukit::Status Session::check_rules(const Client& c, uint16_t command, uint16_t value) const {
  const Disabled d = disabled();
  if (!d.all.empty()) return refuse(d.all + (active_error_ ? "; only releasing is possible" : ""));
  if (reg::is_phone_drive(command)) {
    if (driver_ && *driver_ != c.id) return refuse(std::string(reason_text(Reason::another_driver)));
    // The driving phone may change direction while the chair still moves.
    if (!d.drive.empty() && !(driver_ == c.id && d.drive_reason == Reason::not_static))
      return refuse(d.drive);
  }
  const bool raising = (command == reg::kStandSit || command == reg::kSeatLift) && value == 1;
  if (raising && !d.raise.empty()) return refuse(d.raise);
  return {};
}

rtukit::Status Session::press(ClientId client, uint16_t command, uint16_t value, PressId id, TimePoint now) {
  Client* c = find(client);
  if (!c) return bad("not a client of this chair");
  const Register* r = find_register(command);
  if (!r || r->role != Role::hold || !may_press(c->kind, command))
    return bad(fmt::format("{} is not a command this client may hold", key_of(command)));
  if (value == 0 || check_value(*r, value) != Errc::ok)
    return bad(fmt::format("{}: value {} is not one of its values", r->key, value));
  if (id <= c->last_press)
    return bad(
        fmt::format("press {} is not new: a press needs a new id (the last was {})", id, c->last_press));
  c->last_press = id;
  if (rtukit::Status e = check_rules(*c, command, value)) return e;
  for (const Press& p : presses_)
    if (p.command == command && p.client != client)
      return refuse(fmt::format("{} is held by another client", r->key));
  // A client holds one press per command, and a phone one direction: a new
  // press replaces the old one (the finger moved).
  end_where(
      [&](const Press& p) {
        return p.client == client &&
               (p.command == command || (reg::is_phone_drive(command) && reg::is_phone_drive(p.command)));
      },
      "replaced by a new press", false, now);
  presses_.push_back(Press{client, id, command, value, now + options_.lease, next_serial_++});
  if (reg::is_phone_drive(command) && driver_ != client) {
    driver_ = client;
    events_.push_back(Event{.type = Event::Type::driver_changed, .client = client});
  }
  return {};
}

rtukit::Status Session::renew(ClientId client, PressId id, TimePoint now) {
  tick(now);  // a renewal that comes after the lease finds the press ended
  for (Press& p : presses_) {
    if (p.client != client || p.id != id) continue;
    // What forbids a phone to drive forbids it to go on driving.
    if (const std::string block(reason_text(reg::is_phone_drive(p.command) ? drive_block() : Reason::none));
        !block.empty()) {
      end_where([&](const Press& q) { return q.client == client && q.id == id; }, block, false, now);
      return refuse(block);
    }
    p.until = now + options_.lease;
    return {};
  }
  const Client* c = find(client);
  if (!c || id == 0 || id > c->last_press) return bad(fmt::format("no press {}", id));
  return refuse(fmt::format("press {} has ended: lift the finger and press again", id));
}

void Session::release(ClientId client, PressId id, TimePoint now) {
  end_where([&](const Press& p) { return p.client == client && p.id == id; }, "released", false, now);
}

void Session::stop_all(TimePoint now) {
  stop_latched_ = true;
  start_emergency(now, "the display's STOP");
}

void Session::lift_stop() {
  stop_latched_ = false;
}

void Session::shutdown(TimePoint now) {
  // A phone that was driving loses control when the host goes away.
  end_where(
      [&](const Press& p) {
        const Client* c = find(p.client);
        return reg::is_phone_drive(p.command) && c && c->kind == ClientKind::phone;
      },
      "the host is stopping", true, now);
  end_where([](const Press&) { return true; }, "the host is stopping", false, now);
}

rtukit::Status Session::check_command(ClientId client, uint16_t command, uint16_t value) const {
  const Client* c = find(client);
  if (!c) return bad("not a client of this chair");
  const Register* r = find_register(command);
  if (!r || (r->role != Role::pulse && r->role != Role::setting) || !may_send(c->kind, command))
    return bad(fmt::format("{} is not a command this client may send", key_of(command)));
  if (check_value(*r, value) != Errc::ok)
    return bad(fmt::format("{}: value {} is not one of its values", r->key, value));
  return check_rules(*c, command, value);
}

void Session::tick(TimePoint now) {
  // D-12: a phone that stops renewing a drive press has lost control,
  // whatever the reason (Wi-Fi gone quiet, the app frozen): stop hard.
  end_where(
      [&](const Press& p) {
        const Client* c = find(p.client);
        return now >= p.until && reg::is_phone_drive(p.command) && c && c->kind == ClientKind::phone;
      },
      "no renewal within the lease", true, now);
  end_where([&](const Press& p) { return now >= p.until; }, "no renewal within the lease", false, now);
  if (driver_) {
    const Client* c = find(*driver_);
    const bool holding =
        std::any_of(presses_.begin(), presses_.end(), [&](const Press& p) { return p.client == *driver_; });
    if (!c || (!holding && now - c->idle_since >= options_.driver_idle)) {
      driver_.reset();
      events_.push_back(Event{.type = Event::Type::driver_changed});
    }
  }
}

void Session::on_status(const Snapshot& snapshot, uint16_t active_error, TimePoint now, bool stop_settled) {
  if (snapshot.valid) snapshot_ = snapshot;
  // A link loss makes what was read before it history: the rules wait for
  // the first poll after the link is back.
  if (active_error == kMasterCommunicationError) fresh_from_ = snapshot_.sequence + 1;
  const bool raised = active_error != 0 && active_error != active_error_;
  active_error_ = active_error;
  if (raised) {
    // D-8: an error stops everything; nothing comes back when it clears.
    end_where([](const Press&) { return true; }, fmt::format("stopped by {}", error_text(active_error)),
              false, now);
  }
  if (fresh()) {
    // What forbids a phone to drive ends its drive (D-10, charging, push, the joystick taking over).
    if (const std::string block(reason_text(drive_block())); !block.empty()) {
      end_where(
          [&](const Press& p) {
            const Client* c = find(p.client);
            return reg::is_phone_drive(p.command) && c && c->kind == ClientKind::phone;
          },
          block, false, now);
    }
  }
  if (emergency_ && !stop_latched_ && stop_settled && fresh() && !active_error) {
    emergency_ = false;
    events_.push_back(Event{.type = Event::Type::emergency_ended});
  }
}

void Session::on_write_failed(uint16_t command, TimePoint now) {
  end_where([&](const Press& p) { return p.command == command; },
            "the controller did not confirm the command", false, now);
}

void Session::on_controller_stop(uint16_t command, const std::string& why, TimePoint now) {
  end_where([&](const Press& p) { return p.command == command; }, why, false, now);
}

Session::Hold Session::hold(uint16_t command) const noexcept {
  if (emergency_ && command == reg::kAntiPinch) return {1, emergency_serial_};
  for (const Press& p : presses_)
    if (p.command == command)
      return emergency_ && reg::is_phone_drive(command) ? Hold{} : Hold{p.value, p.serial};
  return {};
}

std::optional<Session::TimePoint> Session::wake_at() const noexcept {
  std::optional<TimePoint> at;
  for (const Press& p : presses_)
    if (!at || p.until < *at) at = p.until;
  // The seat frees at the end of the driver's idle time, counted from its
  // last press's end: only while it holds nothing (while it holds a press,
  // that press's end is the next thing to look at; its idle start may be
  // long past, and a wake-up in the past made the host's thread spin).
  if (driver_) {
    const Client* c = find(*driver_);
    const bool holding =
        std::any_of(presses_.begin(), presses_.end(), [&](const Press& p) { return p.client == *driver_; });
    if (c && !holding) {
      const TimePoint free = c->idle_since + options_.driver_idle;
      if (!at || free < *at) at = free;
    }
  }
  return at;
}

bool Session::near_obstacle() const noexcept {
  if (!snapshot_.valid || snapshot_.is_static()) return false;
  for (uint16_t a = reg::kDistanceFront; a < reg::kDistanceFront + 4; ++a)
    if (snapshot_[a] < options_.near_obstacle_mm) return true;
  return false;
}

void Session::end_where(const std::function<bool(const Press&)>& which, const std::string& reason,
                        bool emergency, TimePoint now) {
  std::vector<Press> ended;
  for (auto it = presses_.begin(); it != presses_.end();) {
    if (which(*it)) {
      ended.push_back(*it);
      it = presses_.erase(it);
    } else {
      ++it;
    }
  }
  if (ended.empty()) return;
  for (const Press& p : ended) {
    if (Client* c = find(p.client)) c->idle_since = now;
    events_.push_back(Event{.type = Event::Type::press_ended,
                            .client = p.client,
                            .press = p.id,
                            .command = p.command,
                            .emergency = emergency,
                            .reason = reason});
  }
  // The stop says which phone and why (the display shows it to the person in
  // the chair: a stop nobody explains looks like a fault of the chair).
  if (emergency)
    start_emergency(now, fmt::format("a phone lost control while driving: {}", reason), ended.front().client);
}

void Session::start_emergency(TimePoint now, const std::string& reason, std::optional<ClientId> phone) {
  // 0x006A stops every actuator too, and the controller clears its holds
  // (D-8), so every other press ends here as well: writing one again after
  // the stop would be a new rising edge, a restart by itself.
  if (!std::exchange(emergency_, true)) {
    emergency_serial_ = next_serial_++;
    Event e{.type = Event::Type::emergency_started, .reason = reason};
    if (phone) e.client = *phone;
    events_.push_back(std::move(e));
  }
  end_where([](const Press&) { return true; }, reason, false, now);
}

}  // namespace rtukit::rehand6600
