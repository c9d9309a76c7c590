// The simulated Inverjet's console: what a service technician does to the
// machine from outside (faults, temperatures, mains). The rest of the
// simulator is the profile kit's one simulator host.
#include "rtukit/devices/inverjet/sim.hpp"

#include <fmt/core.h>

#include <cctype>

#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/driver/simulation.hpp"

namespace rtukit::inverjet {
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
  for (const profile::Named& c : fault_names()) {
    if (slug(c.name) == slug(word)) return static_cast<uint16_t>(1U << c.value);
  }
  return std::nullopt;
}
}  // namespace

profile::SimDevice make_sim_device() {
  auto model = std::make_unique<Machine>();
  Machine& m = *model;
  const auto faults_line = [&m] {
    return fmt::format("faults: {} (0x{:04X}), state {}",
                       profile::format_value(kMap.row(reg::faults), m.faults()), m.faults(),
                       profile::format_value(kMap.row(reg::state), m.state()));
  };
  std::vector<profile::ConsoleVerb> verbs;
  verbs.push_back({"fault", "fault NAME|BIT|0xMASK [on|off]",
                   "inject (or clear) fault bits of input register 0x0008; 'fault clear' clears all",
                   [&m, faults_line](std::span<const std::string> w) -> Outcome<std::string> {
                     if (w.empty()) return std::string("usage: fault NAME|BIT|0xMASK [on|off] | fault clear");
                     if (w[0] == "clear") {
                       m.set_injected_faults(0);
                       return faults_line();
                     }
                     const std::optional<uint16_t> mask = fault_mask(w[0]);
                     if (!mask) {
                       std::string names;
                       for (const profile::Named& c : fault_names())
                         names += fmt::format(" {}={}", c.value, slug(c.name));
                       return fmt::format("unknown fault '{}' (bits:{})", w[0], names);
                     }
                     const bool on = w.size() < 2 || w[1] != "off";
                     m.set_injected_faults(static_cast<uint16_t>(on ? m.injected_faults() | *mask
                                                                    : m.injected_faults() & ~*mask));
                     return faults_line();
                   }});
  verbs.push_back({"temp", "temp mosfet|motor DEGC", "set a temperature (the model carries on from there)",
                   [&m](std::span<const std::string> w) -> Outcome<std::string> {
                     const std::optional<double> t = w.size() == 2 ? parse_double(w[1]) : std::nullopt;
                     if (!t || (w[0] != "mosfet" && w[0] != "motor") || *t < -40 || *t > 200)
                       return std::string("usage: temp mosfet|motor DEGC (-40..200)");
                     if (w[0] == "mosfet")
                       m.set_mosfet_temperature(*t);
                     else
                       m.set_motor_temperature(*t);
                     return fmt::format("{} temperature {:.1f} degC; faults 0x{:04X}", w[0], *t, m.faults());
                   }});
  verbs.push_back({"mains", "mains VOLTS", "set the mains (unloaded DC bus) voltage",
                   [&m](std::span<const std::string> w) -> Outcome<std::string> {
                     const std::optional<double> volts = w.size() == 1 ? parse_double(w[0]) : std::nullopt;
                     if (!volts || *volts < 0 || *volts > 600)
                       return std::string("usage: mains VOLTS (0..600)");
                     m.set_mains_voltage(*volts);
                     return fmt::format("mains {:.1f} V, bus {:.1f} V; faults 0x{:04X}", *volts,
                                        m.bus_voltage(), m.faults());
                   }});
  const auto status_extra = [&m]() -> std::string {
    if (m.mode() < 1 || m.mode() > kPlanCount) return {};
    return fmt::format("  {:<32} {} of {}\n", "plan segment", m.segment() + 1, plan_length(m.plan(m.mode())));
  };
  return profile::SimDevice{std::move(model), std::move(verbs), status_extra, {}};
}

}  // namespace rtukit::inverjet
