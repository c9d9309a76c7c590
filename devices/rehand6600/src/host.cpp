// The host protocol. Events are collected under the lock and delivered after
// it is released, so a handler may call back into the Host.
#include "rtukit/devices/rehand6600/host.hpp"

#include <fmt/core.h>

#include <utility>
#include <vector>

#include "rtukit/devices/profile/text.hpp"
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
      logic_(options),
      session_(SessionOptions{.lease = options.lease}),
      worker_([this](HostLogic::TimePoint) { return step(); }, BusWorker::Options{.clock = &clock_}) {
  session_.join(kLocalClient, ClientKind::tool);
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
  // Safety: nothing stays held when the host goes away. The worker is told
  // to stop first, so the zeros below are the last writes.
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  worker_.stop();
  std::vector<uint16_t> held;
  {
    std::lock_guard lock(mutex_);
    session_.stop_all(clock_.now());
    for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
      const auto command = static_cast<uint16_t>(reg::kCommandFirst + i);
      // Not only what is held now: a release the worker had not sent yet
      // (stop() right after release()) is written here, or the controller
      // would go on moving until its watchdog.
      if (logic_.may_hold(command)) held.push_back(command);
    }
  }
  // Best effort: the controller's watchdog is the backstop.
  for (uint16_t command : held) (void)write_command(command, 0);
}

void Host::emit(const Event& e) {
  if (handler_) handler_(e);
}

// ---------------------------------------------------------------- HostLogic

std::optional<HostLogic::Request> HostLogic::next(TimePoint now) {
  if (in_flight_) return std::nullopt;
  // What the session changed goes first: a press or a release waits for no poll.
  if (connected_ && !urgent_.empty()) {
    in_flight_ = urgent_.front();
    urgent_.pop_front();
    return in_flight_;
  }
  while (phase_ == Phase::holds) {
    if (queue_.empty()) {
      phase_ = Phase::poll;
      next_at_ = cycle_start_ + period();
      return std::nullopt;
    }
    Request r = queue_.front();
    queue_.erase(queue_.begin());
    // The rewrite says what the target is now, not at the poll: a release
    // that came meanwhile was written at once, and an old 1 written after
    // it would hold the command again with no finger down.
    if (r.value != 0) {
      r.value = targets_[r.address - reg::kCommandFirst].value;
      if (r.value == 0) continue;
    }
    in_flight_ = r;
    return in_flight_;
  }
  if (phase_ == Phase::write_ready) {
    in_flight_ = Request{Request::Kind::write, reg::kHostReady, 1};
    return in_flight_;
  }
  if (now < next_at_) return std::nullopt;
  cycle_start_ = now;
  in_flight_ = Request{phase_ == Phase::poll ? Request::Kind::poll : Request::Kind::read_device_id};
  return in_flight_;
}

HostLogic::TimePoint HostLogic::wake_at() const noexcept {
  if (!in_flight_ && connected_ && !urgent_.empty()) return TimePoint::min();
  return next_at_;
}

HostLogic::TimePoint::duration HostLogic::period() const noexcept {
  return std::chrono::duration_cast<TimePoint::duration>(
      std::chrono::duration<double>(1.0 / options_.poll_hz));
}

void HostLogic::on_result(TimePoint now, Error e, std::span<const uint16_t> words) {
  const std::optional<Request> done = std::exchange(in_flight_, std::nullopt);
  if (done && done->kind == Request::Kind::write && done->address != reg::kHostReady) {
    if (done->ticket) results_.emplace_back(done->ticket, e);
    if (!done->ticket && done->address >= reg::kCommandFirst &&
        done->address < reg::kCommandFirst + reg::kCommandCount) {
      // What the controller may hold now: a lost answer may follow an
      // executed write, so a failed 0 leaves the word before it standing.
      uint16_t& sent = targets_[done->address - reg::kCommandFirst].sent;
      if (!e || done->value != 0) sent = done->value;
    }
    if (e && done->target && done->value != 0) {
      // The controller may or may not hold it: the session ends the press,
      // and 0 follows after the next poll.
      targets_[done->address - reg::kCommandFirst].zero_pending = true;
      events_.push_back(Event{Event::Type::write_failed, done->address, 0, done->value, 0, failure_text(e)});
    }
    return;  // a write says nothing about the link's phase: the next poll does
  }
  switch (phase_) {
    case Phase::read_id:
      if (e) {
        raise_comm_error(e, "handshake: " + failure_text(e));
      } else if (words.empty() || words[0] != kDeviceId) {
        raise_comm_error(Error::refused("not a Rehand 6600 controller"),
                         "handshake: " + device_id_mismatch(words.empty() ? 0 : words[0]));
      } else {
        phase_ = Phase::write_ready;
        return;
      }
      next_at_ = cycle_start_ + options_.handshake_retry;
      return;
    case Phase::write_ready:
      if (e) {
        raise_comm_error(e, "handshake: boot-complete write: " + failure_text(e));
        phase_ = Phase::read_id;
        next_at_ = cycle_start_ + options_.handshake_retry;
        return;
      }
      connected_ = true;
      failures_ = 0;
      last_failure_ = {};
      if (std::exchange(comm_error_, false))
        events_.push_back(Event{Event::Type::error_cleared, 0, 0, 0, kMasterCommunicationError, {}});
      events_.push_back(Event{Event::Type::connected});
      phase_ = Phase::poll;
      next_at_ = cycle_start_ + period();
      return;
    case Phase::poll:
      on_poll(now, e, words);
      return;
    case Phase::holds:
      return;  // a held command's rewrite: the next poll shows what the controller holds
  }
}

void HostLogic::on_poll(TimePoint now, Error e, std::span<const uint16_t> words) {
  (void)now;
  next_at_ = cycle_start_ + period();
  if (e || words.size() != reg::kStatusCount) {
    if (!e) e = Errc::unexpected_response;
    last_failure_ = rtukit::Status(e, failure_text(e));
    if (++failures_ >= options_.failures_to_error)
      raise_comm_error(
          e, fmt::format("{} consecutive polls failed ({})", options_.failures_to_error, failure_text(e)));
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
  bool raised = false;
  if (before != next.error_code()) {
    if (before) events_.push_back({Event::Type::error_cleared, reg::kErrorCode, 0, 0, before, {}});
    if (next.error_code()) {
      events_.push_back({Event::Type::error_raised, reg::kErrorCode, 0, 0, next.error_code(),
                         error_text(next.error_code())});
      raised = true;
    }
  }
  next.valid = true;
  next.sequence = prev.sequence + 1;
  snapshot_ = next;
  if (raised) {
    // D-8: the controller stopped; nothing it held is written again. The
    // session ends every press when it hears of the error.
    for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
      Target& t = targets_[i];
      if (t.value != 0) t = {.value = 0, .zero_pending = true, .sent = t.sent};
    }
    urgent_.erase(std::remove_if(urgent_.begin(), urgent_.end(), [](const Request& r) { return r.target; }),
                  urgent_.end());
  }
  // Live targets are written again, so the controller holds exactly what
  // the session wants even after its watchdog fired.
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    Target& t = targets_[i];
    const auto address = static_cast<uint16_t>(reg::kCommandFirst + i);
    if (std::exchange(t.zero_pending, false) && t.value == 0)
      queue_.push_back(Request{Request::Kind::write, address, 0});
    if (t.value != 0) queue_.push_back(Request{Request::Kind::write, address, t.value});
  }
  phase_ = Phase::holds;
}

void HostLogic::raise_comm_error(Error cause, const std::string& reason) {
  last_failure_ = rtukit::Status(cause, reason);
  connected_ = false;
  failures_ = 0;
  phase_ = Phase::read_id;
  queue_.clear();
  // Nothing to write to: the controller's watchdog stops what it held, and
  // the session ends every press when it hears of 1010 (D-8).
  for (Target& t : targets_) t = {.sent = t.sent};  // stop() still tries to write 0
  fail_queued(cause);
  if (!comm_error_) {
    comm_error_ = true;
    events_.push_back(Event{Event::Type::error_raised, 0, 0, 0, kMasterCommunicationError, reason});
  }
}

void HostLogic::fail_queued(Error e) {
  for (const Request& r : urgent_)
    if (r.ticket) results_.emplace_back(r.ticket, e);
  urgent_.clear();
}

void HostLogic::set_target(uint16_t command, uint16_t value) {
  Target& t = targets_[command - reg::kCommandFirst];
  if (t.value == value) return;
  t.value = value;
  if (!connected_) return;  // the first poll after the handshake writes it
  // The newest word wins: an unsent change of the same command is replaced.
  urgent_.erase(std::remove_if(urgent_.begin(), urgent_.end(),
                               [&](const Request& r) { return r.target && r.address == command; }),
                urgent_.end());
  // Target changes go before one-shots: a release waits for no pulse.
  const auto first_oneshot =
      std::find_if(urgent_.begin(), urgent_.end(), [](const Request& r) { return !r.target; });
  urgent_.insert(first_oneshot, Request{Request::Kind::write, command, value, 0, true});
}

bool HostLogic::enqueue(uint16_t address, uint16_t value, uint64_t ticket) {
  if (!connected_) return false;
  const size_t oneshots = static_cast<size_t>(
      std::count_if(urgent_.begin(), urgent_.end(), [](const Request& r) { return !r.target; }));
  if (oneshots >= kQueueLimit) return false;
  urgent_.push_back(Request{Request::Kind::write, address, value, ticket, false});
  return true;
}

uint16_t HostLogic::active_error() const noexcept {
  if (comm_error_ || !connected_) return kMasterCommunicationError;
  return snapshot_.valid ? snapshot_.error_code() : 0;
}

// ---------------------------------------------------------------- Host: the logic on a thread

void Host::sync(HostLogic::TimePoint now) {
  session_.tick(now);
  // The stop command first: when a phone is lost, the controller brakes
  // hard before anything else is written.
  logic_.set_target(reg::kAntiPinch, session_.wanted(reg::kAntiPinch));
  for (const Register& r : registers()) {
    if (r.role != Role::hold || r.address == reg::kHostReady || r.address == reg::kAntiPinch) continue;
    logic_.set_target(r.address, session_.wanted(r.address));
  }
}

std::vector<Event> Host::collect() {
  std::vector<Event> out = logic_.take_events();
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
  for (const auto& [ticket, error] : logic_.take_results()) {
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
    sync(clock_.now());
    request = logic_.next(clock_.now());
    events = collect();
    if (!request && events.empty()) {
      auto wake = logic_.wake_at();
      if (const auto lapse = session_.wake_at(); lapse && *lapse < wake) wake = *lapse;
      return wake;
    }
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
    const auto now = clock_.now();
    logic_.on_result(now, e, std::span<const uint16_t>(words.data(), e ? 0 : n));
    events = logic_.take_events();
    for (const Event& ev : events)
      if (ev.type == Event::Type::write_failed) session_.on_write_failed(ev.address, now);
    session_.on_status(logic_.snapshot(), logic_.active_error(), now);
    sync(now);
    for (Event& ev : collect()) events.push_back(std::move(ev));
  }
  cv_.notify_all();
  for (const Event& ev : events) emit(ev);
  return clock_.now();  // one request a step: the next is decided afresh
}

Snapshot Host::snapshot() const {
  std::lock_guard lock(mutex_);
  return logic_.snapshot();
}

bool Host::connected() const {
  std::lock_guard lock(mutex_);
  return logic_.connected();
}

uint16_t Host::active_error() const {
  std::lock_guard lock(mutex_);
  return logic_.active_error();
}

rtukit::Status Host::last_failure() const {
  std::lock_guard lock(mutex_);
  return logic_.last_failure();
}

bool Host::wait_connected(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return cv_.wait_for(lock, timeout, [this] { return logic_.connected() && logic_.snapshot().valid; });
}

bool Host::wait_poll(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  const uint64_t seen = logic_.snapshot().sequence;
  return cv_.wait_for(lock, timeout, [&] { return logic_.snapshot().sequence > seen; });
}

// ---------------------------------------------------------------- the session, from any thread

void Host::join(ClientId client, ClientKind kind) {
  std::lock_guard lock(mutex_);
  session_.join(client, kind);
}

void Host::leave(ClientId client) {
  {
    std::lock_guard lock(mutex_);
    session_.leave(client, clock_.now());
  }
  notify();
}

rtukit::Status Host::press(ClientId client, uint16_t command, uint16_t value, PressId id) {
  rtukit::Status e;
  {
    std::lock_guard lock(mutex_);
    e = session_.press(client, command, value, id, clock_.now());
  }
  notify();
  return e;
}

rtukit::Status Host::renew(ClientId client, PressId id) {
  rtukit::Status e;
  {
    std::lock_guard lock(mutex_);
    e = session_.renew(client, id, clock_.now());
  }
  notify();
  return e;
}

void Host::release_press(ClientId client, PressId id) {
  {
    std::lock_guard lock(mutex_);
    session_.release(client, id, clock_.now());
  }
  notify();
}

void Host::stop_all() {
  {
    std::lock_guard lock(mutex_);
    session_.stop_all(clock_.now());
  }
  notify();
}

rtukit::Status Host::queue(ClientId client, uint16_t command, uint16_t value, uint64_t* ticket) {
  {
    std::lock_guard lock(mutex_);
    if (rtukit::Status e = session_.check_command(client, command, value)) return e;
    const Register& r = *find_register(command);
    const uint64_t t = next_ticket_++;
    const bool pulse = r.role == Role::pulse;
    // A pulse is two writes with one ticket: its outcome is the last one's.
    if (pulse && logic_.enqueue(command, command == reg::kPhoneLight ? 2 : 1, 0)) {
      if (!logic_.enqueue(command, 0, t))
        return rtukit::Status(Errc::refused, "the controller's queue is full");
    } else if (pulse || !logic_.enqueue(command, value, t)) {
      return rtukit::Status(Errc::refused, logic_.connected() ? "the controller's queue is full: try again"
                                                              : "no communication with the controller");
    }
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
  return session_.disabled();
}

std::vector<Session::Press> Host::presses() const {
  std::lock_guard lock(mutex_);
  return session_.presses();
}

std::optional<Host::ClientId> Host::driver() const {
  std::lock_guard lock(mutex_);
  return session_.driver();
}

bool Host::emergency() const {
  std::lock_guard lock(mutex_);
  return session_.emergency();
}

bool Host::near_obstacle() const {
  std::lock_guard lock(mutex_);
  return session_.near_obstacle();
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
        mine != 0 &&
        std::any_of(session_.presses().begin(), session_.presses().end(), [&](const Session::Press& p) {
          return p.client == kLocalClient && p.id == mine && p.value == value;
        });
    if (live) {
      e = session_.renew(kLocalClient, mine, now);
    } else if (mine != 0) {
      // Ended by the session (a lapse, an error, D-8): refused until the
      // caller releases, so nothing presses again by itself.
      e = rtukit::Status(
          Errc::refused,
          fmt::format("{} was stopped (the lease ran out, or an error: D-8): release and press again",
                      r->key));
    } else {
      e = session_.press(kLocalClient, command, value, ++local_last_, now);
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
    if (mine) session_.release(kLocalClient, mine, clock_.now());
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
