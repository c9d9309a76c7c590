// rtukit Inverjet: the status as people read it, once, for every text
// front-end (`rtukit inverjet status` and `watch`). Plain text: the caller
// decides how a fault is highlighted (`Highlight`) and what goes before a
// line (the time), so nothing here knows a terminal.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "rtukit/devices/inverjet/client.hpp"

namespace rtukit::inverjet {

/// How a front-end marks what needs attention (a fault); nullptr: as it is.
using Highlight = std::function<std::string(std::string_view)>;

/// The factory plan (D-11) in words: "01:00 at 20 %".
std::string factory_plan_text();
/// "V1.2" from a version register pair (major << 16 | minor).
std::string version_text(uint32_t v);
/// "voltage, motor drive (0x0011)", or "none".
std::string faults_text(const MachineStatus& s);
/// "12:30 remaining": the run time and what it counts (verbs.hpp, time_counts).
std::string time_text(const MachineStatus& s, Family remembered = Family::none);
/// The status panel: 7 lines of at most 80 columns, each ending in '\n';
/// the state (in the fault screen) and the faults (when any) go through `alert`.
std::string status_panel(const MachineStatus& s, Family remembered = Family::none,
                         const Highlight& alert = nullptr);
/// The status in one line (a `watch` into a pipe: the front-end puts the time first).
std::string status_line(const MachineStatus& s, Family remembered = Family::none);

}  // namespace rtukit::inverjet
