// The host protocol. Events are collected under the lock and delivered after
// it is released, so a handler may call back into the Host.
#include "rtukit/devices/rehand6600/host.hpp"

#include <fmt/core.h>

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
      master_(std::move(link),
              MasterOptions{.response_timeout = options.response_timeout, .quirks = kProfile.quirks}) {}

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
    bool held = false;
    {
      std::lock_guard lock(mutex_);
      held = holds_[i].value != 0;
      holds_[i] = {};
    }
    if (held) (void)write_command(static_cast<uint16_t>(reg::kCommandFirst + i), 0);
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

void Host::run() {
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.poll_hz));
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
    }
    const auto started = Clock::now();
    Clock::duration wait = period;
    if (!connected()) {
      if (!handshake()) wait = options_.handshake_retry;
    } else if (poll()) {
      service_holds();
    }
    std::unique_lock lock(mutex_);
    cv_.wait_until(lock, started + wait, [this] { return stopping_; });
  }
}

void Host::raise_comm_error(Error cause, const std::string& reason) {
  bool raised = false;
  {
    std::lock_guard lock(mutex_);
    last_failure_ = rtukit::Status(cause, reason);
    connected_ = false;
    failures_ = 0;
    if (!comm_error_) comm_error_ = raised = true;
  }
  cv_.notify_all();
  if (raised) emit(Event{Event::Type::error_raised, 0, 0, 0, kMasterCommunicationError, reason});
}

bool Host::handshake() {
  std::array<uint16_t, 1> id{};
  if (Error e = master_.read_holding_registers(options_.unit, reg::kDeviceId, id)) {
    raise_comm_error(e, "handshake: " + failure_text(e));
    return false;
  }
  if (id[0] != kDeviceId) {
    raise_comm_error(Error::refused("not a Rehand 6600 controller"),
                     fmt::format("handshake: device ID 0x{:02X}, expected 0x{:02X}", id[0], kDeviceId));
    return false;
  }
  if (Error e = master_.write_single_register(options_.unit, reg::kHostReady, 1)) {
    raise_comm_error(e, "handshake: boot-complete write: " + failure_text(e));
    return false;
  }
  bool cleared = false;
  {
    std::lock_guard lock(mutex_);
    connected_ = true;
    failures_ = 0;
    cleared = std::exchange(comm_error_, false);
    last_failure_ = {};
  }
  cv_.notify_all();
  if (cleared) emit(Event{Event::Type::error_cleared, 0, 0, 0, kMasterCommunicationError, {}});
  emit(Event{Event::Type::connected});
  return true;
}

bool Host::poll() {
  Snapshot next;
  if (Error e = master_.read_holding_registers(options_.unit, 0, next.regs)) {
    bool down = false;
    {
      std::lock_guard lock(mutex_);
      last_failure_ = rtukit::Status(e, failure_text(e));
      down = ++failures_ >= options_.failures_to_error;
    }
    if (down)
      raise_comm_error(
          e, fmt::format("{} consecutive polls failed ({})", options_.failures_to_error, failure_text(e)));
    return false;
  }
  std::vector<Event> events;
  {
    std::lock_guard lock(mutex_);
    failures_ = 0;
    const Snapshot& prev = snapshot_;
    for (uint16_t a = 0; a < reg::kStatusCount && prev.valid; ++a) {
      if (prev.regs[a] != next.regs[a])
        events.push_back({Event::Type::changed, a, prev.regs[a], next.regs[a]});
    }
    const auto rising = [&](uint16_t a) { return next.regs[a] != 0 && (!prev.valid || prev.regs[a] == 0); };
    if (rising(reg::kHornButton)) events.push_back({Event::Type::horn, reg::kHornButton, 0, 1});
    if (rising(reg::kViewButton)) events.push_back({Event::Type::view, reg::kViewButton, 0, 1});
    const uint16_t before = prev.valid ? prev.error_code() : 0;
    if (before != next.error_code()) {
      if (before) events.push_back({Event::Type::error_cleared, reg::kErrorCode, 0, 0, before, {}});
      if (next.error_code())
        events.push_back({Event::Type::error_raised, reg::kErrorCode, 0, 0, next.error_code(),
                          error_text(next.error_code())});
    }
    next.valid = true;
    next.sequence = prev.sequence + 1;
    snapshot_ = next;
  }
  cv_.notify_all();
  for (const Event& e : events) emit(e);
  return true;
}

// Expired leases are released; live ones are written again, so the
// controller holds exactly what the UI holds even after its watchdog fired.
void Host::service_holds() {
  const auto now = Clock::now();
  for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
    uint16_t value = 0;
    bool expired = false;
    {
      std::lock_guard lock(mutex_);
      Lease& l = holds_[i];
      if (l.value == 0) continue;
      expired = now >= l.until;
      value = expired ? 0 : l.value;
      if (expired) l = {};
    }
    const auto address = static_cast<uint16_t>(reg::kCommandFirst + i);
    (void)write_command(address, value);
    if (expired) emit(Event{Event::Type::released, address});
  }
}

Snapshot Host::snapshot() const {
  std::lock_guard lock(mutex_);
  return snapshot_;
}

bool Host::connected() const {
  std::lock_guard lock(mutex_);
  return connected_;
}

uint16_t Host::active_error() const {
  std::lock_guard lock(mutex_);
  if (comm_error_ || !connected_) return kMasterCommunicationError;
  return snapshot_.valid ? snapshot_.error_code() : 0;
}

rtukit::Status Host::last_failure() const {
  std::lock_guard lock(mutex_);
  return last_failure_;
}

bool Host::wait_connected(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return cv_.wait_for(lock, timeout, [this] { return connected_ && snapshot_.valid; });
}

bool Host::wait_poll(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  const uint64_t seen = snapshot_.sequence;
  return cv_.wait_for(lock, timeout, [&] { return snapshot_.sequence > seen; });
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
        phone_holding = phone_holding || holds_[a - reg::kCommandFirst].value != 0;
    }
    if (!phone_holding && !s.is_static()) return refuse("phone drive only while the chair is static");
  }
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
    Lease& l = holds_[command - reg::kCommandFirst];
    changed = l.value != value;
    l = {value, Clock::now() + options_.lease};
  }
  if (!changed) return {};
  Error e = write_command(command, value);
  if (e) {
    std::lock_guard lock(mutex_);
    holds_[command - reg::kCommandFirst] = {};
    return rtukit::Status(e, failure_text(e));
  }
  return {};
}

Error Host::release(uint16_t command) {
  if (command < reg::kCommandFirst || command >= reg::kCommandFirst + reg::kCommandCount)
    return Errc::invalid_argument;
  {
    std::lock_guard lock(mutex_);
    holds_[command - reg::kCommandFirst] = {};
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
