#include "rtukit/driver/trace_log.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "rtukit/term/terminal.hpp"

namespace rtukit {

std::string trace_line(const TraceEvent& e, std::string_view time) {
  const std::string bytes = fmt::format("{:02X}", fmt::join(e.bytes, " "));
  if (e.direction == TraceEvent::Direction::sent)
    return fmt::format("{} > {}{}\n", time, bytes, e.outcome.empty() ? "" : fmt::format("  ({})", e.outcome));
  return fmt::format("{} < {}({}, {:.1f} ms)\n", time, e.bytes.empty() ? "nothing " : bytes + "  ", e.outcome,
                     static_cast<double>(e.elapsed.count()) / 1000.0);
}

Outcome<std::function<void(const TraceEvent&)>> trace_writer(bool to_stderr, const std::string& log_path,
                                                             DriverClock& clock) {
  if (!to_stderr && log_path.empty()) return std::function<void(const TraceEvent&)>{};
  std::shared_ptr<std::FILE> log;
  if (!log_path.empty()) {
    log.reset(std::fopen(log_path.c_str(), "a"), [](std::FILE* f) {
      if (f) std::fclose(f);
    });
    if (!log)
      return rtukit::Status(Errc::io_error,
                            fmt::format("cannot open for appending: {}", std::strerror(errno)));
  }
  // The callback may outlive this call (the Master keeps it): the file is shared, the clock outlives both.
  return std::function<void(const TraceEvent&)>([log, to_stderr, &clock](const TraceEvent& e) {
    const term::WallTime w = term::wall_time(false, clock);
    const std::string line =
        trace_line(e, fmt::format("{:02}:{:02}:{:02}.{:03}", w.tm.tm_hour, w.tm.tm_min, w.tm.tm_sec, w.ms));
    if (to_stderr) std::fputs(line.c_str(), stderr);
    if (log) {
      std::fputs(line.c_str(), log.get());
      std::fflush(log.get());
    }
  });
}

}  // namespace rtukit
