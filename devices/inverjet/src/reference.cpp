// The register reference in docs/inverjet.md, from the table (the layout
// predates the profile kit's generic one and is kept for the docs).
#include "rtukit/devices/inverjet/reference.hpp"

#include <fmt/core.h>

#include "rtukit/devices/inverjet/registers.hpp"

namespace rtukit::inverjet {

std::string registers_markdown() {
  std::string out;
  for (const Space table : {Space::holding, Space::input}) {
    out += fmt::format("### {} registers ({})\n\n", table == Space::holding ? "Holding" : "Input",
                       table == Space::holding ? "FC03 read, FC06/FC10 write" : "FC04, read only");
    out += "| address | key | name | access | unit | range | default | persisted | values / notes |\n";
    out += "|---|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : kRows) {
      if (r.space != table) continue;
      std::string address = fmt::format("0x{:04X}", r.address);
      if (r.repeat > 1)
        address = fmt::format("0x{:04X} + {}k (k = 0..{})", r.address, r.step(), r.repeat - 1);
      else if (r.words() > 1)
        address = fmt::format("0x{:04X}..0x{:04X}", r.address, r.last_address());
      std::string range = "-";
      std::string default_text = "-";
      if (r.writable()) {
        range = fmt::format("{}..{}", r.range.min, r.range.max);
        if (const profile::Range w = r.write_range(); w != r.range)
          range += fmt::format(" (writes {}..{})", w.min, w.max);
        default_text = r.repeat > 1 ? fmt::format("{} (segment 1: {})", r.default_value, r.default_first)
                                    : fmt::format("{}", r.default_value);
      } else if (r.words() == 2) {
        range = "u32, high word first";
      }
      std::string notes;
      for (const Named& c : r.names) {
        if (!notes.empty()) notes += ", ";
        notes += r.encoding == Encoding::bits ? fmt::format("bit{} {}", c.value, c.name)
                                              : fmt::format("{} {}", c.value, c.name);
      }
      if (!r.notes.empty()) notes += (notes.empty() ? "" : "; ") + std::string(r.notes);
      if (r.has(kMasked))
        notes += notes.empty() ? "masked by control-mask bit 1" : "; masked by control-mask bit 1";
      std::string unit(r.unit);
      if (r.scale > 1) unit = fmt::format("{} {}", r.scale == 10 ? "0.1" : "0.01", r.unit);
      out += fmt::format("| {} | `{}` | {} | {} | {} | {} | {} | {} | {} |\n", address, r.key, r.title,
                         r.writable() ? "RW" : "R", unit.empty() ? "-" : unit, range, default_text,
                         r.has(profile::kPersisted) ? "yes" : "no", notes.empty() ? "-" : notes);
    }
    out += "\n";
  }
  out += "Every address not listed is reserved: a read or write touching it gets exception 02 (D-8).\n";
  return out;
}

}  // namespace rtukit::inverjet
