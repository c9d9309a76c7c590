// The Inverjet under deterministic simulation (inverjet_simulation.hpp).
// Why each piece is as it is:
//  - the machine is served by the real slave engine behind a MemoryLink, so
//    the client's frames, the master's retries and time-outs and the
//    machine's exceptions are the shipped code; only the wire is ours;
//  - the responder, not the test, advances the machine to the request's
//    time and records whether the request was an accepted write of the
//    control registers: that is the only moment a start may happen;
//  - every invariant reads the machine's own state (the truth), never the
//    client's idea of it, which faults make stale by design.
#include "inverjet_simulation.hpp"

#include <fmt/core.h>

#include <array>
#include <cstdlib>
#include <deque>
#include <memory>
#include <random>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_link.hpp"

namespace rtukit::inverjet::simulation {

std::string Faults::text() const {
  std::string t;
  const auto add = [&](bool on, const char* name) {
    if (on) t += t.empty() ? name : std::string(",") + name;
  };
  add(frames, "frames");
  add(outages, "outages");
  add(power, "power");
  add(machine, "machine");
  return t.empty() ? "none" : t;
}

std::string replay_command(const RunOptions& o) {
  return fmt::format(
      "RTUKIT_SIM_SEED={} RTUKIT_SIM_MS={} RTUKIT_SIM_STEPS={} RTUKIT_SIM_FAULTS={} "
      "build/asan/tests/inverjet_simulation_tests",
      o.seed, o.duration_ms, o.max_steps, o.faults.text());
}

namespace {

using namespace std::chrono_literals;

// Forwards to the machine of the moment: a power cut replaces the machine,
// the engine keeps its unit.
struct Forward final : RegisterBank {
  RegisterBank* m = nullptr;  ///< the machine, through the interface the engine sees
  FunctionSet functions() const noexcept override { return m->functions(); }
  FrameQuirks quirks() const noexcept override { return m->quirks(); }
  Errc read_holding_registers(uint16_t a, std::span<uint16_t> out) override {
    return m->read_holding_registers(a, out);
  }
  Errc read_input_registers(uint16_t a, std::span<uint16_t> out) override {
    return m->read_input_registers(a, out);
  }
  Errc write_holding_registers(uint16_t a, std::span<const uint16_t> v) override {
    return m->write_holding_registers(a, v);
  }
  uint8_t exception_status() override { return m->exception_status(); }
  std::string_view device_object(uint8_t id) override { return m->device_object(id); }
  void after_response() override { m->after_response(); }
};

bool runs(const Machine& m) {
  const Phase p = m.phase();
  return p == Phase::initial || p == Phase::starting || p == Phase::running;
}

class World {
 public:
  explicit World(const RunOptions& o) : o_(o), rng_(o.seed) {
    machine_ = std::make_unique<Machine>(0);
    bank_.m = machine_.get();
    (void)engine_.add_unit(UnitId{kDefaultAddress}, bank_);
    MasterOptions mo;
    mo.clock = &clock_;
    mo.response_timeout = 300ms;
    mo.retries = 1;
    mo.quirks = machine_->quirks();
    auto link = std::make_unique<MemoryLink>(
        clock_, [this](std::span<const uint8_t> request) { return respond(request); });
    master_ = std::make_unique<Master>(std::move(link), mo);
    (void)master_->open();
    client_ = std::make_unique<Client>(*master_);
    timer_top_ = 0;
  }

  RunResult go() {
    while (ok() && device_ms() < o_.duration_ms && !out_of_steps()) {
      machine_events();
      operate();
      idle(pick(50, 4000));
    }
    result_.steps = steps_;
    return result_;
  }

 private:
  // ------------------------------------------------------------ the world

  uint64_t device_ms() const {
    return static_cast<uint64_t>(
        std::chrono::duration_cast<std::chrono::milliseconds>(clock_.now() - origin_).count());
  }
  bool ok() const { return result_.ok; }
  bool out_of_steps() const { return o_.max_steps && steps_ >= o_.max_steps; }
  unsigned pick(unsigned lo, unsigned hi) { return std::uniform_int_distribution<unsigned>(lo, hi)(rng_); }
  bool chance(double p) { return std::bernoulli_distribution(p)(rng_); }

  void fail(const std::string& what) {
    if (!result_.ok) return;
    result_.ok = false;
    std::string recent;
    for (const std::string& line : log_) recent += "\n  " + line;
    result_.failure = fmt::format(
        "at {} ms (machine: phase {}, family {}, mode {}, time {} s, faults {:#x}): {}"
        "\nlast operations:{}",
        device_ms(), phase_name(machine_->phase()), family_name(machine_->family()), machine_->mode(),
        machine_->run_time(), machine_->faults(), what, recent);
  }
  void note(std::string line) {
    // RTUKIT_SIM_TRACE=1: every operation as it happens, with the machine's state (a replay's detail).
    static const bool trace = std::getenv("RTUKIT_SIM_TRACE") != nullptr;
    if (trace)
      fmt::print("{:>8} ms {} [{} {} mode {} time {} s segment {}]\n", device_ms(), line,
                 phase_name(machine_->phase()), family_name(machine_->family()), machine_->mode(),
                 machine_->run_time(), machine_->segment());
    log_.push_back(fmt::format("{:>8} ms {}", device_ms(), std::move(line)));
    if (log_.size() > 12) log_.pop_front();
  }

  // Time passes for the machine: nothing may start, a timer only counts
  // down, a plan ends where it was written.
  void advance_machine() {
    const bool before = runs(*machine_);
    const Family family = machine_->family();
    const uint16_t time = machine_->run_time();
    const Phase phase = machine_->phase();
    machine_->advance_to(device_ms());
    check_state();
    if (!before && runs(*machine_)) fail("the machine started as time passed, without a command");
    if (family == Family::timer && machine_->family() == Family::timer && machine_->run_time() > time &&
        phase == machine_->phase())
      fail(fmt::format("the timer counted up ({} -> {} s) without a command", time, machine_->run_time()));
    if (machine_->family() == Family::training && machine_->phase() == Phase::ended &&
        phase != Phase::ended) {
      const Plan plan = machine_->plan(machine_->mode());
      const unsigned length = plan_length(plan);
      // Exactly at the end, unless the integrator rewrote the running plan
      // (then it ends as soon as the time is past the new end).
      const bool exact = !plan_rewritten_;
      if (length == 0 || (exact ? machine_->run_time() != plan[length - 1].end
                                : machine_->run_time() < plan[length - 1].end))
        fail(fmt::format("plan {} ended at {} s, not at its last segment's end ({} s)", machine_->mode(),
                         machine_->run_time(), length ? plan[length - 1].end : 0));
    }
  }

  void check_state() {
    if (machine_->run_time() > kMaxTime)
      fail(fmt::format("a time of {} s (below 0 or past 99:59)", machine_->run_time()));
    if (machine_->family() == Family::timer && runs(*machine_) && machine_->run_time() > timer_top_)
      fail(fmt::format("the timer shows {} s, more than the {} s it was started with", machine_->run_time(),
                       timer_top_));
    if (machine_->family() == Family::training && runs(*machine_)) {
      const Plan plan = machine_->plan(machine_->mode());
      const unsigned length = plan_length(plan);
      if (machine_->segment() >= length)
        fail(fmt::format("plan {} runs segment {} of {}", machine_->mode(), machine_->segment() + 1, length));
    }
  }

  // The wire: each request may be lost, its answer lost, corrupted or late;
  // while an outage lasts nothing gets through.
  MemoryLink::Reply respond(std::span<const uint8_t> request) {
    ++steps_;
    if (device_ms() < outage_until_) return {};
    if (o_.faults.frames && chance(0.03)) {
      ++result_.faults_injected;
      return {};  // the request lost on the line
    }
    advance_machine();
    const bool before = runs(*machine_);
    const uint16_t time_before = machine_->run_time();
    std::array<uint8_t, kMaxRtuAduSize> out{};
    const size_t n = engine_.handle_rtu(request, out).length;
    // What it was: an accepted write touching the control block (0x0021..0x0024)?
    bool control = false;
    if (n >= 4 && request.size() >= 6 && (out[1] == 0x06 || out[1] == 0x10)) {
      const unsigned first = request[2] << 8 | request[3];
      const unsigned count = out[1] == 0x06 ? 1u : (request[4] << 8 | request[5]);
      control = first <= reg::kRunTime && first + count > reg::kWorkMode;
    }
    if (!before && runs(*machine_)) {
      if (!control) fail("the machine started on a request that was no accepted control write");
      ++result_.starts;
      plan_rewritten_ = false;
      if (machine_->family() == Family::timer) timer_top_ = machine_->run_time();
    }
    if (control && machine_->family() == Family::timer && runs(*machine_))
      timer_top_ = std::max<uint16_t>(machine_->run_time(), before ? time_before : 0);
    check_state();
    if (n == 0) return {};
    MemoryLink::Reply reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 5ms};
    if (o_.faults.frames) {
      if (chance(0.03)) {
        ++result_.faults_injected;
        return {};  // executed, the answer lost
      }
      if (chance(0.02)) {
        ++result_.faults_injected;
        reply.bytes[pick(0, static_cast<unsigned>(reply.bytes.size() - 1))] ^=
            static_cast<uint8_t>(pick(1, 255));
      } else if (chance(0.02)) {
        ++result_.faults_injected;
        reply.delay = std::chrono::milliseconds(pick(300, 900));  // after the master's deadline
      }
    }
    return reply;
  }

  void idle(unsigned ms) {
    // The integrator's program polls at 4 Hz while nothing else happens.
    const uint64_t until = device_ms() + ms;
    while (ok() && device_ms() < until && !out_of_steps()) {
      clock_.advance(250ms);
      advance_machine();
      if (chance(0.5)) (void)client_->status();
    }
  }

  // ------------------------------------------------------------ the machine's side

  void machine_events() {
    if (o_.faults.machine) {
      if (chance(0.04)) {
        const uint16_t bits = static_cast<uint16_t>(1U << pick(0, 8));
        machine_->set_injected_faults(bits);
        ++result_.faults_injected;
        note(fmt::format("fault bits {:#x} on", bits));
      } else if (machine_->injected_faults() && chance(0.3)) {
        machine_->set_injected_faults(0);
        note("fault bits cleared");
      }
      if (chance(0.01)) {
        machine_->set_mosfet_temperature(95);
        ++result_.faults_injected;
        note("MOSFET at 95 degC");
      }
      if (chance(0.01)) {
        machine_->set_mains_voltage(chance(0.5) ? 200 : 311);
        note("mains changed");
      }
    }
    if (o_.faults.outages && chance(0.02)) {
      outage_until_ = device_ms() + pick(500, 5000);
      ++result_.faults_injected;
      note(fmt::format("the line dead until {} ms", outage_until_));
    }
    if (o_.faults.power && chance(0.01)) power_cut();
  }

  // A power cut: the machine comes back off, from what its flash kept.
  void power_cut() {
    ++result_.faults_injected;
    auto fresh = std::make_unique<Machine>(device_ms());
    for (const profile::Row& row : kMap.rows()) {
      if (!row.has(profile::kPersisted)) continue;
      for (unsigned i = 0; i < row.repeat; ++i) fresh->image().set(row, machine_->image().get(row, i), i);
    }
    static_cast<profile::Model&>(*fresh).restored();
    machine_ = std::move(fresh);
    bank_.m = machine_.get();
    note("power cut: the machine restarts");
    if (runs(*machine_)) fail("the machine runs after a power-on");
  }

  // ------------------------------------------------------------ the integrator

  void operate() {
    ++result_.commands;
    const unsigned what = pick(0, 99);
    if (what < 15) {
      const uint16_t speed = static_cast<uint16_t>(pick(20, 100));
      const rtukit::Status s = client_->start_free(speed, chance(0.2));
      note(fmt::format("start free {} %: {}", speed, s ? s.reason() : "ok"));
    } else if (what < 30) {
      const uint16_t speed = static_cast<uint16_t>(pick(20, 100));
      const uint16_t duration = static_cast<uint16_t>(pick(1, 120));
      const rtukit::Status s = client_->start_timer(speed, duration, chance(0.2));
      note(fmt::format("start timer {} % for {} s: {}", speed, duration, s ? s.reason() : "ok"));
    } else if (what < 42) {
      const unsigned plan = pick(1, kPlanCount);
      const rtukit::Status s = client_->start_plan(plan);
      note(fmt::format("start plan {}: {}", plan, s ? s.reason() : "ok"));
    } else if (what < 50) {
      const rtukit::Status s = client_->pause();
      note(fmt::format("pause: {}", s ? s.reason() : "ok"));
    } else if (what < 58) {
      const rtukit::Status s = client_->resume();
      note(fmt::format("resume: {}", s ? s.reason() : "ok"));
    } else if (what < 72) {
      const rtukit::Status s = client_->stop();
      note(fmt::format("stop: {}", s ? s.reason() : "ok"));
      if (!s && runs(*machine_)) fail("the machine runs right after it acknowledged a stop");
    } else if (what < 82) {
      const uint16_t speed = static_cast<uint16_t>(pick(20, 100));
      const rtukit::Status s = client_->set_speed(speed);
      note(fmt::format("speed {} %: {}", speed, s ? s.reason() : "ok"));
    } else if (what < 92) {
      write_plan();
    } else {
      (void)client_->status();
    }
  }

  void write_plan() {
    const unsigned plan = pick(1, kPlanCount);
    std::vector<Segment> segments(pick(1, 6));
    uint16_t end = 0;
    for (Segment& s : segments) {
      end = static_cast<uint16_t>(end + pick(1, 40));
      s = {static_cast<uint16_t>(pick(20, 100)), end};
    }
    if (machine_->family() == Family::training && machine_->mode() == plan) plan_rewritten_ = true;
    const rtukit::Status s = client_->write_plan(plan, segments);
    note(fmt::format("write plan {} ({} segments, ends at {} s): {}", plan, segments.size(), end,
                     s ? s.reason() : "ok"));
    if (s) return;
    const Plan stored = machine_->plan(plan);
    if (plan_length(stored) != segments.size() ||
        !std::equal(segments.begin(), segments.end(), stored.begin()))
      fail(fmt::format("plan {} acknowledged but stored otherwise ({} segments)", plan, plan_length(stored)));
  }

  const RunOptions& o_;
  std::mt19937_64 rng_;
  ManualClock clock_;
  const Clock::time_point origin_ = clock_.now();  ///< device time 0
  std::unique_ptr<Machine> machine_;
  Forward bank_;
  SlaveEngine engine_;
  std::unique_ptr<Master> master_;
  std::unique_ptr<Client> client_;
  uint64_t steps_ = 0;
  uint64_t outage_until_ = 0;
  uint16_t timer_top_ = 0;
  bool plan_rewritten_ = false;  ///< the running plan was written during its run
  std::deque<std::string> log_;
  RunResult result_;
};

}  // namespace

RunResult run(const RunOptions& options) {
  World world(options);
  return world.go();
}

}  // namespace rtukit::inverjet::simulation
