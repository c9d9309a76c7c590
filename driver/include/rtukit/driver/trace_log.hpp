// A Master's frame trace as text (`--trace` on stderr, `--log FILE`): one
// line per request sent and per answer (or silence), stamped with the wall
// time, for a person reading along or a file to diff.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/driver/master.hpp"

namespace rtukit {

/// One event as a line, with its '\n': "14:02:07.123 > 15 03 00 21 00 04 C6 E3"
/// for a request ("  (attempt 2)" after it on a retry), "14:02:07.141 < 15 03
/// 08 ...  (ok, 18.2 ms)" for what came back, "< nothing (timeout, 100.0 ms)"
/// when nothing did. `time`: the stamp, as the writer below makes it.
std::string trace_line(const TraceEvent& event, std::string_view time);

/// A MasterOptions::trace writing trace_line()s stamped with `clock`'s wall
/// time ("HH:MM:SS.mmm", local): to stderr when `to_stderr`, and appended to
/// the file `log_path` (flushed each line) unless it is empty. Neither: an
/// empty function (no tracing at all). Errors: io_error when the file cannot
/// be opened for appending ("cannot open for appending: Permission denied").
Outcome<std::function<void(const TraceEvent&)>> trace_writer(bool to_stderr, const std::string& log_path,
                                                             DriverClock& clock);

}  // namespace rtukit
