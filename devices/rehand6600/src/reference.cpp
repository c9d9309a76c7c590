// The Rehand 6600's tables as people read them: values with the device's
// own formats (error codes as "1010 Master Error", the device ID in hex) and
// the references in docs/rehand6600.md.
#include "rtukit/devices/rehand6600/reference.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <vector>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/chair.hpp"

namespace rtukit::rehand6600 {
namespace {

std::string_view kind_name(Role k) {
  switch (k) {
    case Role::status:
      return "read";
    case Role::control:
      return "control";
    case Role::setting:
      return "setting";
    case Role::hold:
      return "hold";
    case Role::pulse:
      return "pulse";
    case Role::reserved:
      return "reserved";
  }
  return "?";
}

}  // namespace

std::string format_value(const Register& reg, uint16_t raw) {
  if (!reg.names.empty()) {
    const std::string_view name = profile::name_of(reg, raw);
    return name.empty() ? fmt::format("unknown ({})", raw) : fmt::format("{} ({})", name, raw);
  }
  if (reg.address == reg::kErrorCode || reg.address == reg::kHostFault)
    return raw == 0 ? "none" : error_text(raw);
  if (reg.address == reg::kDeviceId) return fmt::format("0x{:02X}", raw);
  if (reg.is_signed()) return fmt::format("{}", static_cast<int16_t>(raw));
  return reg.unit.empty() ? fmt::format("{}", raw) : fmt::format("{} {}", raw, reg.unit);
}

std::string registers_markdown() {
  std::string out;
  for (const Table table : {Table::status, Table::command}) {
    out += table == Table::status
               ? "### Table 1: the host reads (FC03, 0x0000..0x002F; writes get exception 02)\n\n"
               : "### Table 2: the host writes (FC06/FC10, 0x0060..0x007F; reads get exception 02)\n\n";
    out += "| address | key | name | kind | values | default | notes |\n|---|---|---|---|---|---|---|\n";
    for (const Register& r : kRows) {
      if (table_of(r) != table) continue;
      std::string values;
      for (const Named& c : r.names)
        values += fmt::format("{}{} {}", values.empty() ? "" : ", ", c.value, c.name);
      if (values.empty()) {
        if (r.is_signed())
          values = "int16";
        else if (r.range.min != 0 || r.range.max != 0xFFFF)
          values = fmt::format("{}..{}", r.range.min, r.range.max);
        else
          values = "uint16";
        if (!r.unit.empty()) values += " " + std::string(r.unit);
      }
      std::string notes(r.notes);
      if (r.has(kMotion))
        notes += std::string(notes.empty() ? "" : "; ") + "refused (04) during a local fault";
      out += fmt::format("| 0x{:04X} | `{}` | {} | {} | {} | {} | {} |\n", r.address, r.key, r.title,
                         kind_name(r.role), values,
                         table == Table::status ? "-" : std::to_string(r.default_value),
                         notes.empty() ? "-" : notes);
    }
    out += "\n";
  }
  out +=
      "0x0030..0x005F and everything above 0x007F do not exist (exception 02). A value outside a register's "
      "list gets exception 03; a multi-register write is validated whole, then applied all or nothing.\n";
  return out;
}

std::string error_text(uint16_t code) {
  const std::string_view f = error_function(code);
  return fmt::format("{:04X} {} Error", code, f.empty() ? std::string_view("Unknown") : f);
}

namespace {
// After every error (D-8): nothing restarts by itself.
constexpr std::string_view kAfterwards =
    "; when it clears, nothing restarts by itself: press the command again";
}  // namespace

std::string error_advice(uint16_t code) {
  if (code == kMasterCommunicationError)
    return fmt::format(
        "the host gets no valid answer from the controller (communication); check: the controller is powered "
        "on, the UART cable and its connectors, the baud rate (115200 unless changed) and the unit (1); a "
        "device "
        "ID other than 0x68 means another device answers on this port{}",
        kAfterwards);
  if (const ErrorAdvice* a = error_group_advice(error_function(code)))
    return fmt::format("{}; check: {}{}", a->meaning, a->check, kAfterwards);
  return fmt::format(
      "a code table 3 does not list: the controller reports a fault we cannot name; check: the controller's "
      "documentation or the dealer{}",
      kAfterwards);
}

std::span<const uint16_t> error_codes() noexcept {
  static const std::vector<uint16_t> codes = [] {
    std::vector<uint16_t> v;
    for (const ErrorGroup& g : error_groups()) {
      for (uint32_t c = g.first; c <= g.last; ++c) v.push_back(static_cast<uint16_t>(c));
      for (uint16_t e : g.extra) v.push_back(e);
    }
    std::sort(v.begin(), v.end());
    return v;
  }();
  return codes;
}

std::string errors_markdown() {
  std::string out =
      "| codes | function | UI text (example) | what it means | what to check |\n|---|---|---|---|---|\n";
  for (const ErrorGroup& g : error_groups()) {
    std::string codes = fmt::format("{:04X}..{:04X}", g.first, g.last);
    for (uint16_t e : g.extra) codes += fmt::format(", {:04X}", e);
    const ErrorAdvice* a = error_group_advice(g.function);
    out += fmt::format("| {} | {} | {} | {} | {} |\n", codes, g.function, error_text(g.first),
                       a ? a->meaning : "", a ? a->check : "");
  }
  out +=
      "\nEvery active error shows as a full-screen overlay and disables every function; when it clears, "
      "nothing "
      "restarts by itself. 1010 is also raised by the host itself when the controller does not answer "
      "(communication error): check that the controller is powered on, the UART cable and its connectors, "
      "the "
      "baud rate (115200 unless changed) and the unit (1); a device ID other than 0x68 means another device "
      "answers on this port. Table 3 names only the function; the meanings and checks are our reading of it. "
      "`rtukit rehand6600 errors CODE` prints one code's.\n";
  return out;
}

// ---------------------------------------------------------------- D-9

namespace {

// Drives a fresh chair forward from the phone at `level` and `mode` until it
// is at top speed, polled every 50 ms, then stops it one way or the other and
// integrates the distance on the model's 1-ms clock.
StoppingEntry::Stop measure_stop(unsigned level, uint16_t mode, bool release, double* top) {
  constexpr uint32_t kWatchdogMs = 500;
  Chair chair(0, kWatchdogMs);
  uint64_t now = 0;
  const auto request = [&](uint16_t a, uint16_t v) {
    chair.frame_received();
    (void)chair.write(a, std::span<const uint16_t>(&v, 1));
  };
  request(reg::kSpeedLevel, static_cast<uint16_t>(level));
  request(reg::kDriveMode, mode);
  request(reg::kPhoneForward, 1);
  for (int i = 0; i < 400; ++i) {  // 20 s: far longer than any ramp
    chair.advance_to(now += 50);
    chair.frame_received();
  }
  *top = chair.speed_kmh();
  if (release) request(reg::kPhoneForward, 0);  // else: the host's last request was the poll above
  const uint64_t last = now;
  double metres = 0;
  while (chair.speed_kmh() > 0 && now < last + 60000) {
    const double before = chair.speed_kmh();
    chair.advance_to(++now);
    metres += (before + chair.speed_kmh()) / 2 / 3.6 / 1000;  // trapezoid over 1 ms
  }
  return {static_cast<double>(now - last) / 1000.0, metres};
}

}  // namespace

std::vector<StoppingEntry> stopping_table() {
  std::vector<StoppingEntry> out;
  for (unsigned level = 1; level <= 5; ++level) {
    for (uint16_t mode : {uint16_t{2}, uint16_t{1}, uint16_t{3}}) {
      StoppingEntry e{.level = level, .mode = mode};
      const StoppingEntry::Stop released = measure_stop(level, mode, true, &e.top_kmh);
      const StoppingEntry::Stop lost = measure_stop(level, mode, false, &e.top_kmh);
      e.release_s = released.seconds;
      e.release_m = released.metres;
      e.host_lost_s = lost.seconds;
      e.host_lost_m = lost.metres;
      out.push_back(e);
    }
  }
  return out;
}

std::string stopping_markdown() {
  std::string out =
      "| speed level | drive mode | top speed | release: time | release: distance | host lost: time | host "
      "lost: distance |\n|---|---|---|---|---|---|---|\n";
  for (const StoppingEntry& e : stopping_table()) {
    const Register& mode = *find_register(reg::kDriveMode);
    out += fmt::format("| {} | {} | {:.1f} km/h | {:.2f} s | {:.2f} m | {:.2f} s | {:.2f} m |\n", e.level,
                       profile::name_of(mode, e.mode), e.top_kmh, e.release_s, e.release_m, e.host_lost_s,
                       e.host_lost_m);
  }
  return out;
}

}  // namespace rtukit::rehand6600
