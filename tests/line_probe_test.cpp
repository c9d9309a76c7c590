// The doctor's measurements (driver/line_probe.hpp) on virtual time: a
// MemoryLink answers through a real slave engine after a set delay, so the
// numbers are exact and nothing sleeps.
#include "rtukit/driver/line_probe.hpp"

#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "rtukit/core/slave.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/memory_link.hpp"

namespace rtukit {
namespace {

using namespace std::chrono_literals;

TEST(Percentile, NearestRankRounded) {
  EXPECT_EQ(percentile({}, 50), 0);
  EXPECT_EQ(percentile({5, 1, 4, 2, 3}, 0), 1);
  EXPECT_EQ(percentile({5, 1, 4, 2, 3}, 50), 3);
  EXPECT_EQ(percentile({5, 1, 4, 2, 3}, 99), 5);
  EXPECT_EQ(percentile({5, 1, 4, 2, 3}, 100), 5);
  EXPECT_EQ(percentile({1, 2, 3, 4}, 50), 3);  // rank 1.5 rounds up
  EXPECT_EQ(percentile({10, 20}, 25), 10);
  EXPECT_EQ(percentile({7}, 99), 7);
}

// A slave behind MemoryLinks: it answers after `delay`, echoing the request first when `echo`.
struct Line {
  Line() { (void)engine.add_unit(UnitId{1}, bank); }
  std::unique_ptr<io::Link> link() {
    return std::make_unique<MemoryLink>(clock, [this](std::span<const uint8_t> request) {
      if (silent) return MemoryLink::Reply{};
      std::array<uint8_t, kMaxRtuAduSize> out{};
      const size_t n = engine.handle_rtu(request, out).length;
      MemoryLink::Reply r{{}, delay};
      if (echo) r.bytes.assign(request.begin(), request.end());
      r.bytes.insert(r.bytes.end(), out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n));
      return r;
    });
  }
  ManualClock clock;
  MemoryBank bank{100};
  SlaveEngine engine;
  std::chrono::microseconds delay{15ms};
  bool echo = false, silent = false;
};

const std::vector<uint8_t> kRequest{0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};  // unit 1, FC03 0 x1

TEST(LineProbe, AnAnswerAndItsTimes) {
  Line line;
  std::unique_ptr<io::Link> link = line.link();
  ASSERT_TRUE(link->open().ok());
  const LineProbe p = probe_line(*link, kRequest, 7, 200ms, line.clock);
  EXPECT_TRUE(p.answered);
  EXPECT_FALSE(p.echo);
  EXPECT_EQ(p.first_us, 15000);
  EXPECT_EQ(p.last_us, 15000);
  EXPECT_EQ(p.reads, 1U);
}

TEST(LineProbe, TheRequestComingBackFirstIsAnEcho) {
  Line line;
  line.echo = true;
  std::unique_ptr<io::Link> link = line.link();
  ASSERT_TRUE(link->open().ok());
  const LineProbe p = probe_line(*link, kRequest, 7, 200ms, line.clock);
  EXPECT_TRUE(p.echo);
  EXPECT_TRUE(p.answered);
}

TEST(LineProbe, SilenceIsNoAnswer_AfterTheTimeout) {
  Line line;
  line.silent = true;
  std::unique_ptr<io::Link> link = line.link();
  ASSERT_TRUE(link->open().ok());
  const auto t0 = line.clock.now();
  const LineProbe p = probe_line(*link, kRequest, 7, 200ms, line.clock);
  EXPECT_FALSE(p.answered);
  EXPECT_EQ(p.reads, 0U);
  EXPECT_EQ(line.clock.now() - t0, 200ms);
}

LineTestOptions options(Line& line) {
  LineTestOptions o;
  o.unit = UnitId{1};
  o.rounds = 5;
  o.baud = 9600;
  o.bits_per_char = 10;
  o.probe_timeout = 200ms;
  o.clock = &line.clock;
  return o;
}

TEST(LineTest, AGoodLine_NoEcho_NoGapNeeded) {
  Line line;
  std::vector<LineTestProgress> steps;
  const Result<LineTestResult> r = test_line([&line] { return line.link(); }, options(line),
                                             [&](const LineTestProgress& p) { steps.push_back(p); });
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->answered, 5U);
  EXPECT_FALSE(r->echo);
  ASSERT_TRUE(r->error_free_gap_ms.has_value());
  EXPECT_EQ(*r->error_free_gap_ms, 0U);
  // 15 ms to the first byte, less 8 request characters and that byte at 9600 baud, 10 bits each.
  const double char_us = 1e6 * 10 / 9600;
  EXPECT_DOUBLE_EQ(r->char_us, char_us);
  EXPECT_NEAR(r->turnaround_p50_us, 15000 - 9 * char_us, 1e-6);
  EXPECT_NEAR(r->turnaround_p99_us, 15000 - 9 * char_us, 1e-6);
  EXPECT_EQ(r->added_us, 0);  // the answer came before its wire time: nothing added
  // Twice (15 ms + 15 characters on the wire), plus 20 ms.
  EXPECT_EQ(r->timeout_ms, static_cast<unsigned>(2 * (15 + 15 * char_us / 1000) + 20));
  ASSERT_EQ(steps.size(), 10U);  // 5 probes, then 5 requests at a gap of 0 ms
  EXPECT_EQ(steps[4].step, 1U);
  EXPECT_EQ(steps[4].index, 5U);
  EXPECT_EQ(steps[4].count, 4U);  // answered before the fifth probe
  EXPECT_EQ(steps[9].step, 2U);
  EXPECT_EQ(steps[9].gap_ms, 0U);
  EXPECT_EQ(steps[9].count, 0U);
}

TEST(LineTest, AnEchoingAdapterIsFound_AndTheMasterSkipsTheEcho) {
  Line line;
  line.echo = true;
  const Result<LineTestResult> r = test_line([&line] { return line.link(); }, options(line));
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->echo);
  EXPECT_EQ(r->echoes, 5U);
  EXPECT_EQ(r->answered, 5U);
  ASSERT_TRUE(r->error_free_gap_ms.has_value());
  EXPECT_EQ(*r->error_free_gap_ms, 0U);
}

TEST(LineTest, ASilentUnit_NothingAnswered_NoSecondStep) {
  Line line;
  line.silent = true;
  unsigned calls = 0;
  const Result<LineTestResult> r = test_line([&line] { return line.link(); }, options(line),
                                             [&](const LineTestProgress& p) {
                                               ++calls;
                                               EXPECT_EQ(p.step, 1U);
                                             });
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->answered, 0U);
  EXPECT_EQ(calls, 5U);
}

}  // namespace
}  // namespace rtukit
