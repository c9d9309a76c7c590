// What the program-logic tests of the Inverjet share (BridgeLogic,
// PanelLogic): a Master on a MemoryLink to the Inverjet model at unit 21 (the
// simulator's machine), one ManualClock for the bus, the model and the
// schedule, and a way to run a logic's steps at the times it asks for.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <memory>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_link.hpp"

namespace rtukit::programs {

class InverjetOnMemoryLink : public ::testing::Test {
 protected:
  void SetUp() override {
    using namespace std::chrono_literals;
    ASSERT_TRUE(engine_.add_unit(UnitId{21}, machine_).ok());
    master_ = std::make_unique<Master>(
        std::make_unique<MemoryLink>(clock_, [this](std::span<const uint8_t> r) { return answer(r); }),
        MasterOptions{.response_timeout = 300ms, .clock = &clock_});
  }

  // The machine's answer, on its own time (the clock since the start), 5 ms
  // after the request; nothing while `silent_`.
  MemoryLink::Reply answer(std::span<const uint8_t> request) {
    using namespace std::chrono_literals;
    if (request.size() > 1 && (request[1] == 0x06 || request[1] == 0x10)) ++writes_;
    if (silent_) return {};
    machine_.advance_to(static_cast<uint64_t>((clock_.now() - start_) / 1ms));
    std::array<uint8_t, kMaxRtuAduSize> out{};
    const size_t n = engine_.handle_rtu(request, out).length;
    return {{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 5ms};
  }

  // Steps `logic` until the clock reaches `until`, each at the time it asked.
  template <class Logic>
  void run_logic_until(Logic& logic, Clock::time_point until) {
    using namespace std::chrono_literals;
    for (int i = 0; i < 100000 && clock_.now() < until; ++i) {
      const auto next = logic.step(clock_.now());
      clock_.sleep_until(std::min(std::max(next, clock_.now() + 1ms), until));
    }
  }

  ManualClock clock_;
  Clock::time_point start_ = clock_.now();
  inverjet::Machine machine_;
  SlaveEngine engine_;
  bool silent_ = false;
  int writes_ = 0;  ///< write requests (FC06, FC10) sent to the machine
  std::unique_ptr<Master> master_;
};

}  // namespace rtukit::programs
