// The deterministic simulation of the Rehand 6600 host (rehand_simulation.hpp).
//
// The world: virtual time, a HostCore (the host's rules and write logic as
// the Host runs them), a Chair (the controller model) and the line between
// them, clients and the person in the chair. Each step is the earliest of:
// the host's next request (or the end of the one on the wire), a client's
// action, a physical event at the chair, a fault episode starting or
// ending. Randomness comes from one generator seeded by the run's seed, and
// every draw is made whether or not its kind of fault is enabled, so
// switching a kind off while shrinking keeps the rest of the run the same.
#include "rehand_simulation.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <vector>

#include "rtukit/devices/rehand6600/ble_gatt.hpp"
#include "rtukit/devices/rehand6600/chair.hpp"
#include "rtukit/devices/rehand6600/host.hpp"
#include "rtukit/devices/rehand6600/motion.hpp"
#include "rtukit/programs/rehand_message.hpp"

namespace rtukit::rehand6600::simulation {
namespace {

using TimePoint = HostLogic::TimePoint;
using Duration = TimePoint::duration;
using std::chrono::microseconds;
using std::chrono::milliseconds;
using Request = HostLogic::Request;

// splitmix64: small, fast, and the same sequence on every machine.
class Rng {
 public:
  explicit Rng(uint64_t seed) : s_(seed) {}
  uint64_t next() {
    uint64_t z = (s_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  bool chance(double p) { return uniform() < p; }
  int64_t range(int64_t lo, int64_t hi) {
    return lo + static_cast<int64_t>(next() % static_cast<uint64_t>(hi - lo + 1));
  }
  milliseconds ms(int64_t lo, int64_t hi) { return milliseconds(range(lo, hi)); }

 private:
  uint64_t s_;
};

bool is_motion(uint16_t c) {
  return may_press(ClientKind::tool, c) && c != reg::kAntiPinch;
}
bool is_phone_drive(uint16_t c) {
  return c >= reg::kPhoneForward && c <= reg::kPhoneRight;
}
size_t slot(uint16_t c) {
  return c - reg::kCommandFirst;
}

std::string key(uint16_t c) {
  const Register* r = find_register(c);
  return r ? std::string(r->key) : fmt::format("0x{:04X}", c);
}

// A client of the session: the display, a phone over Wi-Fi (JSON) or over
// Bluetooth (bytes), as the daemon carries them.
struct Client {
  ClientKind kind = ClientKind::display;
  bool ble = false;
  uint64_t id = 0;  ///< the session's id of this connection (new at each connect)
  bool connected = false;
  uint64_t last_press = 0;
  bool holding = false;
  uint64_t press = 0;
  uint16_t command = 0, value = 0;
  TimePoint next_renew{}, release_at{}, next_action{};
  TimePoint renewed_at{};  ///< the last renewal the session took (or the press)
  milliseconds renew_every{100};
  bool frozen = false;  ///< stopped renewing (a frozen page, out of range)
};

class World {
 public:
  explicit World(const RunOptions& o)
      : o_(o),
        rng_(o.seed),
        options_(make_options()),
        core_(options_),
        chair_(std::make_unique<Chair>(0, 500)),
        t0_(std::chrono::hours(1)),
        now_(t0_) {
    clients_.push_back(Client{.kind = ClientKind::display});
    clients_.push_back(Client{.kind = ClientKind::phone, .ble = false});
    clients_.push_back(Client{.kind = ClientKind::phone, .ble = true});
    for (Client& c : clients_) c.next_action = now_ + rng_.ms(100, 2000);
    connect(clients_[0]);
    next_physical_ = now_ + rng_.ms(500, 5000);
    next_fault_ = now_ + rng_.ms(500, 5000);
    chair_before_.fill(0);
  }

  RunResult run() {
    const TimePoint end = now_ + milliseconds(o_.duration_ms);
    while (now_ < end && result_.ok && (o_.max_steps == 0 || result_.steps < o_.max_steps)) step();
    return result_;
  }

 private:
  static HostOptions make_options() {
    HostOptions o;
    o.response_timeout = milliseconds(100);
    return o;
  }

  // ------------------------------------------------------------ the loop

  void step() {
    TimePoint host = in_flight_ ? in_flight_->done : std::max(now_, core_.wake_at());
    if (!in_flight_ && now_ < stall_until_) host = std::max(host, stall_until_);
    TimePoint client = TimePoint::max();
    for (const Client& c : clients_) client = std::min(client, next_client_time(c));
    const TimePoint t = std::min({host, client, next_physical_, next_fault_});
    advance(t);
    if (t == host) {
      in_flight_ ? finish_request() : start_request();
    } else if (t == client) {
      for (Client& c : clients_)
        if (next_client_time(c) == t) {
          act(c);
          break;
        }
      // Host::notify(): the bus thread wakes and looks at what the session wants now.
      core_.sync(now_);
    } else if (t == next_physical_) {
      physical_event();
    } else {
      fault_event();
    }
    drain_events();
    check();
  }

  void advance(TimePoint t) {
    if (t < now_) t = now_;
    now_ = t;
    chair_->advance_to(std::max(chair_->now_ms(), device_ms(now_)));
    note_controller_clears();
  }
  uint64_t device_ms(TimePoint t) const {
    return static_cast<uint64_t>(std::chrono::duration_cast<milliseconds>(t - t0_).count());
  }
  std::string at() const {
    return fmt::format("t={:.3f} s", std::chrono::duration<double>(now_ - t0_).count());
  }
  // With RTUKIT_SIM_TRACE set, every step on stderr: what a replay shows.
  template <class... Args>
  void trace(fmt::format_string<Args...> f, Args&&... args) {
    if (!trace_) return;
    fmt::print(stderr, "{:10.3f} ", std::chrono::duration<double>(now_ - t0_).count());
    fmt::print(stderr, f, std::forward<Args>(args)...);
    fmt::print(stderr, "\n");
  }

  void fail(const std::string& what) {
    if (!result_.ok) return;
    result_.ok = false;
    result_.failure = fmt::format("{} (step {}): {}", at(), result_.steps, what);
  }

  // ------------------------------------------------------------ the line and the controller

  struct InFlight {
    Request request;
    TimePoint done{};
    Error error;
    std::array<uint16_t, reg::kStatusCount> words{};
    size_t n = 0;
  };

  static microseconds on_wire(size_t bytes) {  // 115200 8N1: 10 bits a character
    return microseconds(static_cast<int64_t>(bytes) * 10 * 1'000'000 / 115200);
  }

  void start_request() {
    const std::optional<Request> r = core_.next(now_);
    if (!r) {
      // Nothing to send now: the next wake-up is later (or a lease's end).
      if (core_.wake_at() <= now_) now_ += milliseconds(1);
      return;
    }
    ++result_.steps;
    trace("host: {} 0x{:04X} = {}",
          r->kind == Request::Kind::poll             ? "poll"
          : r->kind == Request::Kind::read_device_id ? "read id"
                                                     : "write",
          r->address, r->value);
    drain_events();  // what next() decided on the way (a lease lapsed: an emergency stop)
    on_request_sent(*r);
    const TimePoint sent = now_;
    InFlight f{.request = *r};
    const size_t request_bytes = 8;  // FC03 and FC06 requests alike
    const size_t reply_bytes = r->kind == Request::Kind::poll             ? 5 + 2 * reg::kStatusCount
                               : r->kind == Request::Kind::read_device_id ? 7
                                                                          : 8;
    // The frame's fate: a drop-out of the line, noise, or a clean answer.
    const double p = now_ < noise_until_ ? noise_ : 0.0;
    const bool lost_request_draw = rng_.chance(p), lost_reply_draw = rng_.chance(p);
    const bool corrupt_draw = rng_.chance(p / 2), late_draw = rng_.chance(p / 2);
    const bool outage = now_ < outage_until_;
    const bool lost_request = (outage && !outage_replies_only_) || (o_.faults.frames && lost_request_draw);
    const bool lost_reply = outage || (o_.faults.frames && (lost_reply_draw || late_draw));
    const bool corrupt = o_.faults.frames && corrupt_draw;
    const TimePoint exec = now_ + on_wire(request_bytes);
    if (!lost_request) {
      advance(exec);
      execute(f);
    }
    const milliseconds timeout = options_.response_timeout;
    if (lost_request || lost_reply || corrupt) {
      // No answer by the deadline (a corrupted one: the framer drops a bad
      // CRC and waits the deadline out).
      f.error = Errc::timeout;
      f.done = sent + timeout;
    } else {
      f.done = exec + milliseconds(1) + on_wire(reply_bytes);
    }
    if (f.error) f.n = 0;
    in_flight_ = f;
  }

  // The request reaches the controller: it executes it (D-5a: what it
  // executes feeds its watchdog).
  void execute(InFlight& f) {
    const Request& r = f.request;
    Errc e = Errc::ok;
    switch (r.kind) {
      case Request::Kind::read_device_id:
        e = chair_->read_holding_registers(reg::kDeviceId, std::span(f.words.data(), 1));
        f.n = 1;
        break;
      case Request::Kind::poll:
        e = chair_->read_holding_registers(0, f.words);
        f.n = reg::kStatusCount;
        break;
      case Request::Kind::write: {
        const uint16_t c = r.address;
        const uint16_t before = chair_->command(c);
        const uint16_t v = r.value;
        e = chair_->write_holding_registers(c, std::span(&v, 1));
        if (e == Errc::ok && is_motion(c) && before == 0 && v != 0) rising_edge(c, r);
        if (c >= reg::kCommandFirst && c < reg::kCommandFirst + reg::kCommandCount)
          chair_before_[slot(c)] = chair_->command(c);
        break;
      }
    }
    if (e != Errc::ok) f.error = e;
  }

  void finish_request() {
    InFlight f = *in_flight_;
    in_flight_.reset();
    trace("host: answer {}", f.error ? std::string(f.error.name()) : std::string("ok"));
    if (!f.error && f.request.kind == Request::Kind::poll) last_poll_seen_ = now_;
    core_.on_result(now_, f.error, std::span<const uint16_t>(f.words.data(), f.error ? 0 : f.n));
  }

  // ------------------------------------------------------------ clients

  TimePoint next_client_time(const Client& c) const {
    TimePoint t = c.next_action;
    if (c.holding && !c.frozen) t = std::min(t, std::min(c.next_renew, c.release_at));
    return t;
  }

  void connect(Client& c) {
    c.id = next_client_id_++;
    trace("client {} connects", c.id);
    c.connected = true;
    c.last_press = 0;
    c.holding = false;
    core_.session().join(c.id, c.kind);
  }

  void disconnect(Client& c) {
    trace("client {} goes", c.id);
    core_.session().leave(c.id, now_);
    c.connected = false;
    c.holding = false;
  }

  // A message as the daemon gets it, through its parser; what the daemon
  // does with it, done to the session.
  Status send_json(Client& c, const std::string& text) {
    trace("client {}: {}", c.id, text);
    const programs::HostMessage m = programs::parse_host_message(
        text, c.kind == ClientKind::display ? programs::HostRole::display : programs::HostRole::phone, true);
    if (!m.envelope || !m.command) return Status(Errc::invalid_argument, "refused by the parser");
    const programs::HostCommand& k = *m.command;
    using Kind = programs::HostCommand::Kind;
    Session& s = core_.session();
    switch (k.kind) {
      case Kind::press:
        return s.press(c.id, k.address, k.value, k.press, now_);
      case Kind::renew:
        return s.renew(c.id, k.press, now_);
      case Kind::release:
        s.release(c.id, k.press, now_);
        return {};
      case Kind::stop:
        s.stop_all(now_);
        return {};
      case Kind::lift_stop:
        s.lift_stop();
        return {};
      case Kind::pulse:
      case Kind::set:
        return one_shot(c, k.address, k.kind == Kind::pulse ? 1 : k.value);
      default:
        return {};
    }
  }

  Status send_ble(Client& c, ble::Op op, ble::Function fn, uint32_t press) {
    trace("client {} (ble): op {} function {} press {}", c.id, static_cast<int>(op), static_cast<int>(fn),
          press);
    const auto bytes =
        ble::encode_command({.op = op, .function = fn, .value = 1, .press = press, .sequence = 1});
    const Outcome<ble::Command> cmd = ble::parse_command(bytes);
    if (!cmd) return cmd.error();
    Session& s = core_.session();
    const uint16_t address = ble::register_of(cmd->function);
    switch (cmd->op) {
      case ble::Op::press:
        return s.press(c.id, address, 1, cmd->press, now_);
      case ble::Op::renew:
        return s.renew(c.id, cmd->press, now_);
      case ble::Op::release:
        s.release(c.id, cmd->press, now_);
        return {};
      case ble::Op::pulse:
        return one_shot(c, address, 1);
    }
    return {};
  }

  // As Host::queue: the core checks and queues (a pulse is two writes, a setting one).
  Status one_shot(Client& c, uint16_t command, uint16_t value) {
    return core_.queue(c.id, command, value, ++ticket_);
  }

  Status press(Client& c, uint16_t command, uint16_t value) {
    const uint64_t id = ++c.last_press;
    Status e;
    if (c.ble) {
      const ble::Function fn = command == reg::kPhoneForward   ? ble::Function::forward
                               : command == reg::kPhoneReverse ? ble::Function::reverse
                               : command == reg::kPhoneLeft    ? ble::Function::left
                               : command == reg::kPhoneRight   ? ble::Function::right
                                                               : ble::Function::horn;
      e = send_ble(c, ble::Op::press, fn, static_cast<uint32_t>(id));
    } else {
      const Register& r = *find_register(command);
      e = send_json(
          c, fmt::format(R"({{"op":"press","command":"{}","value":{},"press":{}}})", r.key, value, id));
    }
    if (!e) {
      ++result_.presses;
      accepted_at_[core_.session().hold(command).serial] = now_;
    }
    return e;
  }

  Status renew(Client& c) {
    if (c.ble) return send_ble(c, ble::Op::renew, ble::Function::forward, static_cast<uint32_t>(c.press));
    return send_json(c, fmt::format(R"({{"op":"renew","press":{}}})", c.press));
  }
  void release(Client& c) {
    if (c.ble)
      (void)send_ble(c, ble::Op::release, ble::Function::forward, static_cast<uint32_t>(c.press));
    else
      (void)send_json(c, fmt::format(R"({{"op":"release","press":{}}})", c.press));
    c.holding = false;
  }

  void act(Client& c) {
    if (c.holding && !c.frozen && now_ >= c.release_at) {
      release(c);
      c.next_action = now_ + rng_.ms(50, 1500);
      return;
    }
    if (c.holding && !c.frozen && now_ >= c.next_renew) {
      if (!renew(c)) {
        c.renewed_at = now_;
      } else {
        c.holding = false;  // ended by the host: a person lifts the finger
        c.next_action = now_ + rng_.ms(50, 1000);
        return;
      }
      // Late renewals (a busy phone, Wi-Fi) now and then.
      const bool late = rng_.chance(0.02);
      c.next_renew = now_ + (o_.faults.clients && late ? rng_.ms(250, 500) : c.renew_every + rng_.ms(0, 30));
      return;
    }
    c.next_action = now_ + rng_.ms(100, 2500);
    const uint64_t what = rng_.next() % 100;
    if (c.kind == ClientKind::display) return display_act(c, what);
    phone_act(c, what);
  }

  void start_hold(Client& c, uint16_t command, uint16_t value) {
    if (press(c, command, value)) return;
    c.holding = true;
    c.frozen = false;
    c.press = c.last_press;
    c.command = command;
    c.value = value;
    c.renewed_at = now_;
    c.next_renew = now_ + c.renew_every;
    c.release_at = now_ + rng_.ms(200, 3000);
    c.next_action = c.release_at + rng_.ms(50, 500);
  }

  void display_act(Client& c, uint64_t what) {
    if (c.holding) {
      if (what < 3 && o_.faults.clients) c.frozen = true;  // the page freezes: its press lapses
      return;
    }
    if (what < 55) {
      const Posture& p = kPostures[rng_.next() % kPostures.size()];
      start_hold(c, p.command, static_cast<uint16_t>(rng_.range(1, 2)));
    } else if (what < 60) {
      (void)send_json(c, R"({"op":"stop"})");
    } else if (what < 75) {
      (void)send_json(c, R"({"op":"lift_stop"})");
    } else if (what < 80) {
      (void)send_json(c, R"({"op":"pulse","command":"light"})");
    } else if (what < 85) {
      (void)send_json(c, fmt::format(R"({{"op":"set","key":"speed_level","value":{}}})", rng_.range(1, 5)));
    } else if (what < 88) {
      (void)send_json(c, R"({"op":"press","command":"seat_lift","value":"sideways","press":1})");  // refused
    } else if (what < 90) {
      std::string junk(static_cast<size_t>(rng_.range(0, 40)), ' ');
      for (char& ch : junk) ch = static_cast<char>(rng_.range(1, 255));
      (void)send_json(c, junk);
    }
  }

  void phone_act(Client& c, uint64_t what) {
    if (!c.connected) {
      if (what < 60) connect(c);
      return;
    }
    if (c.holding) {
      if (o_.faults.clients && what < 4) {
        c.frozen = true;  // out of range, the app frozen: renewals stop
      } else if (o_.faults.clients && what < 7) {
        disconnect(c);
      }
      return;
    }
    if (what < 50) {
      const uint16_t command = static_cast<uint16_t>(reg::kPhoneForward + rng_.range(0, 3));
      start_hold(c, command, 1);
    } else if (what < 58) {
      start_hold(c, reg::kPhoneHorn, 1);
    } else if (what < 65) {
      if (c.ble)
        (void)send_ble(c, ble::Op::pulse, ble::Function::left_signal, 0);
      else
        (void)send_json(c, R"({"op":"pulse","command":"phone_light"})");
    } else if (what < 70) {
      disconnect(c);
    }
  }

  // ------------------------------------------------------------ the chair's world

  void physical_event() {
    next_physical_ = now_ + rng_.ms(300, 4000);
    const uint64_t what = rng_.next() % 9;
    trace("chair: physical event {}", what);
    const int64_t a = rng_.range(-100, 100), b = rng_.range(-100, 100);
    const bool on = rng_.chance(0.5);
    const uint16_t posture = kPostures[rng_.next() % kPostures.size()].command;
    const uint16_t dir = static_cast<uint16_t>(rng_.range(0, 2));
    if (!o_.faults.chair) return;
    ++result_.faults_injected;
    switch (what) {
      case 0:
        chair_->set_joystick(on ? static_cast<int>(a) : 0, on ? static_cast<int>(b) : 0);
        break;
      case 1:
        chair_->press_button(posture, dir);
        break;
      case 2:
        chair_->set_distance(static_cast<unsigned>(rng_.range(0, 1)), on ? 200 : 2000);
        break;
      case 3:
        chair_->set_charging(on && rng_.chance(0.5));
        break;
      case 4:
        chair_->set_clutch_drive(on || rng_.chance(0.5));
        break;
      case 5:
        chair_->set_error(on && rng_.chance(0.5) ? 0x10C3 : 0);
        break;
      case 6:
        chair_->set_actuator_overcurrent(static_cast<unsigned>(rng_.range(1, 6)), on && rng_.chance(0.3));
        break;
      default:
        chair_->press_button(posture, 0);
        chair_->set_joystick(0, 0);
        break;
    }
    note_controller_clears();
  }

  void fault_event() {
    next_fault_ = now_ + rng_.ms(300, 6000);
    const uint64_t what = rng_.next() % 5;
    const milliseconds len = rng_.ms(50, 1500);
    trace("line: fault {} for {} ms", what, len.count());
    const double p = 0.02 + rng_.uniform() * 0.3;
    const bool replies_only = rng_.chance(0.5);
    switch (what) {
      case 0:
        if (!o_.faults.frames) return;
        noise_ = p;
        noise_until_ = now_ + len;
        break;
      case 1:
        if (!o_.faults.outages) return;
        outage_until_ = now_ + len;
        outage_replies_only_ = replies_only;
        break;
      case 2:
        if (!o_.faults.restarts || !rng_.chance(0.3)) return;
        // A power cycle: the controller as at power-on (D-7), its commands 0.
        chair_ = std::make_unique<Chair>(chair_->now_ms(), 500);
        chair_before_.fill(0);
        break;
      case 3:
        if (!o_.faults.stalls) return;
        stall_until_ = now_ + std::min(len, milliseconds(800));
        stalls_.emplace_back(now_, stall_until_);
        break;
      default:
        return;
    }
    ++result_.faults_injected;
    last_fault_end_ = std::max({last_fault_end_, noise_until_, outage_until_, stall_until_, now_});
  }

  // ------------------------------------------------------------ invariants

  // How long the host's thread stood still since `t`.
  Duration stalled_since(TimePoint t) const {
    Duration d{};
    for (const auto& [from, to] : stalls_)
      if (to > t) d += to - std::max(from, t);
    return d;
  }

  void note_stop_due(TimePoint since, const char* why) {
    if (!stop_due_) {
      stop_due_ = since;
      stop_due_why_ = why;
    }
  }

  // A register the controller cleared by itself (its watchdog, a safety
  // stop, a button, the joystick): a later rising edge needs a press
  // accepted after it (D-8).
  void note_controller_clears() {
    for (uint16_t c = reg::kCommandFirst; c < reg::kCommandFirst + reg::kCommandCount; ++c) {
      if (!is_motion(c)) continue;
      const uint16_t v = chair_->command(c);
      if (chair_before_[slot(c)] != 0 && v == 0) last_clear_[slot(c)] = now_;
      chair_before_[slot(c)] = v;
    }
  }

  void rising_edge(uint16_t c, const Request& r) {
    const uint64_t serial = sent_serial_[slot(c)];
    const auto accepted = accepted_at_.find(serial);
    const TimePoint cleared = last_clear_[slot(c)];
    // D-8 as the host can keep it: the clear was seen by a poll before the
    // word went out, and the press came before the clear.
    if (accepted != accepted_at_.end() && accepted->second < cleared && last_poll_seen_ > cleared &&
        sent_at_[slot(c)] > last_poll_seen_)
      fail(fmt::format("{} = {} put back on the controller by a press from before its stop (D-8)", key(c),
                       r.value));
  }

  void on_request_sent(const Request& r) {
    const Session& s = core_.session();
    if (stop_due_ && core_.logic().confirmed(reg::kAntiPinch, 1)) stop_due_.reset();  // on already
    if (r.kind != Request::Kind::write || !r.target) {
      if (stop_due_ && core_.logic().connected() && r.kind == Request::Kind::poll)
        fail(fmt::format("a poll went before the stop command ({})", stop_due_why_));
      return;
    }
    const uint16_t c = r.address;
    if (stop_due_) {
      if (c == reg::kAntiPinch && r.value == 1) {
        // Only a request already on the wire comes first (and, with the link
        // down, the next try at the poll rate); a stall of the host's thread
        // holds everything back.
        const auto late = now_ - *stop_due_;
        const auto bound = options_.response_timeout + milliseconds(15) +
                           (connected_at_stop_ ? Duration::zero() : Duration(milliseconds(50))) +
                           stalled_since(*stop_due_);
        if (late > bound)
          fail(fmt::format("the stop command went on the wire {} ms after {}",
                           std::chrono::duration_cast<milliseconds>(late).count(), stop_due_why_));
        stop_due_.reset();
      } else if (s.emergency() && !core_.logic().confirmed(reg::kAntiPinch, 1)) {
        fail(fmt::format("{} = {} went before the stop command ({})", key(c), r.value, stop_due_why_));
      }
    }
    if (c == reg::kAntiPinch && r.value == 0 && !core_.logic().snapshot().still())
      fail("0x006A released while the host's last reading shows the chair moving");
    if (!is_motion(c) || r.value == 0) return;
    // A word that is not 0 belongs to a live press, new, and is written once.
    const Session::Hold h = s.hold(c);
    if (h.value != r.value)
      fail(fmt::format("{} = {} on the wire with no live press holding it", key(c), r.value));
    if (!written_.insert(h.serial).second) fail(fmt::format("{}'s press {} written twice", key(c), h.serial));
    sent_serial_[slot(c)] = h.serial;
    sent_at_[slot(c)] = now_;
    const Snapshot& snap = core_.logic().snapshot();
    if (is_phone_drive(c) && (!snap.seated() || snap.charging() || !snap.clutch_drive()))
      fail(fmt::format("{} sent while the host's reading forbids phone driving (D-10, R-2)", key(c)));
    // D-14: the controller itself (the model, not the host's belief) is at
    // speed level 1 when a remote drive word reaches it.
    if (is_phone_drive(c) && chair_->command(reg::kSpeedLevel) != 1)
      fail(fmt::format(
          "{} = {} sent while the controller is at speed level {} (D-14: a phone drives at level 1)", key(c),
          r.value, chair_->command(reg::kSpeedLevel)));
  }

  // The events of what just happened. An emergency stop is due on the wire
  // from the moment its cause happened: a lease's end (the last renewal the
  // session took, plus the lease), else now (STOP, a phone gone).
  void drain_events() {
    (void)core_.take_results();  // nobody waits for a ticket here: dropped, so they do not pile up
    TimePoint cause = now_;
    const char* why = "the display's STOP or a phone gone";
    for (const Event& e : core_.take_events()) {
      if (e.type != Event::Type::changed)
        trace("event {} 0x{:04X} client {} {}{}", static_cast<int>(e.type), e.address, e.client, e.reason,
              e.emergency ? " (emergency)" : "");
      if (e.type == Event::Type::released && e.emergency && e.reason.find("lease") != std::string::npos) {
        for (const Client& c : clients_)
          if (c.id == e.client) cause = std::min(cause, c.renewed_at + options_.lease);
        why = "a phone's lease lapsed";
      }
      if (e.type == Event::Type::emergency_started) {
        ++result_.stops;
        note_stop_due(cause, why);
        connected_at_stop_ = core_.logic().connected();
      }
    }
  }

  bool live_press(uint16_t c, uint16_t value) const {
    for (const Session::Press& p : core_.session().presses())
      if (p.command == c && p.value == value) return true;
    return false;
  }

  void check() {
    if (!result_.ok) return;
    const Session& s = core_.session();
    // One phone drives at a time.
    std::set<uint64_t> driving;
    for (const Session::Press& p : s.presses())
      if (is_phone_drive(p.command)) driving.insert(p.client);
    if (driving.size() > 1) fail("two phones drive at once");
    // The host never forgets a word the controller holds that no press holds.
    for (uint16_t c = reg::kCommandFirst; c < reg::kCommandFirst + reg::kCommandCount; ++c) {
      if (!is_motion(c)) continue;
      const uint16_t v = chair_->command(c);
      const bool unheld = v != 0 && !live_press(c, v);
      auto& since = unheld_since_[slot(c)];
      if (unheld && !core_.logic().may_hold(c))
        fail(fmt::format("the controller holds {} = {} with no press, and the host owes it no 0", key(c), v));
      if (unheld && !since) since = now_;
      if (!unheld && since) {
        // On a clean line the 0 lands within one request timeout and one poll.
        const auto took = now_ - *since;
        if (*since > last_fault_end_ + milliseconds(200) && now_ > *since && took > milliseconds(160))
          fail(fmt::format("{} = {} stayed on the controller {} ms with no press, on a clean line", key(c), v,
                           std::chrono::duration_cast<milliseconds>(took).count()));
        since.reset();
      }
    }
    // D-9: an emergency stop ends in standstill within 1.5 s.
    if (chair_->emergency_braking()) {
      if (!braking_since_) braking_since_ = now_;
      if (now_ - *braking_since_ > milliseconds(1500)) fail("an emergency stop took more than 1.5 s (D-9)");
    } else {
      braking_since_.reset();
    }
    // D-11: while charging, the seat does not rise.
    if (chair_->status(reg::kCharging) && was_charging_ && chair_->actuator(1) > seat_before_ + 1e-9)
      fail("the seat rose while charging (D-11)");
    was_charging_ = chair_->status(reg::kCharging) != 0;
    seat_before_ = chair_->actuator(1);
  }

  RunOptions o_;
  bool trace_ = std::getenv("RTUKIT_SIM_TRACE") != nullptr;
  Rng rng_;
  HostOptions options_;
  HostCore core_;
  std::unique_ptr<Chair> chair_;
  TimePoint t0_, now_;
  std::vector<Client> clients_;
  uint64_t next_client_id_ = 1;
  uint64_t ticket_ = 0;
  std::optional<InFlight> in_flight_;
  TimePoint next_physical_{}, next_fault_{};
  TimePoint noise_until_{}, outage_until_{}, stall_until_{}, last_fault_end_{};
  double noise_ = 0;
  bool outage_replies_only_ = false;
  RunResult result_;
  // invariant bookkeeping
  std::set<uint64_t> written_;
  std::map<uint64_t, TimePoint> accepted_at_;
  std::array<TimePoint, reg::kCommandCount> last_clear_{};
  std::array<uint16_t, reg::kCommandCount> chair_before_{};
  std::array<uint64_t, reg::kCommandCount> sent_serial_{};
  std::array<TimePoint, reg::kCommandCount> sent_at_{};
  std::array<std::optional<TimePoint>, reg::kCommandCount> unheld_since_{};
  TimePoint last_poll_seen_{};
  std::optional<TimePoint> stop_due_;
  bool connected_at_stop_ = false;
  std::vector<std::pair<TimePoint, TimePoint>> stalls_;  ///< every stall of the host's thread
  const char* stop_due_why_ = "";
  std::optional<TimePoint> braking_since_;
  bool was_charging_ = false;
  double seat_before_ = 0;
};

}  // namespace

std::string Faults::text() const {
  std::string out;
  const auto add = [&](bool on, const char* name) {
    if (!on) return;
    if (!out.empty()) out += ',';
    out += name;
  };
  add(frames, "frames");
  add(outages, "outages");
  add(restarts, "restarts");
  add(stalls, "stalls");
  add(chair, "chair");
  add(clients, "clients");
  return out.empty() ? "none" : out;
}

RunResult run(const RunOptions& options) {
  return World(options).run();
}

std::string replay_command(const RunOptions& o) {
  return fmt::format(
      "RTUKIT_SIM_SEED={} RTUKIT_SIM_STEPS={} RTUKIT_SIM_FAULTS={} RTUKIT_SIM_MS={} "
      "build/asan/tests/rehand_simulation_tests",
      o.seed, o.max_steps, o.faults.text(), o.duration_ms);
}

}  // namespace rtukit::rehand6600::simulation
