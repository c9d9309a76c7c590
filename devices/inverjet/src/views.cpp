// The Inverjet's status as text: what `status` and `watch` print.
#include "rtukit/devices/inverjet/views.hpp"

#include <fmt/core.h>

#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/profile/text.hpp"

namespace rtukit::inverjet {

std::string factory_plan_text() {
  const Segment first = default_plan()[0];
  return fmt::format("{} at {} %", profile::format_mm_ss(first.end), first.speed);
}

std::string version_text(uint32_t v) {
  return fmt::format("V{}.{}", v >> 16, v & 0xFFFF);
}

std::string faults_text(const MachineStatus& s) {
  std::string out;
  for (auto n : s.fault_names()) out += (out.empty() ? "" : ", ") + std::string(n);
  return out.empty() ? "none" : fmt::format("{} (0x{:04X})", out, s.faults);
}

std::string time_text(const MachineStatus& s, Family remembered) {
  return fmt::format("{} {}", profile::format_mm_ss(s.run_time),
                     time_counts_name(time_counts(s, remembered)));
}

std::string status_panel(const MachineStatus& s, Family remembered, const Highlight& alert) {
  const auto mark = [&alert](std::string_view text) { return alert ? alert(text) : std::string(text); };
  const std::string faults = faults_text(s);
  return fmt::format(
      "state     {} ({})   mode {}\n"
      "speed     {} %   motor {} rpm, {:.2f} A\n"
      "time      {}\n"
      "faults    {}\n"
      "temps     MOSFET {:.1f} degC, motor {:.1f} degC\n"
      "bus       {:.1f} V\n"
      "versions  display {} (hw {}), driver {} (hw {})\n",
      s.phase() == Phase::fault ? mark(s.state_name()) : std::string(s.state_name()), s.state,
      profile::format_value(kMap.row(reg::work_mode), s.mode), s.speed, s.rpm, s.current_a,
      time_text(s, remembered), s.faults ? mark(faults) : faults, s.mosfet_c, s.motor_c, s.bus_v,
      version_text(s.display_software), version_text(s.display_hardware), version_text(s.driver_software),
      version_text(s.driver_hardware));
}

std::string status_line(const MachineStatus& s, Family remembered) {
  return fmt::format(
      "{:<17} speed {:>3} %  time {}  motor {} rpm {:.2f} A  MOSFET {:.1f} degC  motor {:.1f} degC  "
      "faults {}",
      s.state_name(), s.speed, time_text(s, remembered), s.rpm, s.current_a, s.mosfet_c, s.motor_c,
      faults_text(s));
}

}  // namespace rtukit::inverjet
