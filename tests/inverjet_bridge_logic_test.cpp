// The MQTT bridge's logic without MQTT and without a thread (BridgeLogic):
// a Master on a MemoryLink to the Inverjet model (the simulator's machine),
// one ManualClock for the bus, the model and the schedule, and a list of
// what the bridge would publish. Each test moves the clock and runs steps,
// so "offline after two failed polls", "health every 10 s" and "at most
// --max-rate documents a second" are exact, in no real time.
#include <gtest/gtest.h>

#include <array>
#include <nlohmann/json.hpp>

#include "inverjet_on_memory_link.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/driver/bus_worker.hpp"
#include "rtukit/driver/memory_link.hpp"
#include "rtukit/programs/inverjet_bridge.hpp"

namespace rtukit::programs {
namespace {

using namespace std::chrono_literals;
using Json = nlohmann::json;

class BridgeLogicTest : public InverjetOnMemoryLink {
 protected:
  void SetUp() override {
    InverjetOnMemoryLink::SetUp();
    options_.machines = {{21, "lane1"}};
    options_.poll_hz = 2;
    options_.max_rate = 2;
    options_.discovery_prefix = "homeassistant";
    logic_ = std::make_unique<BridgeLogic>(*master_, options_, clock_,
                                           [this](size_t, const MqttMessage& m) { sent_.push_back(m); });
  }

  void run_until(Clock::time_point until) { run_logic_until(*logic_, until); }
  void run_for(Clock::duration d) { run_until(clock_.now() + d); }

  std::vector<MqttMessage> taken(const std::string& suffix) {
    std::vector<MqttMessage> out;
    for (const MqttMessage& m : sent_)
      if (m.topic == "rtukit/inverjet/lane1" + suffix) out.push_back(m);
    return out;
  }
  Json last_json(const std::string& suffix) {
    const auto all = taken(suffix);
    return all.empty() ? Json() : Json::parse(all.back().payload);
  }
  std::string command(Json body) {
    body["ts"] = clock_.unix_seconds();
    return body.dump();
  }

  BridgeOptions options_;
  std::unique_ptr<BridgeLogic> logic_;
  std::vector<MqttMessage> sent_;
};

TEST_F(BridgeLogicTest, FirstStep_PublishesOnlineTheStateAndEachValue_Retained) {
  logic_->step(clock_.now());
  ASSERT_EQ(taken("/availability").size(), 1u);
  EXPECT_EQ(taken("/availability")[0].payload, "online");
  EXPECT_TRUE(taken("/availability")[0].retain);
  const Json state = last_json("/state");
  EXPECT_EQ(state["state"], "off");
  EXPECT_EQ(state["speed"], 0);
  EXPECT_TRUE(taken("/state")[0].retain);
  EXPECT_EQ(taken("/value/state").at(0).payload, "off");
  // Nothing changed: the next polls publish no state at all.
  const size_t states = taken("/state").size();
  run_for(5s);
  EXPECT_EQ(taken("/state").size(), states);
}

TEST_F(BridgeLogicTest, PollsEveryPeriod_StartToStart) {
  logic_->step(clock_.now());
  run_for(10s);
  // Health every 10 s, sent before that step's poll: at 2 Hz, the polls at
  // 0, 0.5, ... 9.5 s (20), none late, each 500 ms after the last.
  logic_->step(clock_.now());
  const Json health = last_json("/bridge");
  EXPECT_EQ(health["polls"], 20);
  EXPECT_EQ(health["late_polls"], 0);
  EXPECT_EQ(health["max_poll_gap_ms"], 500);
  EXPECT_EQ(taken("/bridge").size(), 2u);  // at the start and at 10 s
}

TEST_F(BridgeLogicTest, ACommandRunsAtTheNextStep_AnswersWithItsId_AndItsEffectIsPublishedAtOnce) {
  logic_->step(clock_.now());
  ASSERT_TRUE(
      logic_->queue_command(0, "start", command({{"mode", "free"}, {"speed", 40}, {"id", "c1"}}), false));
  const auto before = clock_.now();
  logic_->step(clock_.now());
  const Json result = last_json("/result");
  EXPECT_EQ(result["ok"], true) << result.dump();
  EXPECT_EQ(result["id"], "c1");
  EXPECT_EQ(result["command"], "start");
  // The poll right after it, in the same step, shows the machine starting.
  EXPECT_NE(last_json("/state")["state"], "off");
  EXPECT_EQ(last_json("/state")["speed"], 40);
  EXPECT_LT(clock_.now() - before, 100ms);  // bus time only: two requests' answers
}

TEST_F(BridgeLogicTest, AStaleCommandIsRefused_AndTheMachineStaysOff) {
  logic_->step(clock_.now());
  Json body{{"mode", "free"}, {"speed", 40}, {"ts", clock_.unix_seconds() - 60}};
  ASSERT_TRUE(logic_->queue_command(0, "start", body.dump(), false));
  logic_->step(clock_.now());
  const Json result = last_json("/result");
  EXPECT_EQ(result["ok"], false);
  EXPECT_NE(result["error"].get<std::string>().find("stale"), std::string::npos) << result.dump();
  run_for(2s);
  EXPECT_EQ(last_json("/state")["state"], "off");
}

TEST_F(BridgeLogicTest, AFloodIsAnsweredBusyAtOnce_NotQueued) {
  for (size_t i = 0; i < kCommandQueueLimit; ++i)
    ASSERT_TRUE(logic_->queue_command(0, "stop", command({}), false));
  EXPECT_FALSE(logic_->queue_command(0, "stop", command({{"id", 7}}), false));
  const Json busy = last_json("/result");  // before any step: on the caller's thread
  EXPECT_EQ(busy["ok"], false);
  EXPECT_EQ(busy["id"], 7);
  EXPECT_NE(busy["error"].get<std::string>().find("busy"), std::string::npos);
  EXPECT_EQ(busy["code"], "busy") << "a code programs act on, not the text";
  logic_->step(clock_.now());
  EXPECT_EQ(taken("/result").size(), kCommandQueueLimit + 1);
}

TEST_F(BridgeLogicTest, OfflineAfterTwoFailedPolls_OnlineAgainAtTheFirstAnswer) {
  logic_->step(clock_.now());
  silent_ = true;
  run_for(600ms);  // one failed poll (at 500 ms): still online
  EXPECT_EQ(taken("/availability").back().payload, "online");
  run_for(3s);
  EXPECT_EQ(taken("/availability").back().payload, "offline");
  EXPECT_EQ(taken("/availability").size(), 2u);  // said once
  silent_ = false;
  run_for(6s);  // the back-off is 5 s at most
  EXPECT_EQ(taken("/availability").back().payload, "online");
}

TEST_F(BridgeLogicTest, ChangesFasterThanMaxRateAreHeld_ThenPublished) {
  options_.max_rate = 0.5;  // one document every 2 s at most
  logic_ = std::make_unique<BridgeLogic>(*master_, options_, clock_,
                                         [this](size_t, const MqttMessage& m) { sent_.push_back(m); });
  logic_->step(clock_.now());
  ASSERT_TRUE(logic_->queue_command(0, "start", command({{"mode", "free"}, {"speed", 30}}), false));
  logic_->step(clock_.now());  // a command's effect: published at once, not counted
  const size_t after_command = taken("/state").size();
  // The machine runs on (its run time counts up): a change every poll.
  run_for(4s);
  const size_t published = taken("/state").size() - after_command;
  EXPECT_GE(published, 1u);
  EXPECT_LE(published, 3u);  // 4 s at 0.5 a second (a first one may go at once)
}

TEST_F(BridgeLogicTest, AfterAConnect_DiscoveryAndStateGoOutAgain) {
  logic_->step(clock_.now());
  const size_t states = taken("/state").size();
  logic_->announce(0);
  logic_->step(clock_.now() + 1ms);
  bool discovery = false;
  for (const MqttMessage& m : sent_)
    if (m.topic == "homeassistant/number/rtukit_inverjet_lane1/speed/config") discovery = m.retain;
  EXPECT_TRUE(discovery);
  EXPECT_EQ(taken("/availability").size(), 2u);
  EXPECT_EQ(taken("/state").size(), states);  // published again at the next poll
  run_for(1s);
  EXPECT_EQ(taken("/state").size(), states + 1);
}

TEST_F(BridgeLogicTest, OnTheBusWorker_ThePostedCommandRuns) {
  BusWorker worker([this](Clock::time_point now) { return logic_->step(now); }, {.clock = &clock_});
  worker.run_once();
  ASSERT_TRUE(logic_->queue_command(0, "speed", command({{"speed", 55}}), false));
  worker.wake();
  worker.run_once();
  EXPECT_EQ(last_json("/result")["ok"], true);
  EXPECT_EQ(last_json("/state")["speed"], 55);
}

}  // namespace
}  // namespace rtukit::programs
