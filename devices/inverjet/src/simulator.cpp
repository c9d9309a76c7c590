// The simulator's runtime: clock scaling, link changes after the response,
// saving the flash, the console. The machine itself is in machine.cpp.
#include "rtukit/devices/inverjet/simulator.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <asio.hpp>
#include <cctype>
#include <charconv>
#include <vector>

#include "rtukit/devices/inverjet/state_file.hpp"

namespace rtukit::inverjet {

Simulator::Simulator(SimulatorOptions options) : options_(std::move(options)), clock_(options_.time_scale) {}

Result<std::unique_ptr<Simulator>> Simulator::start(asio::io_context& ctx, SimulatorOptions options,
                                                    std::string* why) {
  const auto bad = [why](const std::string& reason) {
    if (why) *why = reason;
    return Result<std::unique_ptr<Simulator>>(Errc::invalid_argument);
  };
  if (!DeviceClock::valid_scale(options.time_scale))
    return bad("--time-scale must be > 0 (and at most 100000)");
  if (options.unit && (*options.unit < 1 || *options.unit > 254))
    return bad("the Inverjet's address is 1..254");
  if (options.baud && code_of_baud(*options.baud) < 0)
    return bad("the Inverjet runs at 1200, 2400, 4800, 9600 or 19200 baud");

  std::unique_ptr<Simulator> sim(new Simulator(std::move(options)));
  SimulatorOptions& o = sim->options_;
  Settings settings;
  bool loaded_from_file = false;
  if (!o.state_file.empty()) {
    LoadedSettings loaded = load_settings(o.state_file);
    if (!loaded.warning.empty() && o.notice) o.notice("warning: " + loaded.warning);
    settings = loaded.settings;
    loaded_from_file = loaded.from_file;
  }
  const Settings stored = settings;
  if (o.unit) settings.address = *o.unit;
  if (o.baud) settings.baud_code = static_cast<uint16_t>(code_of_baud(*o.baud));
  // The link runs at the device's baud rate unless the command line chose one.
  o.listen.serial.baud = baud_of_code(settings.baud_code);
  sim->machine_ = Machine(settings, sim->device_ms());
  sim->unit_ = static_cast<uint8_t>(settings.address);
  // First start (no file yet) or options that changed what is stored: write it now.
  if (!o.state_file.empty() && (!loaded_from_file || !(stored == settings))) sim->save();

  Simulator* self = sim.get();
  sim->bank_ = std::make_unique<MachineBank>(
      sim->machine_, [self] { return self->device_ms(); }, [self] { self->after_response(); });
  (void)sim->engine_.add_unit(sim->unit_, *sim->bank_);
  auto listener = SlaveListener::start(ctx, sim->engine_, o.listen, why, o.log);
  if (!listener.ok()) return listener.error();
  sim->listener_ = std::move(*listener);
  // Advance the model regularly, so a timer ends (and a fault shows) even
  // when no master is polling.
  sim->ticker_ = std::make_unique<PeriodicTimer>(ctx, std::chrono::milliseconds(20),
                                                 [self] { self->machine_.advance_to(self->device_ms()); });
  return sim;
}

std::string Simulator::where() const {
  return listener_->where();
}

Machine& Simulator::machine() {
  machine_.advance_to(device_ms());
  return machine_;
}

// The response to the write went out with the old address and rate; now
// the device moves (seed 3.2.1, 3.2.2).
void Simulator::after_response() {
  const Machine::LinkChange change = machine_.take_link_change();
  if (change.address && *change.address != unit_) {
    if (!engine_.change_unit_address(unit_, *change.address)) {
      if (options_.notice) options_.notice(fmt::format("address changed: {} -> {}", unit_, *change.address));
      unit_ = *change.address;
    }
  }
  if (change.baud) {
    const Error e = listener_->set_baud(*change.baud);
    if (options_.notice)
      options_.notice(e ? fmt::format("cannot switch to {} baud: {}", *change.baud, e.name())
                        : fmt::format("baud rate changed to {}", *change.baud));
  }
  if (machine_.take_settings_changed()) save();
}

void Simulator::save() {
  if (options_.state_file.empty()) return;
  std::string why;
  if (save_settings(options_.state_file, machine_.settings(), &why) && options_.notice)
    options_.notice("warning: settings not saved: " + why);
}

std::string Simulator::status_text() {
  Machine& m = machine();
  std::string out = fmt::format("device time {} (x{:g})\n",
                                format_mm_ss(static_cast<unsigned>(m.now_ms() / 1000)), options_.time_scale);
  // Every named register, decoded by the same table the CLI uses.
  for (const Register& r : registers()) {
    if (r.repeat > 1) continue;
    std::array<uint16_t, 2> w{};
    const std::span<uint16_t> words(w.data(), r.words);
    const Errc e =
        r.table == Table::holding ? m.read_holding(r.address, words) : m.read_input(r.address, words);
    if (e != Errc::ok) continue;
    const uint32_t raw = r.words == 2 ? (uint32_t{w[0]} << 16) | w[1] : w[0];
    out += fmt::format("  {:<32} {}\n", r.title, format_value(r, raw));
  }
  if (m.mode() >= 1 && m.mode() <= kPlanCount) {
    const Plan& plan = m.settings().plans[m.mode() - 1];
    out += fmt::format("  {:<32} {} of {}\n", "plan segment", m.segment() + 1, plan_length(plan));
  }
  return out;
}

namespace {
std::string slug(std::string_view name) {
  std::string s;
  for (char c : name) s += c == ' ' ? '-' : static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// "3", "0x0082" or a fault name as in the table ("mosfet-over-temperature").
std::optional<uint16_t> fault_mask(const std::string& word) {
  if (const std::optional<long> v = parse_long(word)) {
    const bool mask = word.starts_with("0x") || word.starts_with("0X");
    if (mask)
      return *v >= 0 && *v <= 0xFFFF ? std::optional<uint16_t>(static_cast<uint16_t>(*v)) : std::nullopt;
    return *v >= 0 && *v <= 8 ? std::optional<uint16_t>(static_cast<uint16_t>(1U << *v)) : std::nullopt;
  }
  for (const Choice& c : fault_names()) {
    if (slug(c.name) == slug(word)) return static_cast<uint16_t>(1U << c.value);
  }
  return std::nullopt;
}
}  // namespace

std::string Simulator::command(std::string_view line) {
  const std::vector<std::string> w = split_words(line);
  if (w.empty()) return {};
  Machine& m = machine();
  const std::string& verb = w[0];
  if (verb == "help" || verb == "?") {
    std::string names;
    for (const Choice& c : fault_names()) names += fmt::format(" {}={}", c.value, slug(c.name));
    return "commands:\n"
           "  status                       print the machine\n"
           "  fault NAME|BIT|0xMASK [off]  inject (or clear) fault bits of input register 0x0008\n"
           "  fault clear                  clear every injected fault\n"
           "  temp mosfet|motor DEGC       set a temperature (the model carries on from there)\n"
           "  mains VOLTS                  set the mains (unloaded DC bus) voltage\n"
           "  quit                         stop the simulator\n"
           "fault bits:" +
           names + "\n";
  }
  if (verb == "status") return status_text();
  if (verb == "quit" || verb == "exit") {
    quit_ = true;
    return "bye";
  }
  if (verb == "fault") {
    if (w.size() < 2) return "usage: fault NAME|BIT|0xMASK [on|off] | fault clear";
    if (w[1] == "clear") {
      m.set_injected_faults(0);
    } else {
      const std::optional<uint16_t> mask = fault_mask(w[1]);
      if (!mask) return fmt::format("unknown fault '{}' (see help)", w[1]);
      const bool on = w.size() < 3 || w[2] != "off";
      m.set_injected_faults(
          static_cast<uint16_t>(on ? m.injected_faults() | *mask : m.injected_faults() & ~*mask));
    }
    const Register& faults = *find_register(Table::input, reg::kFaults);
    return fmt::format("faults: {} (0x{:04X}), state {}", format_value(faults, m.faults()), m.faults(),
                       format_value(*find_register(Table::holding, reg::kState), m.state()));
  }
  if (verb == "temp") {
    const std::optional<double> t = w.size() == 3 ? parse_double(w[2]) : std::nullopt;
    if (!t || (w[1] != "mosfet" && w[1] != "motor") || *t < -40 || *t > 200)
      return "usage: temp mosfet|motor DEGC (-40..200)";
    const double c = *t;
    if (w[1] == "mosfet")
      m.set_mosfet_temperature(c);
    else
      m.set_motor_temperature(c);
    return fmt::format("{} temperature {:.1f} degC; faults 0x{:04X}", w[1], c, m.faults());
  }
  if (verb == "mains") {
    const std::optional<double> volts = w.size() == 2 ? parse_double(w[1]) : std::nullopt;
    if (!volts || *volts < 0 || *volts > 600) return "usage: mains VOLTS (0..600)";
    const double v = *volts;
    m.set_mains_voltage(v);
    return fmt::format("mains {:.1f} V, bus {:.1f} V; faults 0x{:04X}", v, m.bus_voltage(), m.faults());
  }
  return fmt::format("unknown command '{}' (try help)", verb);
}

}  // namespace rtukit::inverjet
