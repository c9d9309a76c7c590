// The host protocol. Events are collected under the lock and delivered after
// it is released, so a handler may call back into the Host.
#include "rtukit/devices/rehand6600/host.hpp"

#include <fmt/core.h>

#include <utility>
#include <vector>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"

namespace rtukit::rehand6600 {
namespace {

using Clock = std::chrono::steady_clock;

std::string failure_text(Error e) {
  if (e.is_exception()) return fmt::format("Modbus exception {:02X} ({})", e.exception_code(), e.name());
  return std::string(e.name());
}

bool is_phone_drive(uint16_t a) {
  return a >= reg::kPhoneForward && a <= reg::kPhoneRight;
}

}  // namespace

Host::Host(std::unique_ptr<io::Link> link, HostOptions options)
    : options_(options),
      master_(std::move(link), MasterOptions{.response_timeout = options.response_timeout,
                                             .quirks = kProfile.quirks,
                                             .trace = options.trace}),
      logic_(options) {}

Host::~Host() {
  stop();
}

void Host::on_event(std::function<void(const Event&)> handler) {
  handler_ = std::move(handler);
}

void Host::start() {
  if (thread_.joinable()) return;
  stopping_ = false;
  thread_ = std::thread([this] { run(); });
}

void Host::stop() {
  if (!thread_.joinable()) return;
  // Safety: nothing stays held when the host goes away.
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    const auto command = static_cast<uint16_t>(reg::kCommandFirst + i);
    bool held = false;
    {
      std::lock_guard lock(mutex_);
      held = logic_.held(command) != 0;
      logic_.release(command);
    }
    if (held) (void)write_command(command, 0);  // best effort: the controller's watchdog is the backstop
  }
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void Host::emit(const Event& e) {
  if (handler_) handler_(e);
}

// ---------------------------------------------------------------- HostLogic

std::optional<HostLogic::Request> HostLogic::next(TimePoint now) {
  if (in_flight_) return std::nullopt;
  if (phase_ == Phase::holds) {
    if (queue_.empty()) {
      phase_ = Phase::poll;
      next_at_ = cycle_start_ + period();
      return std::nullopt;
    }
    Request r = queue_.front();
    queue_.erase(queue_.begin());
    in_flight_ = true;
    return r;
  }
  if (phase_ == Phase::write_ready) {
    in_flight_ = true;
    return Request{Request::Kind::write, reg::kHostReady, 1};
  }
  if (now < next_at_) return std::nullopt;
  cycle_start_ = now;
  in_flight_ = true;
  return Request{phase_ == Phase::poll ? Request::Kind::poll : Request::Kind::read_device_id};
}

HostLogic::TimePoint::duration HostLogic::period() const noexcept {
  return std::chrono::duration_cast<TimePoint::duration>(
      std::chrono::duration<double>(1.0 / options_.poll_hz));
}

void HostLogic::on_result(TimePoint now, Error e, std::span<const uint16_t> words) {
  in_flight_ = false;
  switch (phase_) {
    case Phase::read_id:
      if (e) {
        raise_comm_error(e, "handshake: " + failure_text(e));
      } else if (words.empty() || words[0] != kDeviceId) {
        raise_comm_error(Error::refused("not a Rehand 6600 controller"),
                         fmt::format("handshake: device ID 0x{:02X}, expected 0x{:02X}",
                                     words.empty() ? 0 : words[0], kDeviceId));
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
  if (raised) drop_holds(true);
  // Expired leases are released; live ones are written again, so the
  // controller holds exactly what the UI holds even after its watchdog fired.
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    Lease& l = holds_[i];
    const auto address = static_cast<uint16_t>(reg::kCommandFirst + i);
    if (std::exchange(l.zero_pending, false) && l.value == 0)
      queue_.push_back(Request{Request::Kind::write, address, 0});
    if (l.value == 0) continue;
    const bool expired = now >= l.until;
    queue_.push_back(Request{Request::Kind::write, address, expired ? uint16_t{0} : l.value});
    if (expired) {
      l = {};
      events_.push_back(Event{Event::Type::released, address});
    }
  }
  phase_ = Phase::holds;
}

void HostLogic::raise_comm_error(Error cause, const std::string& reason) {
  last_failure_ = rtukit::Status(cause, reason);
  connected_ = false;
  failures_ = 0;
  phase_ = Phase::read_id;
  queue_.clear();
  if (!comm_error_) {
    comm_error_ = true;
    events_.push_back(Event{Event::Type::error_raised, 0, 0, 0, kMasterCommunicationError, reason});
  }
  drop_holds(false);  // nothing to write to: the controller's watchdog stops it
}

void HostLogic::drop_holds(bool write_zero) {
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    Lease& l = holds_[i];
    if (l.value == 0) continue;
    const auto address = static_cast<uint16_t>(reg::kCommandFirst + i);
    if (write_zero) queue_.push_back(Request{Request::Kind::write, address, 0});
    l = {.dropped = true};
    events_.push_back(Event{Event::Type::released, address});
  }
}

bool HostLogic::hold(uint16_t command, uint16_t value, TimePoint now) {
  Lease& l = holds_[command - reg::kCommandFirst];
  const bool changed = l.value != value;
  l = {value, now + options_.lease};
  return changed;
}

bool HostLogic::press_settled(uint16_t command, uint16_t value, bool written) {
  Lease& l = holds_[command - reg::kCommandFirst];
  if (written) return l.value != value;
  // Not written: the press is refused until the UI releases it, as after a
  // stop. A finger that stays down must not press again by itself on the
  // next renewal, once the link (or the controller) answers again.
  // Released (or pressed with another value) meanwhile: that is the UI's
  // newer word; only the possibly executed write is undone.
  if (l.value == value || l.dropped)
    l = {.dropped = true, .zero_pending = true};
  else
    l.zero_pending = true;
  return false;
}

void HostLogic::release(uint16_t command) {
  holds_[command - reg::kCommandFirst] = {};
}

uint16_t HostLogic::active_error() const noexcept {
  if (comm_error_ || !connected_) return kMasterCommunicationError;
  return snapshot_.valid ? snapshot_.error_code() : 0;
}

// ---------------------------------------------------------------- Host: the logic on a thread

void Host::run() {
  for (;;) {
    std::optional<HostLogic::Request> request;
    {
      std::unique_lock lock(mutex_);
      if (stopping_) return;
      request = logic_.next(Clock::now());
      if (!request) {
        cv_.wait_until(lock, logic_.wake_at(), [this] { return stopping_; });
        continue;
      }
    }
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
    std::vector<Event> events;
    {
      std::lock_guard lock(mutex_);
      logic_.on_result(Clock::now(), e, std::span<const uint16_t>(words.data(), e ? 0 : n));
      events = logic_.take_events();
    }
    cv_.notify_all();
    for (const Event& ev : events) emit(ev);
  }
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

rtukit::Status Host::check_ui_rules(const Register& r, uint16_t value) const {
  const auto refuse = [](std::string reason) { return rtukit::Status(Errc::refused, std::move(reason)); };
  if (value == 0) return {};
  const uint16_t error = active_error();
  if (error) {
    return refuse(
        error == kMasterCommunicationError && !connected()
            ? fmt::format("{}: no communication with the controller; only releasing is possible",
                          error_text(error))
            : fmt::format("error overlay active ({}); only releasing is possible", error_text(error)));
  }
  if (is_phone_drive(r.address)) {
    const Snapshot s = snapshot();
    if (s.charging()) return refuse("no driving while charging");
    if (!s.clutch_drive()) return refuse("no driving with the clutch in push (free-wheel) mode");
    bool phone_holding = false;
    {
      std::lock_guard lock(mutex_);
      for (uint16_t a = reg::kPhoneForward; a <= reg::kPhoneRight; ++a)
        phone_holding = phone_holding || logic_.held(a) != 0;
    }
    if (!phone_holding && !s.is_static()) return refuse("phone drive only while the chair is static");
    if (s[reg::kActuatorPosition] > 0 || s[reg::kActuatorPosition + 2] > 0)
      return refuse("no phone driving while the chair is not fully seated");
  }
  if ((r.address == reg::kStandSit || r.address == reg::kSeatLift) && value == 1 && snapshot().charging())
    return refuse("no standing up or raising the seat while charging");
  return {};
}

Error Host::write_command(uint16_t address, uint16_t value) {
  return master_.write_single_register(options_.unit, address, value);
}

rtukit::Status Host::hold(uint16_t command, uint16_t value) {
  const Register* r = find_register(command);
  if (!r || r->role != Role::hold || command == reg::kHostReady)
    return rtukit::Status(Errc::invalid_argument, fmt::format("0x{:04X} is not a hold command", command));
  if (check_value(*r, value) != Errc::ok)
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("{}: value {} is not one of its values", r->key, value));
  if (value == 0) return release(command);
  if (rtukit::Status e = check_ui_rules(*r, value)) return e;
  bool changed = false;
  {
    std::lock_guard lock(mutex_);
    if (logic_.dropped(command))
      return rtukit::Status(Errc::refused,
                            fmt::format("{} was stopped by an error (D-8): release and press again", r->key));
    changed = logic_.hold(command, value, Clock::now());
  }
  if (!changed) return {};
  const Error e = write_command(command, value);
  bool stopped_meanwhile = false;
  {
    // While the write was on the bus a stop may have dropped the hold (an
    // error, the link lost: D-8) or the UI released it. Before, a failed
    // write cleared the lease and with it the "dropped" mark, so the next
    // renewal of a finger that stayed down through a link loss pressed
    // again by itself (found by bench/rehand_link_soak.py).
    std::lock_guard lock(mutex_);
    stopped_meanwhile = logic_.press_settled(command, value, e.ok());
  }
  if (stopped_meanwhile) (void)write_command(command, 0);  // any doubt about motion: stop
  if (e) return rtukit::Status(e, failure_text(e));
  if (stopped_meanwhile)
    return rtukit::Status(
        Errc::refused,
        fmt::format("{} was stopped while it was being pressed: release and press again", r->key));
  return {};
}

Error Host::release(uint16_t command) {
  if (command < reg::kCommandFirst || command >= reg::kCommandFirst + reg::kCommandCount)
    return Errc::invalid_argument;
  {
    std::lock_guard lock(mutex_);
    logic_.release(command);
  }
  return write_command(command, 0);
}

rtukit::Status Host::pulse(uint16_t command) {
  const Register* r = find_register(command);
  if (!r || r->role != Role::pulse)
    return rtukit::Status(Errc::invalid_argument, fmt::format("0x{:04X} is not a pulse command", command));
  const uint16_t on = command == reg::kPhoneLight ? 2 : 1;  // the seed's value for phone lighting
  if (rtukit::Status e = check_ui_rules(*r, on)) return e;
  if (Error e = write_command(command, on)) return rtukit::Status(e, failure_text(e));
  if (Error e = write_command(command, 0)) return rtukit::Status(e, failure_text(e));
  return {};
}

// A setting: the value checked against its row, then the UI rules.
rtukit::Status Host::set_drive_mode(uint16_t mode) {
  const Register& r = *find_register(reg::kDriveMode);
  if (rtukit::Status e = profile::check_argument(r, mode)) return e;
  if (rtukit::Status e = check_ui_rules(r, mode)) return e;
  if (Error e = write_command(reg::kDriveMode, mode)) return rtukit::Status(e, failure_text(e));
  return {};
}

rtukit::Status Host::set_speed_level(uint16_t level) {
  const Register& r = *find_register(reg::kSpeedLevel);
  if (rtukit::Status e = profile::check_argument(r, level)) return e;
  if (rtukit::Status e = check_ui_rules(r, level)) return e;
  if (Error e = write_command(reg::kSpeedLevel, level)) return rtukit::Status(e, failure_text(e));
  return {};
}

Error Host::set_host_fault(uint16_t code) {
  return write_command(reg::kHostFault, code);
}

}  // namespace rtukit::rehand6600
