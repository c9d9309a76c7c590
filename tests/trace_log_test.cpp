// The frame trace of --trace and --log (driver/trace_log.hpp): its lines,
// and the writer stamping them with its clock's wall time.
#include "rtukit/driver/trace_log.hpp"

#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace rtukit {
namespace {

using namespace std::chrono_literals;

TEST(TraceLog, ALineSaysTheDirectionTheBytesAndWhatCameOfIt) {
  const std::array<uint8_t, 3> request{0x15, 0x03, 0x0A};
  TraceEvent e{TraceEvent::Direction::sent, request, "", 0us};
  EXPECT_EQ(trace_line(e, "14:02:07.123"), "14:02:07.123 > 15 03 0A\n");
  e.outcome = "attempt 2";
  EXPECT_EQ(trace_line(e, "t"), "t > 15 03 0A  (attempt 2)\n");
  e = {TraceEvent::Direction::received, request, "ok", 18'250us};
  EXPECT_EQ(trace_line(e, "t"), "t < 15 03 0A  (ok, 18.2 ms)\n");
  e = {TraceEvent::Direction::received, {}, "timeout", 100ms};
  EXPECT_EQ(trace_line(e, "t"), "t < nothing (timeout, 100.0 ms)\n");
}

TEST(TraceLog, TheWriterAppendsStampedLines_NothingAskedIsNoWriter) {
  ManualClock clock;
  Outcome<std::function<void(const TraceEvent&)>> none = trace_writer(false, "", clock);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(static_cast<bool>(*none));
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "rtukit-trace-log-test";
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "frames.log";
  { std::ofstream(file) << "kept\n"; }
  Outcome<std::function<void(const TraceEvent&)>> w = trace_writer(false, file.string(), clock);
  ASSERT_TRUE(w.ok()) << w.error().reason();
  const std::array<uint8_t, 2> bytes{0x01, 0x02};
  clock.sleep_until(clock.now() + 1'500ms);
  (*w)({TraceEvent::Direction::sent, bytes, "", 0us});
  std::stringstream text;
  text << std::ifstream(file).rdbuf();
  // Appended after what was there, stamped with the clock's time (local).
  EXPECT_TRUE(text.str().starts_with("kept\n")) << text.str();
  EXPECT_TRUE(text.str().ends_with(".500 > 01 02\n")) << text.str();
  Outcome<std::function<void(const TraceEvent&)>> bad =
      trace_writer(false, (dir / "no/such/dir/x").string(), clock);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code(), Errc::io_error);
  EXPECT_NE(bad.error().reason().find("cannot open for appending: No such file"), std::string_view::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rtukit
