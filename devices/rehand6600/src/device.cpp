#include "rtukit/devices/rehand6600/device.hpp"

#include <fmt/core.h>

#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/registers.hpp"
#include "rtukit/devices/rehand6600/sim.hpp"
#include "rtukit/devices/rehand6600/verbs.hpp"
#include "rtukit/devices/rehand6600/views.hpp"
#include "rtukit/driver/simulation.hpp"

namespace rtukit::rehand6600 {
namespace {

constexpr profile::SimOption kSimOptions[] = {
    {.name = "watchdog-ms", .help = "communication watchdog (D-5); 0 disables", .default_value = "500"},
};

Outcome<profile::SimDevice> make_sim(const profile::SimSettings& settings) {
  const std::string_view text = profile::setting(settings, kSimOptions, "watchdog-ms");
  const std::optional<long> ms = parse_long(text);
  if (!ms || *ms < 0 || *ms > 600'000)
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("--watchdog-ms {}: milliseconds from 0 (off) to 600000", text));
  return make_sim_device(SimConfig{.watchdog_ms = static_cast<uint32_t>(*ms)});
}

}  // namespace

const profile::DeviceEntry& device_entry() {
  static const profile::DeviceEntry entry{
      .profile = &kProfile,
      .sim_options = kSimOptions,
      .make_sim = make_sim,
      .markdown = [] { return registers_markdown(); },
      .doc = "docs/rehand6600.md",
      .doc_sections = {{"errors", [] { return errors_markdown(); }},
                       {"stopping", [] { return stopping_markdown(); }}},
      .verbs = verb_table(),
      .run_verb = run_verb,
      .label = "Rehand 6600",
      .no_answer = [](const rtukit::Status& e) { return link_failure_text(e.reason(), false); },
      .identify = identify,
      .example_port = "/dev/ttyS3",
      .answer_timeout_ms = 200};
  return entry;
}

}  // namespace rtukit::rehand6600
