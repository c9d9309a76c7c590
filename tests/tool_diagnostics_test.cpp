// The profile kit's diagnostics (profile/diagnostics.hpp): the FC08 counters
// with FC07 and FC0B, the FC0C log, echo timed on the given clock, clear,
// restart and listen-only, FC11 and FC2B/0E decoded, each failure naming its
// step; and the doctor's advice from a line test's measurements. A slave
// behind a MemoryLink on a ManualClock: no process, no port, no sleeping.
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/memory_link.hpp"
#include "rtukit/tool/diagnostics.hpp"
#include "rtukit/tool/protocol_text.hpp"

namespace rtukit::tool {
namespace {

using namespace std::chrono_literals;

// A generic slave at unit 5 behind a MemoryLink on virtual time. `answers`
// requests are answered, then it is silent; `flip_echo` changes the first
// data byte of an FC08 00 request on its way (a line that corrupts it).
struct Rig {
  Rig() : bank(0x0400) {
    (void)engine.add_unit(UnitId{5}, bank);
    auto link = std::make_unique<MemoryLink>(clock, [this](std::span<const uint8_t> request) {
      if (answers == 0) return MemoryLink::Reply{};
      --answers;
      std::vector<uint8_t> in(request.begin(), request.end());
      if (flip_echo && in.size() > 6 && in[1] == 0x08 && in[2] == 0 && in[3] == 0) {
        in[4] ^= 0xFF;
        const uint16_t crc = crc16(std::span<const uint8_t>(in).first(in.size() - 2));
        in[in.size() - 2] = static_cast<uint8_t>(crc & 0xFF);
        in[in.size() - 1] = static_cast<uint8_t>(crc >> 8);
      }
      std::array<uint8_t, kMaxRtuAduSize> out{};
      const size_t n = engine.handle_rtu(in, out).length;
      return MemoryLink::Reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 2ms};
    });
    master = std::make_unique<Master>(
        std::move(link), MasterOptions{.response_timeout = 100ms, .retries = 0, .clock = &clock});
  }
  ManualClock clock;
  MemoryBank bank;
  SlaveEngine engine;
  unsigned answers = 1000;
  bool flip_echo = false;
  std::unique_ptr<Master> master;
};

constexpr UnitId kUnit{5};

size_t counter_index(std::string_view key) {
  const auto all = diag_counters();
  for (size_t i = 0; i < all.size(); ++i)
    if (all[i].key == key) return i;
  return all.size();
}

// ------------------------------------------------------------- counters

TEST(ToolDiagnostics, CounterTableIsTheSpecificationsOrder) {
  const auto all = diag_counters();
  ASSERT_EQ(all.size(), 9U);
  EXPECT_EQ(all[0].sub, Diagnostic::bus_message_count);
  EXPECT_STREQ(all[1].key, "bus_crc_errors");
  EXPECT_STREQ(all[1].text, "bus CRC errors");
  EXPECT_EQ(all[8].sub, Diagnostic::return_diagnostic_register);
}

TEST(ToolDiagnostics, ReadsEveryCounterTheStatusAndTheEventCount) {
  Rig rig;
  ASSERT_TRUE(clear_counters(*rig.master, kUnit).ok());
  std::array<uint16_t, 1> out{};
  // One read past the slave's registers: exception 02.
  ASSERT_TRUE(rig.master->read_holding_registers(kUnit, 0x2000, out).is_exception());
  DiagCounters c;
  const Status s = read_counters(*rig.master, kUnit, c);
  ASSERT_TRUE(s.ok()) << s.reason();
  ASSERT_EQ(c.values.size(), diag_counters().size());
  EXPECT_EQ(c.values[counter_index("bus_exceptions")], 1U);
  EXPECT_EQ(c.values[counter_index("bus_crc_errors")], 0U);
  EXPECT_GE(c.values[counter_index("bus_messages")], 2U);
  EXPECT_EQ(c.exception_status, 0U);
  // FC0B counts completed requests, not the exception.
  EXPECT_GT(c.event_count, 0U);
}

TEST(ToolDiagnostics, AFailedCounterNamesItsStepAndKeepsWhatCameBefore) {
  Rig rig;
  rig.answers = 2;
  DiagCounters c;
  const Status s = read_counters(*rig.master, kUnit, c);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), Errc::timeout);
  EXPECT_EQ(c.values.size(), 2U);
  EXPECT_EQ(s.reason(),
            "FC08 diagnostics sub-function 0x0D (exceptions sent) to unit 5 on " + rig.master->describe());
}

TEST(ToolDiagnostics, AFailedEventCounterNamesFc0B) {
  Rig rig;
  rig.answers = static_cast<unsigned>(diag_counters().size()) + 1;  // the counters and FC07
  DiagCounters c;
  const Status s = read_counters(*rig.master, kUnit, c);
  EXPECT_EQ(s.code(), Errc::timeout);
  EXPECT_EQ(s.reason(), "FC0B get comm event counter from unit 5 on " + rig.master->describe());
}

// ------------------------------------------------------------- event log

TEST(ToolDiagnostics, ReadsTheEventLogNewestFirst) {
  Rig rig;
  std::array<uint16_t, 1> out{};
  ASSERT_TRUE(rig.master->read_holding_registers(kUnit, 0x2000, out).is_exception());
  const auto log = read_event_log(*rig.master, kUnit);
  ASSERT_TRUE(log.ok()) << log.error().reason();
  ASSERT_GE(log->events.size(), 2U);
  // The newest is this FC0C request received, then the exception sent before it.
  EXPECT_EQ(comm_event_text(log->events[0]), "received");
  EXPECT_NE(comm_event_text(log->events[1]).find("sent, read exception"), std::string::npos)
      << comm_event_text(log->events[1]);
  EXPECT_EQ(log->status, 0U);
}

TEST(ToolDiagnostics, AFailedEventLogNamesFc0C) {
  Rig rig;
  rig.answers = 0;
  const auto log = read_event_log(*rig.master, kUnit);
  ASSERT_FALSE(log.ok());
  EXPECT_EQ(log.error().code(), Errc::timeout);
  EXPECT_EQ(log.error().reason(), "FC0C get comm event log from unit 5 on " + rig.master->describe());
}

// ------------------------------------------------------------- echo

TEST(ToolDiagnostics, EchoReturnsTheDataTimedOnTheGivenClock) {
  Rig rig;
  const auto e = echo(*rig.master, kUnit, {0x12, 0x34}, rig.clock);
  ASSERT_TRUE(e.ok()) << e.error().reason();
  EXPECT_EQ(e->sent, (std::vector<uint8_t>{0x12, 0x34}));
  EXPECT_TRUE(e->same());
  // The link answers 2 ms after the request, on virtual time.
  EXPECT_GE(e->ms, 2.0);
  EXPECT_LT(e->ms, 100.0);
}

TEST(ToolDiagnostics, EchoWithoutDataSendsA537) {
  Rig rig;
  const auto e = echo(*rig.master, kUnit, {}, rig.clock);
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->sent, (std::vector<uint8_t>{0xA5, 0x37}));
  EXPECT_EQ(e->answer, e->sent);
}

TEST(ToolDiagnostics, AnEchoThatDiffersIsNotAnError) {
  Rig rig;
  rig.flip_echo = true;
  const auto e = echo(*rig.master, kUnit, {0x12, 0x34}, rig.clock);
  ASSERT_TRUE(e.ok()) << e.error().reason();
  EXPECT_FALSE(e->same());
  EXPECT_EQ(e->answer, (std::vector<uint8_t>{0xED, 0x34}));
}

TEST(ToolDiagnostics, AFailedEchoNamesItsStep) {
  Rig rig;
  rig.answers = 0;
  const auto e = echo(*rig.master, kUnit, {1}, rig.clock);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().reason(), "FC08 return query data to unit 5 on " + rig.master->describe());
}

// ------------------------------------------------------------- listen-only, restart, clear

TEST(ToolDiagnostics, ListenOnlyThenRestartWithoutAnAnswer) {
  Rig rig;
  ASSERT_TRUE(force_listen_only(*rig.master, kUnit).ok());
  EXPECT_TRUE(rig.engine.listen_only());
  const auto silent = restart_communications(*rig.master, kUnit, false);
  ASSERT_TRUE(silent.ok()) << silent.error().reason();
  EXPECT_FALSE(*silent);  // it restarted without answering
  EXPECT_FALSE(rig.engine.listen_only());
  const auto answered = restart_communications(*rig.master, kUnit, true);
  ASSERT_TRUE(answered.ok());
  EXPECT_TRUE(*answered);
}

TEST(ToolDiagnostics, ClearAndListenOnlyFailuresNameTheirStep) {
  Rig rig;
  rig.answers = 0;
  const Status clear = clear_counters(*rig.master, kUnit);
  EXPECT_EQ(clear.code(), Errc::timeout);
  EXPECT_EQ(clear.reason(), "FC08 clear counters to unit 5 on " + rig.master->describe());
  // Listen-only is never answered, so silence is no failure.
  EXPECT_TRUE(force_listen_only(*rig.master, kUnit).ok());
}

TEST(ToolDiagnostics, RestartToASilentUnitIsNotAnError) {
  Rig rig;
  const auto r = restart_communications(*rig.master, UnitId{6}, false);  // no unit 6: no answer
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(*r);
}

// ------------------------------------------------------------- identification

TEST(ToolDiagnostics, ReportServerIdDecodesTheHeadAndText) {
  Rig rig;
  const auto id = report_server_id(*rig.master, kUnit);
  ASSERT_TRUE(id.ok()) << id.error().reason();
  EXPECT_TRUE(id->has_head);
  EXPECT_EQ(id->id, 5U);
  EXPECT_TRUE(id->running);
  EXPECT_TRUE(id->printable);
  EXPECT_EQ(id->text, "rtukit rtukit-slave 1.0");
  EXPECT_EQ(id->data.size(), id->text.size() + 2);
}

TEST(ToolDiagnostics, ReportServerIdKeepsBytesThatAreNotText) {
  Rig rig;
  rig.bank.objects[0] = std::string("\x01\x02", 2);
  const auto id = report_server_id(*rig.master, kUnit);
  ASSERT_TRUE(id.ok());
  EXPECT_FALSE(id->printable);
}

TEST(ToolDiagnostics, LevelNamesAnAccess) {
  EXPECT_EQ(*device_id_access("basic", false), DeviceIdAccess::basic);
  EXPECT_EQ(*device_id_access("regular", false), DeviceIdAccess::regular);
  EXPECT_EQ(*device_id_access("extended", false), DeviceIdAccess::extended);
  EXPECT_EQ(*device_id_access("basic", true), DeviceIdAccess::individual);
  const auto bad = device_id_access("full", false);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code(), Errc::invalid_argument);
  EXPECT_EQ(bad.error().reason(), "--level full: use basic, regular or extended");
}

TEST(ToolDiagnostics, ReadsIdentificationObjectsByName) {
  Rig rig;
  rig.bank.objects[0x80] = "test bench";
  const auto id = read_identification(*rig.master, kUnit, DeviceIdAccess::extended);
  ASSERT_TRUE(id.ok()) << id.error().reason();
  EXPECT_STREQ(id->level, "extended");
  EXPECT_TRUE(id->individual);
  using Object = std::pair<std::string, std::string>;
  EXPECT_EQ(id->objects, (std::vector<Object>{{"vendor", "rtukit"},
                                              {"product code", "rtukit-slave"},
                                              {"revision", "1.0"},
                                              {"0x80", "test bench"}}));
}

TEST(ToolDiagnostics, AMissingObjectIsTheDevicesException) {
  Rig rig;
  const auto id = read_identification(*rig.master, kUnit, DeviceIdAccess::individual, 7);
  ASSERT_FALSE(id.ok());
  EXPECT_TRUE(id.error().is_exception());
  EXPECT_EQ(id.error().reason(),
            "FC2B/0E read device identification from unit 5 on " + rig.master->describe());
}

// ------------------------------------------------------------- the doctor's advice

LineTestResult measured() {
  LineTestResult r;
  r.answered = 10;
  r.timeout_ms = 60;
  r.added_us = 500;
  r.error_free_gap_ms = 0;
  return r;
}

TEST(ToolDiagnostics, AdviceForAGoodLineIsBaudAndTimeout) {
  const LineAdvice a = line_advice(measured(), 9600, false);
  EXPECT_EQ(a.options, "--baud 9600 --timeout 60");
  EXPECT_FALSE(a.high_latency);
}

TEST(ToolDiagnostics, AdviceAddsEchoDelayAndRs485) {
  LineTestResult r = measured();
  r.echo = true;
  r.error_free_gap_ms = 5;
  r.added_us = 2500;
  const LineAdvice a = line_advice(r, 19200, true);
  EXPECT_EQ(a.options, "--baud 19200 --timeout 60 --echo --delay 5 --rs485");
  EXPECT_TRUE(a.high_latency);
}

TEST(ToolDiagnostics, AdviceForALineWithErrorsAtEveryGapIsRetries) {
  LineTestResult r = measured();
  r.error_free_gap_ms.reset();
  r.added_us = 2000;  // not more than 2 ms: not called out
  const LineAdvice a = line_advice(r, 9600, false);
  EXPECT_EQ(a.options, "--baud 9600 --timeout 60 --retries 2");
  EXPECT_FALSE(a.high_latency);
}

}  // namespace
}  // namespace rtukit::tool
