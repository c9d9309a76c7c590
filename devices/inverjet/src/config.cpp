// The Inverjet's settings by key: what `rtukit inverjet config KEY VALUE` writes.
#include <fmt/core.h>

#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/profile/text.hpp"

namespace rtukit::inverjet {

Outcome<ConfigChange> parse_config(std::string_view key, std::string_view text, const ReadNumber& read) {
  const auto change = [key](reg::Handle h, int64_t raw, int64_t value) -> Outcome<ConfigChange> {
    return ConfigChange{key, &kMap.row(h), raw, static_cast<uint32_t>(value)};
  };
  if (key == "address") {
    const profile::UnitRange units = profile::unit_range(kProfile);
    const Outcome<int64_t> n = read(text, fmt::format("{} unit", kProfile.name), units.min, units.max);
    if (!n.ok()) return n.error();
    return change(reg::address, *n, *n);
  }
  if (key == "baud") {
    const Outcome<int64_t> n = read(text, "baud", 0, 1000000);
    if (!n.ok()) return n.error();
    const int code = code_of_baud(static_cast<uint32_t>(*n));
    if (code < 0)
      return rtukit::Status(Errc::invalid_argument,
                            fmt::format("baud {}: the Inverjet runs at 1200, 2400, 4800, 9600 or 19200", *n));
    return change(reg::baud, code, *n);
  }
  if (key == "mask") {
    const profile::Range bits = kMap.row(reg::control_mask).write_range();
    const Outcome<int64_t> n = read(text, "control mask", bits.min, bits.max);
    if (!n.ok()) return n.error();
    return change(reg::control_mask, *n, *n);
  }
  if (key == "pairing") {
    // The row's value names, as `set pairing` takes them.
    const Outcome<int64_t> n = profile::parse_value(kMap.row(reg::pairing), text);
    if (!n.ok()) return n.error();
    return change(reg::pairing, *n, *n);
  }
  return rtukit::Status(Errc::invalid_argument,
                        fmt::format("config {}: expected show, address, baud, mask or pairing", key));
}

rtukit::Status write_config(Client& client, const ConfigChange& c) {
  if (c.row == &kMap.row(reg::address)) return client.set_address(static_cast<uint8_t>(c.value));
  if (c.row == &kMap.row(reg::baud)) return client.set_baud(c.value);
  if (c.row == &kMap.row(reg::control_mask)) return client.set_control_mask(static_cast<uint16_t>(c.value));
  if (c.row == &kMap.row(reg::pairing)) return client.set_pairing(static_cast<uint16_t>(c.value));
  return rtukit::Status(Errc::invalid_argument, "not a setting");
}

}  // namespace rtukit::inverjet
