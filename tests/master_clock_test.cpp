// The master on virtual time: a MemoryLink answers through a real slave
// engine, a ManualClock stands in for the steady clock, so timeouts,
// retries, the inter-request delay and the broadcast turnaround are checked
// to the microsecond without sleeping. (driver_test.cpp keeps one
// real-transport test of each.)
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/memory_link.hpp"

namespace rtukit {
namespace {

using namespace std::chrono_literals;

// A slave behind a MemoryLink; `drop` requests are left unanswered first.
struct Rig {
  explicit Rig(MasterOptions o = {}, unsigned drop = 0) : to_drop(drop) {
    (void)engine.add_unit(UnitId{1}, bank);
    o.clock = &clock;
    auto link = std::make_unique<MemoryLink>(clock, [this](std::span<const uint8_t> request) {
      arrivals.push_back(clock.now());
      if (to_drop > 0) {
        --to_drop;
        return MemoryLink::Reply{};
      }
      std::array<uint8_t, kMaxRtuAduSize> out{};
      const size_t n = engine.handle_rtu(request, out).length;
      return MemoryLink::Reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 2ms};
    });
    memory = link.get();
    master = std::make_unique<Master>(std::move(link), o);
  }
  ManualClock clock;
  MemoryBank bank{100};
  SlaveEngine engine;
  unsigned to_drop;
  std::vector<Clock::time_point> arrivals;
  MemoryLink* memory = nullptr;
  std::unique_ptr<Master> master;
};

TEST(MasterOnVirtualTime, RetriesAfterTimeouts_ThenSucceeds) {
  Rig rig({.response_timeout = 1000ms, .retries = 2}, /*drop=*/2);
  rig.bank.holding[3] = 42;
  const auto t0 = rig.clock.now();
  uint16_t r = 0;
  ASSERT_TRUE(rig.master->read_holding_registers(UnitId{1}, 3, {&r, 1}).ok());
  EXPECT_EQ(r, 42);
  const MasterStats s = rig.master->stats();
  EXPECT_EQ(s.requests, 3U);
  EXPECT_EQ(s.timeouts, 2U);
  EXPECT_EQ(s.retries, 2U);
  // Two full timeouts passed on the clock, each followed by 20 ms of quiet
  // line (where a late answer would be dropped), then the answer after 2 ms.
  ASSERT_EQ(rig.arrivals.size(), 3U);
  EXPECT_EQ(rig.arrivals[1] - rig.arrivals[0], 1020ms);
  EXPECT_EQ(rig.arrivals[2] - rig.arrivals[1], 1020ms);
  EXPECT_EQ(rig.clock.now() - t0, 2042ms);
}

// A device that answers after the master gave up: its answer must never be
// taken for the next request's, which has the same shape (one register) and
// would otherwise report register 3's value as register 4's.
TEST(MasterOnVirtualTime, ALateAnswerIsNeverTakenForTheNextRequest) {
  ManualClock clock;
  MemoryBank bank{100};
  bank.holding[3] = 33;
  bank.holding[4] = 44;
  SlaveEngine engine;
  (void)engine.add_unit(UnitId{1}, bank);
  unsigned calls = 0;
  auto link = std::make_unique<MemoryLink>(clock, [&](std::span<const uint8_t> request) {
    std::array<uint8_t, kMaxRtuAduSize> out{};
    const size_t n = engine.handle_rtu(request, out).length;
    // The first answer comes 10 ms after the master's 100-ms timeout.
    return MemoryLink::Reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)},
                             calls++ ? 2ms : 110ms};
  });
  Master master(std::move(link), {.response_timeout = 100ms, .clock = &clock});
  uint16_t r = 0;
  EXPECT_EQ(master.read_holding_registers(UnitId{1}, 3, {&r, 1}).code(), Errc::timeout);
  ASSERT_TRUE(master.read_holding_registers(UnitId{1}, 4, {&r, 1}).ok());
  EXPECT_EQ(r, 44);
  EXPECT_EQ(calls, 2U);
}

TEST(MasterOnVirtualTime, SilentUnit_TimesOutAfterEveryRetry) {
  Rig rig({.response_timeout = 300ms, .retries = 1}, /*drop=*/10);
  uint16_t r = 0;
  EXPECT_EQ(rig.master->read_holding_registers(UnitId{1}, 0, {&r, 1}).code(), Errc::timeout);
  EXPECT_EQ(rig.master->stats().timeouts, 2U);
  EXPECT_EQ(rig.arrivals.size(), 2U);
}

TEST(MasterOnVirtualTime, InterRequestDelay_SeparatesRequests) {
  Rig rig({.inter_request_delay = 500ms});
  uint16_t r = 0;
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(rig.master->read_holding_registers(UnitId{1}, 0, {&r, 1}).ok());
  ASSERT_EQ(rig.arrivals.size(), 3U);
  // Each request leaves 500 ms after the previous answer (which came 2 ms after its request).
  EXPECT_EQ(rig.arrivals[1] - rig.arrivals[0], 502ms);
  EXPECT_EQ(rig.arrivals[2] - rig.arrivals[1], 502ms);
}

TEST(MasterOnVirtualTime, BroadcastWaitsTheTurnaroundAndExpectsNoAnswer) {
  Rig rig({.turnaround_delay = 100ms});
  ASSERT_TRUE(rig.master->write_single_register(kBroadcast, 4, 77).ok());
  EXPECT_EQ(rig.bank.holding[4], 77);  // executed by the slave, which stayed silent
  uint16_t r = 0;
  ASSERT_TRUE(rig.master->read_holding_registers(UnitId{1}, 4, {&r, 1}).ok());
  ASSERT_EQ(rig.arrivals.size(), 2U);
  EXPECT_EQ(rig.arrivals[1] - rig.arrivals[0], 100ms);
  EXPECT_EQ(rig.master->stats().responses, 1U);
}

TEST(MasterOnVirtualTime, AnswerAfterTheDeadline_IsATimeout) {
  MasterOptions o{.response_timeout = 50ms};
  ManualClock clock;
  o.clock = &clock;
  Master master(std::make_unique<MemoryLink>(
                    clock,
                    [](std::span<const uint8_t>) {
                      // A correct answer to "01 03 00 00 00 01", 60 ms late.
                      return MemoryLink::Reply{{0x01, 0x03, 0x02, 0x00, 0x05, 0x78, 0x47}, 60ms};
                    }),
                o);
  uint16_t r = 0;
  EXPECT_EQ(master.read_holding_registers(UnitId{1}, 0, {&r, 1}).code(), Errc::timeout);
}

}  // namespace
}  // namespace rtukit
