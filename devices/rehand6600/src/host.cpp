// The host protocol. Events are collected under the lock and delivered after
// it is released, so a handler may call back into the Host.
#include "rtukit/devices/rehand6600/host.hpp"

#include <fmt/core.h>

#include <utility>
#include <vector>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/motion.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/verbs.hpp"

namespace rtukit::rehand6600 {
namespace {

std::string failure_text(Error e) {
  if (e.is_exception()) return fmt::format("Modbus exception {:02X} ({})", e.exception_code(), e.name());
  return std::string(e.name());
}

}  // namespace

Host::Host(std::unique_ptr<io::Link> link, HostOptions options)
    : options_(options),
      clock_(clock_or_steady(options.clock)),
      master_(std::move(link), MasterOptions{.response_timeout = options.response_timeout,
                                             .quirks = kProfile.quirks,
                                             .clock = &clock_,
                                             .trace = options.trace}),
      core_(options),
      worker_([this](HostLogic::TimePoint) { return step(); }, BusWorker::Options{.clock = &clock_}) {
  core_.session().join(kLocalClient, ClientKind::tool);
}

Host::~Host() {
  stop();
}

void Host::on_event(std::function<void(const Event&)> handler) {
  handler_ = std::move(handler);
}

void Host::start() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = false;
  }
  worker_.start();
}

void Host::notify() {
  cv_.notify_all();
  worker_.wake();
}

void Host::stop() {
  if (!worker_.running()) return;
  // The worker is told to stop first, so the stops below are the last writes.
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  worker_.stop();
  {
    std::lock_guard lock(mutex_);
    core_.begin_shutdown(clock_.now());
  }
  // Every stop still owed, each tried a few times (a lost answer is normal
  // on RS-485): a release asked for just before stop() whose 0 was not sent
  // yet, a 0 whose answer was lost, a phone's loss of control (0x006A = 1,
  // left held). The controller's watchdog is the backstop.
  for (;;) {
    std::optional<HostLogic::Request> request;
    {
      std::lock_guard lock(mutex_);
      request = core_.next(clock_.now());
    }
    if (!request) break;
    const Error e = write_command(request->address, request->value);
    std::lock_guard lock(mutex_);
    core_.on_result(clock_.now(), e);
  }
}

void Host::emit(const Event& e) {
  if (handler_) handler_(e);
}

// ---------------------------------------------------------------- HostLogic

namespace {

// The hold-type commands the host writes for presses and stops: the
// postures, anti-pinch, phone drive and horn (what a tool may press). Not
// host-ready (the handshake's), not SOS (reserved, never written).
bool is_held_command(uint16_t command) {
  return may_press(ClientKind::tool, command);
}

std::string key_of(uint16_t command) {
  const Register* r = find_register(command);
  return r ? std::string(r->key) : fmt::format("0x{:04X}", command);
}

// "No answer" proves nothing about the controller; an exception is an answer.
bool unanswered(Error e) {
  return e && !e.is_exception();
}

}  // namespace

HostLogic::HostLogic(const HostOptions& options) : options_(options) {
  for (uint16_t i = 0; i < reg::kCommandCount; ++i)
    commands_[i].maybe = is_held_command(static_cast<uint16_t>(reg::kCommandFirst + i));
}

std::optional<uint16_t> HostLogic::stop_owed(uint16_t command) const {
  const Command& c = commands_[index(command)];
  if (command == reg::kAntiPinch) {
    if (c.want != 0) return c.known && c.confirmed != 0 ? std::nullopt : std::optional<uint16_t>(c.want);
    // Released only when the chair is still (two polls after the 1).
    return c.maybe && stop_settled() ? std::optional<uint16_t>(0) : std::nullopt;
  }
  return c.want == 0 && c.maybe ? std::optional<uint16_t>(0) : std::nullopt;
}

bool HostLogic::stop_settled() const noexcept {
  const Command& c = commands_[index(reg::kAntiPinch)];
  if (c.want != 0 && !(c.known && c.confirmed != 0)) return false;  // the 1 is not on the controller yet
  return still_polls_ >= 2;
}

bool HostLogic::stops_owed() const {
  for (uint16_t command = reg::kCommandFirst; command < reg::kCommandFirst + reg::kCommandCount; ++command)
    if (is_held_command(command) && stop_owed(command)) return true;
  return false;
}

std::optional<HostLogic::Request> HostLogic::next_stop() {
  const auto sendable = [&](const Command& c) {
    if (shutting_down_) return c.attempts < kShutdownAttempts;
    return !connected_ || !c.after_poll;
  };
  const auto take = [&](uint16_t command, uint16_t value) {
    Command& c = commands_[index(command)];
    if (shutting_down_) ++c.attempts;
    return Request{Request::Kind::write, command, value, 0, true};
  };
  // The stop command first: it stops every actuator and the wheels at once.
  if (const auto v = stop_owed(reg::kAntiPinch); v && *v != 0 && sendable(commands_[index(reg::kAntiPinch)]))
    return take(reg::kAntiPinch, *v);
  // Then the zeros, each in turn (one that keeps failing does not starve the others).
  for (size_t k = 0; k < reg::kCommandCount; ++k) {
    const size_t i = (stop_cursor_ + k) % reg::kCommandCount;
    const auto command = static_cast<uint16_t>(reg::kCommandFirst + i);
    if (!is_held_command(command)) continue;
    const auto v = stop_owed(command);
    if (!v || !sendable(commands_[i])) continue;
    stop_cursor_ = i + 1;
    return take(command, *v);
  }
  return std::nullopt;
}

std::optional<HostLogic::Request> HostLogic::next_press() {
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    const auto command = static_cast<uint16_t>(reg::kCommandFirst + i);
    Command& c = commands_[i];
    if (command == reg::kAntiPinch || !is_held_command(command)) continue;
    if (c.want == 0 || c.serial == c.written) continue;
    // Once per press: from here the controller may hold it, whatever the answer.
    c.written = c.serial;
    c.maybe = true;
    c.watch = Watch::none;
    return Request{Request::Kind::write, command, c.want, 0, true};
  }
  return std::nullopt;
}

std::optional<HostLogic::Request> HostLogic::next(TimePoint now) {
  if (in_flight_) return std::nullopt;
  if (shutting_down_) {
    // A dead link is not tried for ever: as many unanswered requests as make a 1010.
    if (!identified_ || failures_ >= options_.failures_to_error) return std::nullopt;
    in_flight_ = next_stop();
    return in_flight_;
  }
  // Stops first, whenever the controller is known: while connected at once,
  // while the link is down at the poll rate, in place of the handshake (a 0
  // is idempotent, and the sooner it lands after the link is back, the
  // shorter the motion nobody holds; its answer is the sign the link is back).
  if (identified_ && (connected_ || phase_ == Phase::write_ready || now >= stop_retry_)) {
    if ((in_flight_ = next_stop())) return in_flight_;
  }
  if (identified_ && !connected_ && phase_ == Phase::read_id && stops_owed()) return std::nullopt;
  if (connected_) {
    if ((in_flight_ = next_press())) return in_flight_;
    if (!oneshots_.empty()) {
      in_flight_ = oneshots_.front();
      oneshots_.pop_front();
      return in_flight_;
    }
  }
  if (phase_ == Phase::write_ready) {
    in_flight_ = Request{Request::Kind::write, reg::kHostReady, 1};
    return in_flight_;
  }
  if (now < next_at_) return std::nullopt;
  sent_at_ = now;
  in_flight_ = Request{phase_ == Phase::poll ? Request::Kind::poll : Request::Kind::read_device_id};
  return in_flight_;
}

HostLogic::TimePoint HostLogic::wake_at() const noexcept {
  if (in_flight_) return next_at_;
  if (shutting_down_) return TimePoint::min();
  bool stop = false, deferred_only = true;
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    const auto command = static_cast<uint16_t>(reg::kCommandFirst + i);
    if (!is_held_command(command) || !stop_owed(command)) continue;
    stop = true;
    deferred_only = deferred_only && commands_[i].after_poll;
  }
  if (identified_ && stop) {
    if (!connected_ && phase_ != Phase::write_ready) return stop_retry_;
    if (!deferred_only) return TimePoint::min();
  }
  if (connected_) {
    if (!oneshots_.empty()) return TimePoint::min();
    for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
      const Command& c = commands_[i];
      const auto command = static_cast<uint16_t>(reg::kCommandFirst + i);
      if (command != reg::kAntiPinch && is_held_command(command) && c.want != 0 && c.serial != c.written)
        return TimePoint::min();
    }
  }
  if (phase_ == Phase::write_ready) return TimePoint::min();
  return next_at_;
}

HostLogic::TimePoint::duration HostLogic::period() const noexcept {
  return std::chrono::duration_cast<TimePoint::duration>(
      std::chrono::duration<double>(1.0 / options_.poll_hz));
}

void HostLogic::on_result(TimePoint now, Error e, std::span<const uint16_t> words) {
  const std::optional<Request> done = std::exchange(in_flight_, std::nullopt);
  if (!done) return;
  if (done->kind == Request::Kind::write && done->address != reg::kHostReady) return on_write(now, *done, e);
  switch (phase_) {
    case Phase::read_id:
      if (e) {
        raise_comm_error(e, "handshake: " + failure_text(e));
      } else if (words.empty() || words[0] != kDeviceId) {
        identified_ = false;  // another device: nothing is written to it
        raise_comm_error(Error::refused("not a Rehand 6600 controller"),
                         "handshake: " + device_id_mismatch(words.empty() ? 0 : words[0]));
      } else {
        identified_ = true;
        phase_ = Phase::write_ready;
        return;
      }
      next_at_ = sent_at_ + options_.handshake_retry;
      return;
    case Phase::write_ready:
      if (e) {
        raise_comm_error(e, "handshake: boot-complete write: " + failure_text(e));
        phase_ = Phase::read_id;
        next_at_ = sent_at_ + options_.handshake_retry;
        return;
      }
      connected_ = true;
      failures_ = 0;
      last_failure_ = {};
      if (std::exchange(comm_error_, false))
        events_.push_back(Event{Event::Type::error_cleared, 0, 0, 0, kMasterCommunicationError, {}});
      events_.push_back(Event{Event::Type::connected});
      phase_ = Phase::poll;
      next_at_ = now;  // the state at once: nothing is allowed before the first poll
      return;
    case Phase::poll:
      on_poll(now, e, words);
      return;
  }
}

void HostLogic::on_write(TimePoint now, const Request& done, Error e) {
  const bool was_down = !connected_ && phase_ == Phase::read_id;  // a stop tried while the link is down
  if (done.ticket) results_.emplace_back(done.ticket, e);
  if (done.target) {
    Command& c = commands_[index(done.address)];
    if (!e) {
      c.known = true;
      c.confirmed = done.value;
      c.maybe = done.value != 0;
      c.after_poll = false;
      if (done.address == reg::kAntiPinch && done.value != 0) still_polls_ = 0;  // the stop's polls start now
      // A press's word: what the polls from now on show of it.
      if (done.value != 0 && done.address != reg::kAntiPinch && c.serial == c.written &&
          c.want == done.value && effect_of(done.address, done.value, snapshot_) != Effect::unknown) {
        c.watch = Watch::starting;
        c.deadline = now + options_.start_timeout;
      }
    } else {
      // The controller may have executed it before the answer was lost, or
      // may still hold the word before it.
      c.known = false;
      if (done.value != 0) c.maybe = true;
      if (e.is_exception()) c.after_poll = true;  // refused: again after a poll, not in a loop
      if (done.value != 0 && done.address != reg::kAntiPinch) {
        // A press's word is not written again: the session ends the press,
        // and its 0 is owed until confirmed.
        c.watch = Watch::none;
        events_.push_back(Event{Event::Type::write_failed, done.address, 0, done.value, 0, failure_text(e)});
      }
    }
  }
  if (unanswered(e)) {
    count_failure(e, fmt::format("write of {} = {}", key_of(done.address), done.value));
  } else {
    failures_ = 0;
  }
  if (was_down) {
    if (!unanswered(e))
      next_at_ = now;  // the controller answers again: the handshake at once
    else
      stop_retry_ = now + period();
  }
}

void HostLogic::count_failure(Error e, const std::string& what) {
  last_failure_ = rtukit::Status(e, fmt::format("{}: {}", what, failure_text(e)));
  if (shutting_down_) {
    ++failures_;  // next() gives up on a dead link
    return;
  }
  if (connected_ && ++failures_ >= options_.failures_to_error)
    raise_comm_error(e, fmt::format("{} consecutive requests failed (last: {}, {})",
                                    options_.failures_to_error, what, failure_text(e)));
  else if (!connected_)
    ++failures_;
}

void HostLogic::on_poll(TimePoint now, Error e, std::span<const uint16_t> words) {
  next_at_ = sent_at_ + period();
  if (e || words.size() != reg::kStatusCount) {
    if (!e) e = Errc::unexpected_response;
    if (e.is_exception()) failures_ = 0;  // an answer, though not the one wanted
    last_failure_ = rtukit::Status(e, "poll: " + failure_text(e));
    if (!connected_) return;
    if (unanswered(e) || e.code() == Errc::unexpected_response) {
      if (++failures_ >= options_.failures_to_error)
        raise_comm_error(
            e, fmt::format("{} consecutive polls failed ({})", options_.failures_to_error, failure_text(e)));
    }
    return;
  }
  failures_ = 0;
  Snapshot next;
  std::copy(words.begin(), words.end(), next.regs.begin());
  const Snapshot& prev = snapshot_;
  for (uint16_t a = 0; a < reg::kStatusCount && prev.valid; ++a) {
    if (prev.regs[a] != next.regs[a])
      events_.push_back({Event::Type::changed, a, prev.regs[a], next.regs[a]});
  }
  const auto rising = [&](uint16_t a) { return next.regs[a] != 0 && (!prev.valid || prev.regs[a] == 0); };
  if (rising(reg::kHornButton)) events_.push_back({Event::Type::horn, reg::kHornButton, 0, 1});
  if (rising(reg::kViewButton)) events_.push_back({Event::Type::view, reg::kViewButton, 0, 1});
  const uint16_t before = prev.valid ? prev.error_code() : 0;
  if (before != next.error_code()) {
    if (before) events_.push_back({Event::Type::error_cleared, reg::kErrorCode, 0, 0, before, {}});
    if (next.error_code())
      events_.push_back({Event::Type::error_raised, reg::kErrorCode, 0, 0, next.error_code(),
                         error_text(next.error_code())});
  }
  next.valid = true;
  next.sequence = prev.sequence + 1;
  snapshot_ = next;
  still_polls_ = snapshot_.still() ? still_polls_ + 1 : 0;
  for (Command& c : commands_) c.after_poll = false;
  watch_presses(now);
}

// Nothing is written again after a poll (D-8): when table 1 shows that the
// controller is not doing what a press asked, the press ends here instead.
void HostLogic::watch_presses(TimePoint now) {
  if (snapshot_.error_code() != 0) return;  // the error ends every press, with its own reason
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    Command& c = commands_[i];
    const auto command = static_cast<uint16_t>(reg::kCommandFirst + i);
    if (c.watch == Watch::none || c.want == 0 || c.written != c.serial) continue;
    const Effect effect = effect_of(command, c.want, snapshot_);
    if (effect == Effect::moving || effect == Effect::at_end) {
      c.watch = Watch::running;
      continue;
    }
    if (effect != Effect::none) continue;
    if (c.watch == Watch::running) {
      c.watch = Watch::none;
      events_.push_back(
          Event{Event::Type::chair_stopped, command, 0, c.want, 0,
                fmt::format("the chair stopped {} by itself (an obstacle, the joystick, a button, "
                            "a limit of its own or its watchdog): press again",
                            key_of(command))});
    } else if (now >= c.deadline) {
      c.watch = Watch::none;
      events_.push_back(Event{Event::Type::chair_stopped, command, 0, c.want, 0,
                              fmt::format("the chair did not start {}: press again", key_of(command))});
    }
  }
}

void HostLogic::raise_comm_error(Error cause, const std::string& reason) {
  last_failure_ = rtukit::Status(cause, reason);
  connected_ = false;
  failures_ = 0;
  phase_ = Phase::read_id;
  // What the controller holds is unknown from now on; what it may hold is
  // still owed its 0 (and a held stop its 1): tried while the link is down,
  // and first after the handshake. The session ends every press (D-8).
  for (Command& c : commands_) {
    c.known = false;
    c.watch = Watch::none;
    c.after_poll = false;
  }
  stop_retry_ = {};  // an owed stop is tried at once, then at the poll rate
  fail_queued(cause);
  if (!comm_error_) {
    comm_error_ = true;
    events_.push_back(Event{Event::Type::error_raised, 0, 0, 0, kMasterCommunicationError, reason});
  }
}

void HostLogic::fail_queued(Error e) {
  for (const Request& r : oneshots_)
    if (r.ticket) results_.emplace_back(r.ticket, e);
  oneshots_.clear();
}

void HostLogic::set_target(uint16_t command, uint16_t value, uint64_t serial) {
  Command& c = commands_[index(command)];
  if (value == 0) serial = 0;
  if (c.want == value && c.serial == serial) return;
  c.want = value;
  c.serial = serial;
  if (c.serial != c.written) c.watch = Watch::none;
}

bool HostLogic::enqueue(uint16_t address, uint16_t value, uint64_t ticket) {
  if (!connected_ || shutting_down_ || oneshots_.size() >= kQueueLimit) return false;
  oneshots_.push_back(Request{Request::Kind::write, address, value, ticket, false});
  return true;
}

void HostLogic::begin_shutdown() {
  shutting_down_ = true;
  failures_ = 0;
  for (Command& c : commands_) c.attempts = 0;
  fail_queued(Errc::not_connected);
}

uint16_t HostLogic::active_error() const noexcept {
  if (comm_error_ || !connected_) return kMasterCommunicationError;
  return snapshot_.valid ? snapshot_.error_code() : 0;
}

// ---------------------------------------------------------------- Host: the logic on a thread

// ---------------------------------------------------------------- HostCore: the logic and the rules joined

void HostCore::sync(TimePoint now) {
  now_ = now;
  session_.tick(now);
  // D-14: a remote driver drives at speed level 1, and the display's level
  // comes back when the seat is free. The write of level 1 goes first; the
  // drive words wait for its confirmation (a one-shot is written before the
  // polls, so the wait is one request).
  const bool remote = session_.driver().has_value();
  if (!remote && slow_ == Slow::yes) {
    slow_ = Slow::no;
    if (chosen_speed_ != 1) (void)logic_.enqueue(reg::kSpeedLevel, chosen_speed_, kRestoreTicket);
  }
  if (remote && slow_ == Slow::no && now >= slow_retry_at_ &&
      logic_.enqueue(reg::kSpeedLevel, 1, kSlowTicket))
    slow_ = Slow::asked;
  for (uint16_t command = reg::kCommandFirst; command < reg::kCommandFirst + reg::kCommandCount; ++command) {
    if (!may_press(ClientKind::tool, command)) continue;
    Session::Hold h = session_.hold(command);
    if (reg::is_phone_drive(command) && slow_ != Slow::yes) h = {};
    logic_.set_target(command, h.value, h.serial);
  }
}

// The logic's results appear only in its on_result() and begin_shutdown():
// absorbed right after the first (on_result) and before any are handed on
// (take_results), so sync() needs no look of its own.
void HostCore::absorb_results(TimePoint now) {
  for (auto& [ticket, error] : logic_.take_results()) {
    if (ticket == kSlowTicket) {
      if (error) {
        // Any doubt: the drive presses waiting for it end (nothing of them
        // was written), and the write is tried again at the next press after
        // a pause (a controller that refuses it is not asked at bus speed).
        slow_ = Slow::no;
        slow_retry_at_ = now + std::chrono::milliseconds(500);
        for (uint16_t c = reg::kPhoneForward; c <= reg::kPhoneRight; ++c)
          session_.on_controller_stop(c, fmt::format("{}: press again", reason_text(Reason::speed_level)),
                                      now);
      } else if (session_.driver()) {
        slow_ = Slow::yes;
      } else {
        // The seat was given up while the write was on its way.
        slow_ = Slow::no;
        if (chosen_speed_ != 1) (void)logic_.enqueue(reg::kSpeedLevel, chosen_speed_, kRestoreTicket);
      }
    } else if (ticket != kRestoreTicket) {  // a restore that failed leaves the chair slow: the safe side
      results_.emplace_back(ticket, error);
    }
  }
}

std::vector<std::pair<uint64_t, Error>> HostCore::take_results() {
  absorb_results(now_);
  return std::exchange(results_, {});
}

rtukit::Status HostCore::queue(Session::ClientId client, uint16_t command, uint16_t value, uint64_t ticket) {
  if (rtukit::Status e = session_.check_command(client, command, value)) return e;
  if (command == reg::kSpeedLevel && session_.driver())
    return rtukit::Status(
        Errc::refused,
        "a phone is driving: the chair stays at speed level 1 until it gives up the seat (D-14)");
  const Register& r = *find_register(command);
  // A pulse is two writes with one ticket: its outcome is the last one's.
  if (r.role == Role::pulse) {
    if (!logic_.enqueue(command, command == reg::kPhoneLight ? 2 : 1, 0) ||
        !logic_.enqueue(command, 0, ticket))
      return rtukit::Status(Errc::refused, logic_.connected() ? "the controller's queue is full: try again"
                                                              : "no communication with the controller");
    return {};
  }
  if (!logic_.enqueue(command, value, ticket))
    return rtukit::Status(Errc::refused, logic_.connected() ? "the controller's queue is full: try again"
                                                            : "no communication with the controller");
  if (command == reg::kSpeedLevel) chosen_speed_ = value;
  if (command == reg::kDriveMode) chosen_drive_mode_ = value;
  return {};
}

HostState HostCore::state() const {
  return {.snapshot = logic_.snapshot(),
          .connected = logic_.connected(),
          .active_error = logic_.active_error(),
          .presses = session_.presses(),
          .disabled = session_.disabled(),
          .driver = session_.driver(),
          .emergency = session_.emergency(),
          .near_obstacle = session_.near_obstacle(),
          .stop_latched = session_.stop_latched(),
          .speed_level = speed_level(),
          .chosen_speed = chosen_speed_,
          .drive_mode = chosen_drive_mode_};
}

std::optional<HostLogic::Request> HostCore::next(TimePoint now) {
  sync(now);
  return logic_.next(now);
}

void HostCore::on_result(TimePoint now, Error e, std::span<const uint16_t> words) {
  now_ = now;
  logic_.on_result(now, e, words);
  // An error's own reason first (it ends every press), then what the write
  // and the polls said of single presses.
  session_.on_status(logic_.snapshot(), logic_.active_error(), now, logic_.stop_settled());
  absorb_results(now);
  for (Event& ev : logic_.take_events()) {
    // A handshake: the controller may have restarted at its power-on level,
    // or kept any; a remote driver's level 1 is written again before it drives.
    if (ev.type == Event::Type::connected && slow_ == Slow::yes) slow_ = Slow::no;
    if (ev.type == Event::Type::write_failed) session_.on_write_failed(ev.address, now);
    if (ev.type == Event::Type::chair_stopped) session_.on_controller_stop(ev.address, ev.reason, now);
    events_.push_back(std::move(ev));
  }
  sync(now);
}

HostCore::TimePoint HostCore::wake_at() const {
  TimePoint wake = logic_.wake_at();
  if (const auto lapse = session_.wake_at(); lapse && *lapse < wake) wake = *lapse;
  return wake;
}

std::vector<Event> HostCore::take_events() {
  std::vector<Event> out = std::exchange(events_, {});
  for (Event& e : logic_.take_events()) out.push_back(std::move(e));
  for (const Session::Event& s : session_.take_events()) {
    using T = Session::Event::Type;
    Event e(s.type == T::press_ended         ? Event::Type::released
            : s.type == T::emergency_started ? Event::Type::emergency_started
            : s.type == T::emergency_ended   ? Event::Type::emergency_ended
                                             : Event::Type::driver_changed,
            s.command, 0, 0, 0, s.reason);
    e.client = s.client;
    e.press = s.press;
    e.emergency = s.emergency;
    out.push_back(std::move(e));
  }
  return out;
}

void HostCore::begin_shutdown(TimePoint now) {
  session_.shutdown(now);
  sync(now);
  logic_.begin_shutdown();
}

// ---------------------------------------------------------------- Host: the core on a thread

std::vector<Event> Host::collect() {
  std::vector<Event> out = core_.take_events();
  for (const auto& [ticket, error] : core_.take_results()) {
    finished_.emplace_back(ticket, error);
    if (finished_.size() > 64) finished_.pop_front();
  }
  return out;
}

HostLogic::TimePoint Host::step() {
  std::optional<HostLogic::Request> request;
  std::vector<Event> events;
  {
    std::lock_guard lock(mutex_);
    request = core_.next(clock_.now());
    events = collect();
    if (!request && events.empty()) return core_.wake_at();
  }
  cv_.notify_all();
  for (const Event& ev : events) emit(ev);
  if (!request) return clock_.now();  // the events may have changed what is due: look again
  std::array<uint16_t, reg::kStatusCount> words{};
  size_t n = 0;
  Error e;
  switch (request->kind) {
    case HostLogic::Request::Kind::read_device_id:
      n = 1;
      e = master_.read_holding_registers(options_.unit, reg::kDeviceId, std::span(words.data(), n));
      break;
    case HostLogic::Request::Kind::poll:
      n = reg::kStatusCount;
      e = master_.read_holding_registers(options_.unit, 0, words);
      break;
    case HostLogic::Request::Kind::write:
      e = write_command(request->address, request->value);
      break;
  }
  {
    std::lock_guard lock(mutex_);
    core_.on_result(clock_.now(), e, std::span<const uint16_t>(words.data(), e ? 0 : n));
    events = collect();
  }
  cv_.notify_all();
  for (const Event& ev : events) emit(ev);
  return clock_.now();  // one request a step: the next is decided afresh
}

HostState Host::state() const {
  std::lock_guard lock(mutex_);
  return core_.state();
}

Snapshot Host::snapshot() const {
  std::lock_guard lock(mutex_);
  return core_.logic().snapshot();
}

bool Host::connected() const {
  std::lock_guard lock(mutex_);
  return core_.logic().connected();
}

uint16_t Host::active_error() const {
  std::lock_guard lock(mutex_);
  return core_.logic().active_error();
}

rtukit::Status Host::last_failure() const {
  std::lock_guard lock(mutex_);
  return core_.logic().last_failure();
}

bool Host::wait_connected(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return cv_.wait_for(lock, timeout,
                      [this] { return core_.logic().connected() && core_.logic().snapshot().valid; });
}

bool Host::wait_poll(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  const uint64_t seen = core_.logic().snapshot().sequence;
  return cv_.wait_for(lock, timeout, [&] { return core_.logic().snapshot().sequence > seen; });
}

// ---------------------------------------------------------------- the session, from any thread

void Host::join(ClientId client, ClientKind kind) {
  std::lock_guard lock(mutex_);
  core_.session().join(client, kind);
}

void Host::leave(ClientId client) {
  {
    std::lock_guard lock(mutex_);
    core_.session().leave(client, clock_.now());
  }
  notify();
}

rtukit::Status Host::press(ClientId client, uint16_t command, uint16_t value, PressId id) {
  rtukit::Status e;
  {
    std::lock_guard lock(mutex_);
    e = core_.session().press(client, command, value, id, clock_.now());
  }
  notify();
  return e;
}

rtukit::Status Host::renew(ClientId client, PressId id) {
  rtukit::Status e;
  {
    std::lock_guard lock(mutex_);
    e = core_.session().renew(client, id, clock_.now());
  }
  notify();
  return e;
}

void Host::release_press(ClientId client, PressId id) {
  {
    std::lock_guard lock(mutex_);
    core_.session().release(client, id, clock_.now());
  }
  notify();
}

void Host::stop_all() {
  {
    std::lock_guard lock(mutex_);
    core_.session().stop_all(clock_.now());
    core_.sync(clock_.now());  // the stop command is the next request on the wire
  }
  notify();
}

void Host::lift_stop() {
  {
    std::lock_guard lock(mutex_);
    core_.session().lift_stop();
  }
  notify();
}

bool Host::stop_latched() const {
  std::lock_guard lock(mutex_);
  return core_.session().stop_latched();
}

rtukit::Status Host::queue(ClientId client, uint16_t command, uint16_t value, uint64_t* ticket) {
  {
    std::lock_guard lock(mutex_);
    const uint64_t t = next_ticket_++;
    if (rtukit::Status e = core_.queue(client, command, value, t)) return e;
    if (ticket) *ticket = t;
  }
  notify();
  return {};
}

rtukit::Status Host::send(ClientId client, uint16_t command, uint16_t value) {
  return queue(client, command, value, nullptr);
}

rtukit::Status Host::wait_ticket(uint64_t ticket) {
  std::unique_lock lock(mutex_);
  std::optional<Error> result;
  const bool done = cv_.wait_for(lock, options_.response_timeout * 10 + std::chrono::seconds(1), [&] {
    for (const auto& [t, e] : finished_)
      if (t == ticket) {
        result = e;
        return true;
      }
    return stopping_;
  });
  if (!done || !result) return rtukit::Status(Errc::timeout, "the write was not confirmed");
  if (*result) return rtukit::Status(*result, failure_text(*result));
  return {};
}

Disabled Host::disabled() const {
  std::lock_guard lock(mutex_);
  return core_.session().disabled();
}

std::vector<Session::Press> Host::presses() const {
  std::lock_guard lock(mutex_);
  return core_.session().presses();
}

std::optional<Host::ClientId> Host::driver() const {
  std::lock_guard lock(mutex_);
  return core_.session().driver();
}

uint16_t Host::speed_level() const {
  std::lock_guard lock(mutex_);
  return core_.speed_level();
}

bool Host::emergency() const {
  std::lock_guard lock(mutex_);
  return core_.session().emergency();
}

bool Host::near_obstacle() const {
  std::lock_guard lock(mutex_);
  return core_.session().near_obstacle();
}

// ---------------------------------------------------------------- blocking helpers (the CLI)

rtukit::Status Host::hold(uint16_t command, uint16_t value) {
  const Register* r = find_register(command);
  if (!r || r->role != Role::hold || command == reg::kHostReady)
    return rtukit::Status(Errc::invalid_argument, fmt::format("0x{:04X} is not a hold command", command));
  if (value == 0) return release(command);
  rtukit::Status e;
  {
    std::lock_guard lock(mutex_);
    PressId& mine = local_press_[command - reg::kCommandFirst];
    const auto now = clock_.now();
    const bool live =
        mine != 0 && std::any_of(core_.session().presses().begin(), core_.session().presses().end(),
                                 [&](const Session::Press& p) {
                                   return p.client == kLocalClient && p.id == mine && p.value == value;
                                 });
    if (live) {
      e = core_.session().renew(kLocalClient, mine, now);
    } else if (mine != 0) {
      // Ended by the session (a lapse, an error, D-8): refused until the
      // caller releases, so nothing presses again by itself.
      e = rtukit::Status(
          Errc::refused,
          fmt::format("{} was stopped (the lease ran out, or an error: D-8): release and press again",
                      r->key));
    } else {
      e = core_.session().press(kLocalClient, command, value, ++local_last_, now);
      if (!e) mine = local_last_;
    }
  }
  notify();
  return e;
}

Error Host::release(uint16_t command) {
  if (command < reg::kCommandFirst || command >= reg::kCommandFirst + reg::kCommandCount)
    return Errc::invalid_argument;
  {
    std::lock_guard lock(mutex_);
    PressId& mine = local_press_[command - reg::kCommandFirst];
    if (mine) core_.session().release(kLocalClient, mine, clock_.now());
    mine = 0;
  }
  notify();
  return {};
}

rtukit::Status Host::pulse(uint16_t command) {
  const Register* r = find_register(command);
  if (!r || r->role != Role::pulse)
    return rtukit::Status(Errc::invalid_argument, fmt::format("0x{:04X} is not a pulse command", command));
  uint64_t ticket = 0;
  if (rtukit::Status e = queue(kLocalClient, command, 1, &ticket)) return e;
  return wait_ticket(ticket);
}

// A setting, checked against its row, queued as the local tool, waited for.
rtukit::Status Host::set_setting(uint16_t address, uint16_t value) {
  if (rtukit::Status e = profile::check_argument(*find_register(address), value)) return e;
  uint64_t ticket = 0;
  if (rtukit::Status e = queue(kLocalClient, address, value, &ticket)) return e;
  return wait_ticket(ticket);
}

rtukit::Status Host::set_drive_mode(uint16_t mode) {
  return set_setting(reg::kDriveMode, mode);
}

rtukit::Status Host::set_speed_level(uint16_t level) {
  return set_setting(reg::kSpeedLevel, level);
}

Error Host::set_host_fault(uint16_t code) {
  // Allowed during an overlay: the host reports its own fault.
  return write_command(reg::kHostFault, code);
}

Error Host::write_command(uint16_t address, uint16_t value) {
  return master_.write_single_register(options_.unit, address, value);
}

}  // namespace rtukit::rehand6600
