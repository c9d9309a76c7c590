#include "rtukit/tool/diagnostics.hpp"

#include <fmt/format.h>

#include <chrono>

#include "rtukit/tool/protocol_text.hpp"

namespace rtukit::tool {
namespace {

constexpr DiagCounter kCounters[] = {
    {Diagnostic::bus_message_count, "bus_messages", "bus messages"},
    {Diagnostic::bus_communication_error_count, "bus_crc_errors", "bus CRC errors"},
    {Diagnostic::bus_exception_error_count, "bus_exceptions", "exceptions sent"},
    {Diagnostic::server_message_count, "server_messages", "messages to this unit"},
    {Diagnostic::server_no_response_count, "server_no_response", "left unanswered"},
    {Diagnostic::server_nak_count, "server_nak", "NAK sent"},
    {Diagnostic::server_busy_count, "server_busy", "busy (06) sent"},
    {Diagnostic::bus_character_overrun_count, "bus_overruns", "character overruns"},
    {Diagnostic::return_diagnostic_register, "diagnostic_register", "diagnostic register"},
};

// The Master's Error kept whole (the front-end picks its exit code and its
// advice from the code, an exception's number or the OS error), with the
// step in words as the reason.
Status failed(Error e, std::string context) {
  return {e, std::move(context)};
}

// FC08 whose answer is only an acknowledgement (the request echoed).
Status diagnostic(Master& master, UnitId unit, Diagnostic sub, std::span<const uint8_t> data,
                  std::string_view what) {
  std::vector<uint8_t> answer;
  if (Error e = master.diagnostics(unit, sub, data, answer))
    return failed(e, fmt::format("FC08 {} to {}", what, unit_where(unit, master)));
  return {};
}

}  // namespace

std::string unit_where(UnitId unit, const Master& master) {
  return fmt::format("unit {} on {}", unit.value, master.describe());
}

std::span<const DiagCounter> diag_counters() noexcept {
  return kCounters;
}

Status read_counters(Master& master, UnitId unit, DiagCounters& out) {
  out = {};
  for (const DiagCounter& c : kCounters) {
    uint16_t v = 0;
    if (Error e = master.diagnostic_value(unit, c.sub, v))
      return failed(e, fmt::format("FC08 diagnostics sub-function 0x{:02X} ({}) to {}",
                                   static_cast<unsigned>(c.sub), c.text, unit_where(unit, master)));
    // Kept as read: a front-end that prints as it goes shows what came before a failure.
    out.values.push_back(v);
  }
  if (Error e = master.read_exception_status(unit, out.exception_status))
    return failed(e, "FC07 read exception status from " + unit_where(unit, master));
  Master::CommEvents events;
  if (Error e = master.comm_events(unit, false, events))
    return failed(e, "FC0B get comm event counter from " + unit_where(unit, master));
  out.event_count = events.event_count;
  return {};
}

Outcome<Master::CommEvents> read_event_log(Master& master, UnitId unit) {
  Master::CommEvents log;
  if (Error e = master.comm_events(unit, true, log))
    return failed(e, "FC0C get comm event log from " + unit_where(unit, master));
  return log;
}

Outcome<Echo> echo(Master& master, UnitId unit, std::vector<uint8_t> data, DriverClock& clock) {
  Echo out;
  out.sent = data.empty() ? std::vector<uint8_t>{0xA5, 0x37} : std::move(data);
  // The caller's clock, not the steady clock: a test times the echo on
  // virtual time, and the library reads the time only through a DriverClock.
  const auto t0 = clock.now();
  if (Error e = master.diagnostics(unit, Diagnostic::return_query_data, out.sent, out.answer))
    return failed(e, "FC08 return query data to " + unit_where(unit, master));
  out.ms = std::chrono::duration<double, std::milli>(clock.now() - t0).count();
  return out;
}

Status clear_counters(Master& master, UnitId unit) {
  const uint8_t zero[2] = {0, 0};
  return diagnostic(master, unit, Diagnostic::clear_counters, zero, "clear counters");
}

Outcome<bool> restart_communications(Master& master, UnitId unit, bool clear_log) {
  const uint8_t data[2] = {static_cast<uint8_t>(clear_log ? 0xFF : 0x00), 0x00};
  std::vector<uint8_t> answer;
  // A unit in listen-only mode restarts without answering: its silence is
  // the expected outcome, not a failure.
  const Error e = master.diagnostics(unit, Diagnostic::restart_communications, data, answer);
  if (e && e.code() != Errc::timeout)
    return failed(e, "FC08 restart communications to " + unit_where(unit, master));
  return !e;
}

Status force_listen_only(Master& master, UnitId unit) {
  const uint8_t zero[2] = {0, 0};
  return diagnostic(master, unit, Diagnostic::force_listen_only, zero, "force listen only mode");
}

Outcome<ServerId> report_server_id(Master& master, UnitId unit) {
  ServerId out;
  if (Error e = master.report_server_id(unit, out.data))
    return failed(e, "FC11 report server id to " + unit_where(unit, master));
  // Server id, run indicator, then device-specific bytes (text when printable).
  out.has_head = out.data.size() >= 2;
  if (out.has_head) {
    out.id = out.data[0];
    out.running = out.data[1] == 0xFF;
  }
  for (size_t i = out.has_head ? 2 : 0; i < out.data.size(); ++i) {
    out.printable = out.printable && out.data[i] >= 0x20 && out.data[i] < 0x7F;
    out.text += static_cast<char>(out.data[i]);
  }
  return out;
}

Outcome<DeviceIdAccess> device_id_access(std::string_view level, bool individual) {
  if (individual) return DeviceIdAccess::individual;
  if (level == "basic") return DeviceIdAccess::basic;
  if (level == "regular") return DeviceIdAccess::regular;
  if (level == "extended") return DeviceIdAccess::extended;
  return Status{Errc::invalid_argument, fmt::format("--level {}: use basic, regular or extended", level)};
}

Outcome<Identification> read_identification(Master& master, UnitId unit, DeviceIdAccess access,
                                            uint8_t object) {
  Master::DeviceIdentification id;
  if (Error e = master.read_device_identification(unit, access, id, object))
    return failed(e, "FC2B/0E read device identification from " + unit_where(unit, master));
  Identification out;
  out.level = conformity_level_name(id.conformity);
  out.individual = (id.conformity & 0x80) != 0;
  for (const auto& [oid, text] : id.objects) {
    const char* name = device_object_name(oid);
    out.objects.emplace_back(name ? std::string(name) : fmt::format("0x{:02X}", oid), text);
  }
  return out;
}

LineAdvice line_advice(const LineTestResult& r, uint32_t baud, bool kernel_rs485) {
  LineAdvice out;
  out.high_latency = r.added_us > 2000;
  out.options = fmt::format("--baud {} --timeout {}", baud, r.timeout_ms);
  if (r.echo) out.options += " --echo";
  // A gap only when one helped; none at all: the line has errors, so retry.
  if (r.error_free_gap_ms && *r.error_free_gap_ms > 0)
    out.options += fmt::format(" --delay {}", *r.error_free_gap_ms);
  if (!r.error_free_gap_ms) out.options += " --retries 2";
  if (kernel_rs485) out.options += " --rs485";
  return out;
}

}  // namespace rtukit::tool
