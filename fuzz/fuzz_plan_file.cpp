// The Inverjet training-plan file parser (parse_plan: CSV, a JSON array, or
// the document `plan show --json` prints) on arbitrary text.
// Properties: never crashes and never throws; an accepted plan obeys the
// machine's rules (1..50 segments, end times strictly increasing and at most
// 99:59, speeds 0..100 %), passes validate_plan, and plan_to_csv of it parses
// back to the same plan; a refused plan is invalid_argument with a reason.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/plan_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace rtukit::inverjet;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto plan = parse_plan(text);
  if (!plan.ok()) {
    if (plan.error().code() != rtukit::Errc::invalid_argument || plan.error().reason().empty()) std::abort();
    return 0;
  }
  const std::vector<Segment>& segments = *plan;
  if (segments.empty() || segments.size() > kSegmentsPerPlan) std::abort();
  uint16_t previous = 0;
  for (const Segment& s : segments) {
    if (s.speed > kMaxSpeed || s.end > kMaxTime || s.end <= previous) std::abort();
    previous = s.end;
  }
  if (validate_plan(segments)) std::abort();
  const auto again = parse_plan(plan_to_csv(segments));
  if (!again.ok() || *again != segments) std::abort();
  return 0;
}
