// fault_soak: our master against each simulator on a faulty virtual bus,
// for a long time, checking every value and every write (issue 13, section 4;
// figures in docs/reliability.md, "Fault soaks").
//
// One soak: a virtual bus hosted here (driver/virtual_bus.hpp) with the
// faults asked for, `rtukit sim DEVICE -v` on one port (it logs every request
// it executed and its answer), `rtukit doctor` run on the faulty line, and
// our Master on the other port with the options the doctor recommends. The
// master runs a mix of reads and writes (FC03, FC04, FC06, FC10 on the
// device's own registers, values from its register table) for N
// transactions, then the faults stop (VirtualBus::set_faults) and it runs a
// few hundred more. Afterwards the simulator's log is compared with what the
// master sent and accepted:
//   - a corrupted write executed: the simulator executed a write request
//     (and answered it normally) that is not byte for byte one the master sent;
//   - a corrupted value accepted: a read the master accepted whose values the
//     simulator never sent in answer to that request;
//   - a write the master took as done that the simulator never executed;
//   - recovery: failed transactions after the faults stopped (the target is
//     none after the first).
//
//   build/default/bench/fault_soak [--device inverjet|rehand6600]... [--fault
//   noise|drop|stray|latency|echo]...
//                                  [--transactions N] [--ber R] [--seed S]
//                                  [--retries-floor N]  (the master's least retries, likewise)
//                                  [--timeout-floor MS]  (the master's least response timeout: CI's
//                                  smoke run checks values and writes, not how fast a busy machine answers)
// Exit status: 0 when every check held, 1 otherwise, 2 on bad usage.
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../tests/process.hpp"
#include "rtukit/devices/inverjet/registers.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/virtual_bus.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/io/port.hpp"

using namespace rtukit;
using namespace rtukit::test;
using namespace std::chrono_literals;

namespace {

using Bytes = std::vector<uint8_t>;

// What a soak leaves if it ends early: its folder under /tmp and its
// simulator. TempDir and Process clean up when soak() returns, but std::exit
// (the failure paths below) skips the destructors of locals and a signal
// (ctest stopping the test, Ctrl-C, a closed terminal) skips everything. So
// they are also listed here, and cleaned up at exit and, on SIGTERM, SIGINT or
// SIGHUP, by a thread the handler wakes through a pipe (a handler may only
// write(2)), which then ends the process by that signal. SIGKILL leaves them.
struct Leftovers {
  std::mutex mutex;
  std::vector<std::string> dirs;
  std::vector<pid_t> children;
  int wake[2] = {-1, -1};

  void clean() {
    std::lock_guard lock(mutex);
    for (const pid_t p : children) ::kill(p, SIGTERM);
    for (const std::string& d : dirs) {
      std::error_code ignored;
      std::filesystem::remove_all(d, ignored);
    }
    children.clear();
    dirs.clear();
  }
};
Leftovers leftovers;

// Lists a soak's folder, then its simulator, for as long as it lives.
struct Listed {
  explicit Listed(std::string dir) : dir_(std::move(dir)) {
    std::lock_guard lock(leftovers.mutex);
    leftovers.dirs.push_back(dir_);
  }
  void child(pid_t pid) {
    std::lock_guard lock(leftovers.mutex);
    leftovers.children.push_back(child_ = pid);
  }
  ~Listed() {
    std::lock_guard lock(leftovers.mutex);
    std::erase(leftovers.dirs, dir_);
    std::erase(leftovers.children, child_);
  }
  Listed(const Listed&) = delete;
  Listed& operator=(const Listed&) = delete;

 private:
  std::string dir_;
  pid_t child_ = -1;
};

extern "C" void on_stop_signal(int sig) {
  const unsigned char s = static_cast<unsigned char>(sig);
  [[maybe_unused]] const ssize_t n = ::write(leftovers.wake[1], &s, 1);
}

void clean_up_on_exit_and_signals() {
  std::atexit([] { leftovers.clean(); });
  if (::pipe2(leftovers.wake, O_CLOEXEC) != 0) return;
  std::thread([] {
    unsigned char s = 0;
    ssize_t n = 0;
    while ((n = ::read(leftovers.wake[0], &s, 1)) < 0 && errno == EINTR) {
    }
    if (n != 1) return;
    leftovers.clean();
    std::signal(s, SIG_DFL);
    std::raise(s);
    std::_Exit(128 + s);
  }).detach();
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  for (const int sig : {SIGTERM, SIGINT, SIGHUP}) ::sigaction(sig, &sa, nullptr);
}

/// One request of the workload.
struct Op {
  enum Kind { read_holding, read_input, write_single, write_multiple } kind;
  uint16_t address = 0;
  uint16_t count = 0;            // reads
  std::vector<uint16_t> values;  // writes
};

/// A device under soak: how to start it and what to ask of it.
struct Target {
  std::string device;  // rtukit sim DEVICE
  const profile::Profile* profile;
  uint32_t baud;
  uint16_t doctor_address;  // a holding register the doctor may read
  Op (*next)(std::mt19937_64&);
};

uint16_t pick(std::mt19937_64& rng, uint16_t lo, uint16_t hi) {
  return static_cast<uint16_t>(std::uniform_int_distribution<unsigned>(lo, hi)(rng));
}

// The Inverjet: its flash settings and training plans, written and read back,
// and its input registers. Addresses and ranges from its register table.
Op inverjet_op(std::mt19937_64& rng) {
  namespace ij = inverjet;
  const uint16_t plan = ij::reg::at(ij::reg::plan_speed(1 + pick(rng, 0, 3)));
  switch (pick(rng, 0, 5)) {
    case 0:
      return {Op::read_holding, ij::reg::at(ij::reg::free_speed), 4, {}};
    case 1:
      return {Op::write_single, ij::reg::at(ij::reg::free_speed), 0, {pick(rng, 0, ij::kMaxSpeed)}};
    case 2: {
      // Five segments: speed, end time, speed, end time, ...
      Op op{Op::write_multiple, static_cast<uint16_t>(plan + 2 * pick(rng, 0, 45)), 0, {}};
      for (int i = 0; i < 5; ++i) {
        op.values.push_back(pick(rng, 0, ij::kMaxSpeed));
        op.values.push_back(pick(rng, 0, ij::kMaxTime));
      }
      return op;
    }
    case 3:
      return {Op::read_holding, static_cast<uint16_t>(plan + 2 * pick(rng, 0, 45)), 10, {}};
    case 4:
      return {Op::read_input, 0, ij::reg::kInputCount, {}};
    default:
      return {Op::write_multiple,
              ij::reg::at(ij::reg::timer_speed),
              0,
              {pick(rng, 0, ij::kMaxSpeed), pick(rng, 0, ij::kMaxTime)}};
  }
}

// The Rehand 6600: the host's poll of table 1 (in parts), its settings and
// the reserved registers of table 2 (stored, no effect). No motion command:
// a soak must not drive the chair.
Op rehand_op(std::mt19937_64& rng) {
  switch (pick(rng, 0, 4)) {
    case 0:
      return {Op::read_holding, 0x0000, 16, {}};
    case 1:
      return {Op::read_holding, pick(rng, 0x10, 0x20), 16, {}};
    case 2:
      return {Op::write_single, 0x0069, 0, {pick(rng, 1, 5)}};  // speed_level
    case 3:
      return {Op::write_single, 0x0060, 0, {pick(rng, 1, 3)}};  // drive_mode
    default: {
      Op op{Op::write_multiple, 0x0076, 0, {}};
      for (int i = 0; i < 10; ++i) op.values.push_back(pick(rng, 0, 0xFFFF));
      return op;
    }
  }
}

std::string hex(const Bytes& b) {
  std::string s;
  char buf[4];
  for (uint8_t x : b) {
    std::snprintf(buf, sizeof buf, "%02X ", x);
    s += buf;
  }
  return s;
}

Bytes parse_hex(const std::string& text) {
  Bytes out;
  std::istringstream in(text);
  std::string tok;
  while (in >> tok) out.push_back(static_cast<uint8_t>(std::stoul(tok, nullptr, 16)));
  return out;
}

/// A request the simulator executed and what it answered ("rx .. -> tx ..").
struct Served {
  Bytes rx, tx;
};

std::vector<Served> parse_sim_log(const std::string& log) {
  std::vector<Served> out;
  std::istringstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.starts_with("rx ")) continue;
    const size_t arrow = line.find(" -> ");
    if (arrow == std::string::npos) continue;
    Served s;
    s.rx = parse_hex(line.substr(3, arrow - 3));
    const std::string rest = line.substr(arrow + 4);
    if (rest.starts_with("tx ")) s.tx = parse_hex(rest.substr(3));
    out.push_back(std::move(s));
  }
  return out;
}

bool is_write(uint8_t fc) {
  return fc == 0x05 || fc == 0x06 || fc == 0x0F || fc == 0x10 || fc == 0x16 || fc == 0x17;
}

/// The register values in a read response (FC03/04, 1- or 2-byte count): the
/// 2n bytes before the CRC.
std::vector<uint16_t> response_values(const Bytes& tx, size_t n) {
  std::vector<uint16_t> v;
  if (tx.size() < 2 * n + 4) return v;
  const size_t at = tx.size() - 2 - 2 * n;
  for (size_t i = 0; i < n; ++i) v.push_back(static_cast<uint16_t>(tx[at + 2 * i] << 8 | tx[at + 2 * i + 1]));
  return v;
}

struct DoctorAdvice {
  std::string options;  // as printed
  MasterOptions master;
};

// `rtukit doctor` on the faulty line; its recommended options as MasterOptions.
DoctorAdvice ask_doctor(const std::string& port, const Target& t) {
  const RunResult r = run({RTUKIT_BIN, "doctor", "--port", port, "--baud", std::to_string(t.baud), "--unit",
                           std::to_string(profile::link_defaults(*t.profile).unit), "--address",
                           std::to_string(t.doctor_address), "--rounds", "20"},
                          120s);
  DoctorAdvice a;
  const size_t at = r.output.find("recommended: ");
  if (r.code != 0 || at == std::string::npos) {
    std::fprintf(stderr, "doctor failed (exit %d):\n%s\n", r.code, r.output.c_str());
    std::exit(1);
  }
  a.options = r.output.substr(at + 13, r.output.find('\n', at) - at - 13);
  std::istringstream in(a.options);
  std::string opt;
  while (in >> opt) {
    std::string value;
    if (opt == "--timeout" && in >> value)
      a.master.response_timeout = std::chrono::milliseconds(std::stoul(value));
    if (opt == "--delay" && in >> value)
      a.master.inter_request_delay = std::chrono::milliseconds(std::stoul(value));
    if (opt == "--retries" && in >> value) a.master.retries = static_cast<unsigned>(std::stoul(value));
    if (opt == "--baud") in >> value;
    if (opt == "--echo") a.master.discard_echo = true;
  }
  return a;
}

struct Report {
  std::string device, fault, doctor;
  uint64_t transactions = 0, failed = 0, longest_failure_run = 0;
  uint64_t exceptions = 0;  // answers the device refused: a workload error, never expected
  MasterStats master;
  BusLineStats bus;
  uint64_t sim_served = 0;
  uint64_t foreign_frames = 0;      // frames the simulator accepted that the master never sent
  uint64_t corrupted_writes = 0;    // of those, writes it executed
  uint64_t corrupted_values = 0;    // reads accepted with values the simulator never sent
  uint64_t unconfirmed_writes = 0;  // writes the master took as done, never executed
  uint64_t after = 0, after_failed = 0, last_failure_after = 0;  // once the faults stopped
  double seconds = 0;
  bool ok() const {
    return exceptions == 0 && corrupted_writes == 0 && corrupted_values == 0 && unconfirmed_writes == 0 &&
           (after_failed == 0 || (after_failed == 1 && last_failure_after == 1));
  }
};

// --timeout-floor: the least response timeout the master uses, whatever the doctor recommends.
std::chrono::milliseconds g_timeout_floor{0};
// --retries-floor: the least number of retries, likewise. A busy machine
// (CI's ASan suite, browsers beside it) can hold an answer past the timeout
// or split a frame past the silence that ends it: on the line that is a lost
// frame, which a master retries. Without it the smoke run failed about one
// run in four with "after the faults stopped: 1 of 50 failed", no fault on
// the line. The documented long runs keep the doctor's own figure.
unsigned g_retries_floor = 0;

Report soak(const Target& t, const std::string& fault, BusConfig faults, uint64_t transactions,
            uint64_t after, uint64_t seed) {
  Report rep;
  rep.device = t.device;
  rep.fault = fault;
  TempDir dir;
  Listed listed(dir.path());  // declared after dir: unlisted before TempDir removes it
  asio::io_context ctx;
  faults.baud = t.baud;
  faults.bits_per_char = 10;
  faults.seed = seed;
  auto bus = VirtualBus::start(ctx, {.ports = 2, .links = {dir / "dev", dir / "host"}, .line = faults});
  if (!bus.ok()) {
    std::fprintf(stderr, "bus: %s\n", std::string(bus.error().reason()).c_str());
    std::exit(1);
  }
  auto guard = asio::make_work_guard(ctx);
  std::thread bus_thread([&] { ctx.run(); });

  Process sim({RTUKIT_BIN, "sim", t.device, "--listen", dir / "dev", "--baud", std::to_string(t.baud),
               "--no-state", "--no-console", "-v"});
  listed.child(sim.pid());
  if (!sim.wait_for_output("listening on", 10s)) {
    std::fprintf(stderr, "the simulator did not start:\n%s\n", sim.output().c_str());
    std::exit(1);
  }
  const DoctorAdvice advice = ask_doctor(dir / "host", t);
  rep.doctor = advice.options;
  // The doctor's probes are in the simulator's log too: the soak's part starts after them.
  const size_t doctor_served = parse_sim_log(sim.output()).size();
  std::fprintf(stderr, "%s, %s: doctor recommends %s\n", t.device.c_str(), fault.c_str(),
               advice.options.c_str());

  MasterOptions o = advice.master;
  // The doctor times an idle moment; a shared machine's busy moment may answer
  // later. Where timing is not what is checked (CI's smoke run), a floor.
  o.response_timeout = std::max(o.response_timeout, g_timeout_floor);
  o.retries = std::max(o.retries, g_retries_floor);
  o.quirks = t.profile->quirks;
  o.fc10_without_byte_count = t.profile->quirks.fc10_without_byte_count;
  std::set<Bytes> sent;
  Bytes last_request, last_received;
  o.trace = [&](const TraceEvent& e) {
    if (e.direction == TraceEvent::Direction::received) {
      last_received.assign(e.bytes.begin(), e.bytes.end());
      return;
    }
    last_request.assign(e.bytes.begin(), e.bytes.end());
    sent.insert(last_request);
  };
  io::PortSpec spec = *io::parse_port(dir / "host", false);
  spec.serial.baud = t.baud;
  Master m(io::make_link(spec), o);
  const UnitId unit{profile::link_defaults(*t.profile).unit};

  struct Accepted {
    Bytes request;
    std::vector<uint16_t> values;
    bool write;
    Bytes received;  // every byte the master read during the accepted attempt
    uint64_t index;  // the transaction's number
  };
  std::vector<Accepted> accepted;
  std::mt19937_64 rng(seed);
  uint64_t run = 0;
  const auto transaction = [&]() {
    const Op op = t.next(rng);
    std::vector<uint16_t> values(op.count);
    Error e;
    switch (op.kind) {
      case Op::read_holding:
        e = m.read_holding_registers(unit, op.address, values);
        break;
      case Op::read_input:
        e = m.read_input_registers(unit, op.address, values);
        break;
      case Op::write_single:
        e = m.write_single_register(unit, op.address, op.values[0]);
        break;
      case Op::write_multiple:
        e = m.write_multiple_registers(unit, op.address, op.values);
        break;
    }
    if (e.ok())
      accepted.push_back({last_request, std::move(values), op.kind >= Op::write_single, last_received,
                          rep.transactions + rep.after});
    return e;
  };
  const auto t0 = std::chrono::steady_clock::now();
  for (uint64_t i = 0; i < transactions; ++i) {
    if (i && i % 10000 == 0)
      std::fprintf(stderr, "  %s, %s: %llu transactions\n", t.device.c_str(), fault.c_str(),
                   static_cast<unsigned long long>(i));
    const Error e = transaction();
    ++rep.transactions;
    if (e.ok()) {
      run = 0;
      continue;
    }
    if (e.is_exception() && ++rep.exceptions <= 5)
      std::fprintf(stderr, "exception %s (a workload value the device refused?)\n",
                   std::string(e.name()).c_str());
    ++rep.failed;
    rep.longest_failure_run = std::max(rep.longest_failure_run, ++run);
  }
  // The noise stops (the cable is put back, the adapter fixed). Not an
  // adapter's echo: that is how the adapter is built.
  if (faults.echo_ports) after = 0;
  (*bus)->set_faults({});
  for (uint64_t i = 1; i <= after; ++i) {
    ++rep.after;
    if (transaction()) {
      ++rep.after_failed;
      rep.last_failure_after = i;
    }
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rep.master = m.stats();
  sim.stop();
  std::vector<Served> served = parse_sim_log(sim.output());
  served.erase(served.begin(),
               served.begin() + static_cast<std::ptrdiff_t>(std::min(doctor_served, served.size())));
  rep.sim_served = served.size();
  asio::post(ctx, [&] {
    rep.bus = (*bus)->stats();
    bus->reset();
    guard.reset();
  });
  bus_thread.join();

  // What the simulator executed against what the master sent.
  std::map<std::pair<Bytes, std::vector<uint16_t>>, unsigned> answers;  // (request, values) -> times sent
  std::map<Bytes, unsigned> executed_writes;
  for (const Served& s : served) {
    if (s.rx.size() < 4 || s.rx[0] != unit.value) continue;
    const uint8_t fc = s.rx[1];
    const bool normal = s.tx.size() >= 2 && s.tx[1] == fc;
    if (!sent.contains(s.rx)) {
      ++rep.foreign_frames;
      if (rep.foreign_frames <= 5)
        std::fprintf(stderr, "executed but never sent: rx %s\n", hex(s.rx).c_str());
      if (is_write(fc) && normal) ++rep.corrupted_writes;
      continue;
    }
    if (!normal) continue;
    if (is_write(fc)) {
      ++executed_writes[s.rx];
    } else if (fc == 0x03 || fc == 0x04) {
      const size_t n = static_cast<size_t>(s.rx[4] << 8 | s.rx[5]);
      ++answers[{s.rx, response_values(s.tx, n)}];
    }
  }
  for (const Accepted& a : accepted) {
    if (a.write) {
      if (executed_writes[a.request] == 0) ++rep.unconfirmed_writes;
      continue;
    }
    auto it = answers.find({a.request, a.values});
    if (it != answers.end() && it->second > 0) {
      --it->second;
      continue;
    }
    // What the master took, and what the simulator answered to that request.
    if (++rep.corrupted_values <= 5) {
      std::string sim_answers;
      for (const Served& s : served)
        if (s.rx == a.request) sim_answers += "\n    sim answered: " + hex(s.tx);
      std::fprintf(stderr, "corrupted value accepted, transaction %llu: request %s\n    master read: %s%s\n",
                   static_cast<unsigned long long>(a.index), hex(a.request).c_str(), hex(a.received).c_str(),
                   sim_answers.c_str());
    }
  }
  return rep;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> devices{"inverjet", "rehand6600"},
      faults{"noise", "drop", "stray", "latency", "echo"};
  uint64_t transactions = 0, seed = 1, after = 500;
  double ber = 1e-3;
  bool device_given = false, fault_given = false;  // repeatable options: the first replaces the default
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--device" && has) {
      if (!device_given) devices.clear();
      device_given = true;
      devices.push_back(argv[++i]);
    } else if (a == "--fault" && has) {
      if (!fault_given) faults.clear();
      fault_given = true;
      faults.push_back(argv[++i]);
    } else if (a == "--transactions" && has) {
      transactions = std::stoull(argv[++i]);
    } else if (a == "--ber" && has) {
      ber = std::stod(argv[++i]);
    } else if (a == "--seed" && has) {
      seed = std::stoull(argv[++i]);
    } else if (a == "--after" && has) {
      after = std::stoull(argv[++i]);
    } else if (a == "--timeout-floor" && has) {
      g_timeout_floor = std::chrono::milliseconds(std::stoull(argv[++i]));
    } else if (a == "--retries-floor" && has) {
      g_retries_floor = static_cast<unsigned>(std::stoul(argv[++i]));
    } else {
      std::fprintf(stderr,
                   "usage: fault_soak [--device inverjet|rehand6600] [--fault noise|drop|stray|latency|echo] "
                   "[--transactions N] [--ber R] [--after N] [--seed S] [--timeout-floor MS] [--retries-floor N]\n");
      return 2;
    }
  }
  ::signal(SIGPIPE, SIG_IGN);
  clean_up_on_exit_and_signals();
  // The Inverjet at its fastest documented rate (D-4), the Rehand at its own.
  const Target targets[] = {
      {"inverjet", &inverjet::kProfile, 19200, inverjet::reg::kAddress, inverjet_op},
      {"rehand6600", &rehand6600::kProfile, 115200, 0x0000, rehand_op},
  };
  std::vector<Report> reports;
  for (const std::string& d : devices) {
    const Target* t = nullptr;
    for (const Target& x : targets)
      if (x.device == d) t = &x;
    if (!t) {
      std::fprintf(stderr, "unknown device %s\n", d.c_str());
      return 2;
    }
    for (const std::string& f : faults) {
      BusConfig c;
      uint64_t n = transactions;
      if (f == "noise") {
        c.bit_error_rate = ber;
        if (!n) n = 100000;
      } else if (f == "drop") {
        c.drop_rate = 1e-3;
      } else if (f == "stray") {
        c.stray_rate = 0.05;
      } else if (f == "latency") {
        c.latency_us = 16000;
      } else if (f == "echo") {
        c.echo_ports = 1U << 1;  // the master's adapter (port 1) echoes; the device's transceiver does not
      } else {
        std::fprintf(stderr, "unknown fault %s\n", f.c_str());
        return 2;
      }
      if (!n) n = 5000;
      reports.push_back(soak(*t, f, c, n, after, seed));
      const Report& r = reports.back();
      std::fprintf(
          stderr,
          "%s, %s: %llu transactions in %.0f s, %llu failed (longest run %llu); master: %llu retries, "
          "%llu timeouts, %llu corrupted frames dropped; bus: %llu characters, %llu with bit errors, "
          "%llu dropped, %llu stray; simulator executed %llu requests, %llu not as sent (corrupted "
          "but CRC-valid), %llu of them writes; corrupted values accepted %llu; writes taken as done "
          "but never executed %llu; after the faults stopped: %llu of %llu failed (last #%llu)\n",
          r.device.c_str(), r.fault.c_str(), (unsigned long long)r.transactions, r.seconds,
          (unsigned long long)r.failed, (unsigned long long)r.longest_failure_run,
          (unsigned long long)r.master.retries, (unsigned long long)r.master.timeouts,
          (unsigned long long)r.master.crc_errors, (unsigned long long)r.bus.characters,
          (unsigned long long)r.bus.bit_errors, (unsigned long long)r.bus.dropped,
          (unsigned long long)r.bus.stray, (unsigned long long)r.sim_served,
          (unsigned long long)r.foreign_frames, (unsigned long long)r.corrupted_writes,
          (unsigned long long)r.corrupted_values, (unsigned long long)r.unconfirmed_writes,
          (unsigned long long)r.after_failed, (unsigned long long)r.after,
          (unsigned long long)r.last_failure_after);
    }
  }
  std::printf(
      "| device | fault | doctor recommends | transactions | failed (longest run) | retries | characters "
      "damaged "
      "on the line | CRC-valid corruptions executed (writes) | corrupted values accepted | writes never "
      "executed | "
      "failed after the fault stopped | time |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  bool all_ok = true;
  for (const Report& r : reports) {
    all_ok = all_ok && r.ok();
    std::printf(
        "| %s | %s | `%s` | %llu | %llu (%llu) | %llu | %llu | %llu (%llu) | %llu | %llu | %llu of %llu | "
        "%.0f s |\n",
        r.device.c_str(), r.fault.c_str(), r.doctor.c_str(), (unsigned long long)r.transactions,
        (unsigned long long)r.failed, (unsigned long long)r.longest_failure_run,
        (unsigned long long)r.master.retries,
        (unsigned long long)(r.bus.bit_errors + r.bus.dropped + r.bus.stray),
        (unsigned long long)r.foreign_frames, (unsigned long long)r.corrupted_writes,
        (unsigned long long)r.corrupted_values, (unsigned long long)r.unconfirmed_writes,
        (unsigned long long)r.after_failed, (unsigned long long)r.after, r.seconds);
  }
  return all_ok ? 0 : 1;
}
