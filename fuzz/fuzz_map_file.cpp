// The register-map file loader (parse_map: YAML, and JSON through the same
// loader) on arbitrary text.
// Properties: never crashes and never throws; a map it loads passes its own
// checks (check_profile), exports (map_to_yaml, map_to_json) to text that
// loads again and exports identically, and serves as a register-only device
// (make_register_device); a map it refuses says why with the line:
// "SOURCE:LINE: what is wrong".
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "rtukit/devices/profile/map_file.hpp"

namespace {

using namespace rtukit;

constexpr std::string_view kSource = "fuzz.yaml";

// "fuzz.yaml:LINE: ..." with LINE a positive number.
bool names_a_line(std::string_view reason) {
  if (reason.substr(0, kSource.size() + 1) != std::string(kSource) + ":") return false;
  reason.remove_prefix(kSource.size() + 1);
  size_t digits = 0;
  while (digits < reason.size() && std::isdigit(static_cast<unsigned char>(reason[digits]))) ++digits;
  if (digits == 0 || digits >= reason.size() || reason[digits] != ':') return false;
  return reason.substr(0, digits) != std::string(digits, '0');
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto loaded = profile::parse_map(text, kSource);
  if (!loaded.ok()) {
    if (loaded.error().code() != Errc::invalid_argument || !names_a_line(loaded.error().reason()))
      std::abort();
    return 0;
  }
  const profile::Profile& p = (*loaded)->profile();
  if (profile::check_profile(p)) std::abort();
  const std::string yaml = profile::map_to_yaml(p);
  const std::string json = profile::map_to_json(p);
  for (const std::string& exported : {yaml, json}) {
    const auto again = profile::parse_map(exported, kSource);
    if (!again.ok()) std::abort();
    if (profile::map_to_yaml((*again)->profile()) != yaml) std::abort();
  }
  if (!profile::make_register_device(p)) std::abort();
  return 0;
}
