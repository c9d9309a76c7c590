// The pool panel's logic without the web server and without a thread
// (PanelLogic): a Master on a MemoryLink to the Inverjet model (the
// simulator's machine), one ManualClock for the bus, the model and the
// schedule, and a list of the messages the pages would get. Each test moves
// the clock and runs steps, so "a poll every 500 ms, start to start",
// "offline after two failed polls" and "busy past 16 commands" are exact, in
// no real time.
#include <gtest/gtest.h>

#include <array>
#include <nlohmann/json.hpp>

#include "inverjet_on_memory_link.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/driver/bus_worker.hpp"
#include "rtukit/driver/memory_link.hpp"
#include "rtukit/programs/inverjet_panel.hpp"

namespace rtukit::programs {
namespace {

using namespace std::chrono_literals;
using Json = nlohmann::json;

constexpr uint64_t kPage = 7;  // the socket id of the page that sends commands

class PanelLogicTest : public InverjetOnMemoryLink {
 protected:
  void SetUp() override {
    InverjetOnMemoryLink::SetUp();
    options_.unit = 21;
    options_.poll_hz = 2;
    make_logic();
  }

  void make_logic() {
    logic_ = std::make_unique<PanelLogic>(*master_, options_, clock_,
                                          [this](const PanelMessage& m) { sent_.push_back(m); });
  }

  void run_until(Clock::time_point until) { run_logic_until(*logic_, until); }
  void run_for(Clock::duration d) { run_until(clock_.now() + d); }

  // The messages of `type` (for every page, or for `to`), parsed.
  std::vector<Json> taken(const std::string& type, uint64_t to = 0) const {
    std::vector<Json> out;
    for (const PanelMessage& m : sent_) {
      if (m.to != to) continue;
      Json j = Json::parse(m.text);
      if (j["type"] == type) out.push_back(std::move(j));
    }
    return out;
  }
  Json last(const std::string& type, uint64_t to = 0) const {
    const auto all = taken(type, to);
    return all.empty() ? Json() : all.back();
  }
  // As the web thread passes it: parsed from the page's text (where 40 is an
  // unsigned number; a C++ literal 40 is a signed one, which the commands refuse).
  bool queue(const Json& command) { return logic_->queue_command(kPage, Json::parse(command.dump())); }

  PanelOptions options_;
  std::unique_ptr<PanelLogic> logic_;
  std::vector<PanelMessage> sent_;
};

TEST_F(PanelLogicTest, PollsAtPollHz_StartToStart) {
  // Each poll's state carries the time of its answer: a new one every poll.
  run_for(10s);
  std::vector<Json> states = taken("state");
  ASSERT_EQ(states.size(), 20u);  // at 0, 0.5, ... 9.5 s
  for (size_t i = 1; i < states.size(); ++i)
    EXPECT_EQ(states[i]["last_contact_ms"].get<int64_t>() - states[i - 1]["last_contact_ms"].get<int64_t>(),
              500)
        << i;  // not 505: the bus time of a poll does not push the next one back

  options_.poll_hz = 4;
  make_logic();
  sent_.clear();
  run_for(10s);
  states = taken("state");
  ASSERT_EQ(states.size(), 40u);
  EXPECT_EQ(states[1]["last_contact_ms"].get<int64_t>() - states[0]["last_contact_ms"].get<int64_t>(), 250);
}

TEST_F(PanelLogicTest, Start_ResultToItsPage_AndTheNextStateShowsTheMachineRunning) {
  run_for(1s);
  logic_->step(clock_.now());  // the poll at 1 s
  EXPECT_EQ(last("state")["state"], "off");
  clock_.advance(100ms);  // between two polls: the next is 400 ms away
  const size_t states = taken("state").size();
  ASSERT_TRUE(queue({{"op", "start"}, {"mode", "free"}, {"speed", 40}, {"id", "c1"}}));
  logic_->step(clock_.now());
  const Json result = last("result", kPage);
  EXPECT_EQ(result["ok"], true) << result.dump();
  EXPECT_EQ(result["id"], "c1");
  EXPECT_EQ(result["op"], "start");
  EXPECT_TRUE(taken("result").empty());  // to its page only
  EXPECT_NE(machine_.phase(), inverjet::Phase::off);
  EXPECT_EQ(machine_.speed(), 40);
  // An extra poll right after it, in the same step, shows the machine starting.
  ASSERT_EQ(taken("state").size(), states + 1);
  EXPECT_NE(last("state")["state"], "off");
  EXPECT_EQ(last("state")["speed"], 40);
  EXPECT_EQ(last("state")["online"], true);
}

TEST_F(PanelLogicTest, PastTheQueueLimit_BusyAtOnce_AndNeverRun) {
  run_for(1s);
  ASSERT_EQ(kPanelCommandLimit, 16u);  // the panel's limit, as it was before PanelLogic
  for (size_t i = 0; i < 16; ++i) ASSERT_TRUE(queue({{"op", "stop"}, {"id", i}}));
  // The one past the limit is a start: it must never reach the machine.
  EXPECT_FALSE(queue({{"op", "start"}, {"mode", "free"}, {"speed", 40}, {"id", "late"}}));
  const Json busy = last("result", kPage);  // before any step: on the caller's thread
  EXPECT_EQ(busy["ok"], false);
  EXPECT_EQ(busy["id"], "late");
  EXPECT_EQ(busy["op"], "start");
  EXPECT_NE(busy["error"].get<std::string>().find("busy"), std::string::npos) << busy.dump();
  EXPECT_EQ(busy["code"], "busy") << "a code programs act on, not the text";
  logic_->step(clock_.now());
  run_for(2s);
  EXPECT_EQ(taken("result", kPage).size(), 17u);
  EXPECT_EQ(machine_.phase(), inverjet::Phase::off);
  EXPECT_EQ(last("state")["state"], "off");
  // The queue ran empty: the next command is taken again.
  EXPECT_TRUE(queue({{"op", "stop"}}));
}

TEST_F(PanelLogicTest, ABadCommandIsRefused_WithoutTouchingTheMachine) {
  run_for(1s);
  ASSERT_TRUE(queue({{"op", "start"}, {"mode", "free"}, {"speed", "fast"}, {"id", 1}}));
  ASSERT_TRUE(queue({{"op", "launch"}, {"id", 2}}));
  ASSERT_TRUE(queue({{"op", "start"}, {"mode", 1}, {"id", 3}}));
  logic_->step(clock_.now());
  const std::vector<Json> results = taken("result", kPage);
  ASSERT_EQ(results.size(), 3u);
  for (const Json& r : results) {
    EXPECT_EQ(r["ok"], false) << r.dump();
    EXPECT_FALSE(r["error"].get<std::string>().empty());
  }
  EXPECT_NE(results[1]["error"].get<std::string>().find("unknown command"), std::string::npos);
  EXPECT_EQ(writes_, 0);
  // Not a command at all: answered at once, never queued.
  EXPECT_FALSE(logic_->queue_command(kPage, Json::array({1, 2})));
  EXPECT_FALSE(logic_->queue_command(kPage, Json{{"op", 5}}));
  EXPECT_EQ(taken("error", kPage).size(), 2u);
  EXPECT_EQ(machine_.phase(), inverjet::Phase::off);
}

TEST_F(PanelLogicTest, OfflineAfterTwoFailedPolls_OnlineAgainAtTheFirstAnswer) {
  logic_->step(clock_.now());
  ASSERT_EQ(last("state")["online"], true);
  silent_ = true;
  run_for(600ms);  // one failed poll (at 500 ms): still online
  EXPECT_EQ(last("state")["online"], true);
  run_for(3s);
  EXPECT_EQ(last("state")["online"], false);
  EXPECT_EQ(last("state")["state"], "off");  // the last state, marked offline
  size_t offline = 0;
  for (const Json& s : taken("state")) offline += s["online"] == false;
  EXPECT_EQ(offline, 1u);  // said once
  run_for(10s);
  EXPECT_EQ(taken("state").back()["online"], false);
  offline = 0;
  for (const Json& s : taken("state")) offline += s["online"] == false;
  EXPECT_EQ(offline, 1u);
  silent_ = false;
  run_for(6s);  // the back-off is 5 s at most
  EXPECT_EQ(last("state")["online"], true);
}

TEST_F(PanelLogicTest, AMachineThatNeverAnswered_IsShownOffline_WithoutPlans) {
  silent_ = true;
  run_for(5s);
  const std::vector<Json> states = taken("state");
  ASSERT_EQ(states.size(), 1u);
  EXPECT_EQ(states[0]["online"], false);
  EXPECT_FALSE(states[0].contains("state"));
  EXPECT_TRUE(taken("plans").empty());
}

TEST_F(PanelLogicTest, DuringARun_SamplesCarryTheSpeed_AndTheHistoryKeepsThem) {
  run_for(1s);
  EXPECT_TRUE(taken("sample").empty());  // no run, no samples
  ASSERT_TRUE(queue({{"op", "start"}, {"mode", "free"}, {"speed", 40}}));
  run_for(10s);
  const std::vector<Json> samples = taken("sample");
  ASSERT_GE(samples.size(), 19u);
  EXPECT_EQ(samples.back()["speed"], 40);
  EXPECT_GT(samples.back()["current_a"].get<double>(), 0);
  EXPECT_GT(samples.back()["t"].get<double>(), samples.front()["t"].get<double>());
  // A new run starts with an empty history, sent before its first sample.
  ASSERT_EQ(taken("history").size(), 1u);
  EXPECT_TRUE(taken("history")[0]["samples"].empty());

  uint64_t seq = 0;
  const std::vector<std::string> welcome = logic_->welcome(seq);
  ASSERT_EQ(welcome.size(), 4u);  // state, history, plans, limits
  const Json history = Json::parse(welcome[1]);
  EXPECT_EQ(history["type"], "history");
  ASSERT_EQ(history["samples"].size(), samples.size());
  EXPECT_EQ(history["samples"].back(), samples.back());

  // Kept after the run ends; a second run starts a new one.
  ASSERT_TRUE(queue({{"op", "stop"}}));
  run_for(5s);
  ASSERT_EQ(machine_.phase(), inverjet::Phase::off);
  const size_t run_samples = taken("sample").size();
  run_for(5s);
  EXPECT_EQ(taken("sample").size(), run_samples);  // none while off
  EXPECT_EQ(Json::parse(logic_->welcome(seq)[1])["samples"].size(), run_samples);
  ASSERT_TRUE(queue({{"op", "start"}, {"mode", "free"}, {"speed", 30}}));
  run_for(3s);
  EXPECT_EQ(taken("history").size(), 2u);
  const Json second = Json::parse(logic_->welcome(seq)[1]);
  EXPECT_LT(second["samples"].size(), 10u);
  EXPECT_EQ(last("sample")["speed"], 30);
}

TEST_F(PanelLogicTest, PlansAreReadOnceAfterTheFirstAnswer_AndOnRequest) {
  silent_ = true;
  run_for(2s);
  EXPECT_TRUE(taken("plans").empty());
  silent_ = false;
  run_for(10s);
  ASSERT_EQ(taken("plans").size(), 1u);
  const Json plans = last("plans")["plans"];
  ASSERT_EQ(plans.size(), 4u);
  ASSERT_FALSE(plans[0].empty());
  EXPECT_EQ(plans[0][0]["speed"], machine_.plan(1)[0].speed);
  EXPECT_EQ(plans[0][0]["end_s"], machine_.plan(1)[0].end);

  // Offline and back: not read again.
  silent_ = true;
  run_for(5s);
  silent_ = false;
  run_for(6s);
  EXPECT_EQ(taken("plans").size(), 1u);

  ASSERT_TRUE(queue({{"op", "plans"}, {"id", "p"}}));
  logic_->step(clock_.now());
  EXPECT_EQ(taken("plans").size(), 2u);
  EXPECT_EQ(last("result", kPage)["ok"], true);
  EXPECT_EQ(last("result", kPage)["id"], "p");
}

TEST_F(PanelLogicTest, APlanTheMachineTook_IsReadBackAndSent) {
  run_for(1s);
  ASSERT_TRUE(queue({{"op", "plan"},
                     {"plan", 2},
                     {"segments", {{{"speed", 40}, {"end", "05:00"}}, {{"speed", 70}, {"end", "10:00"}}}}}));
  logic_->step(clock_.now());
  EXPECT_EQ(last("result", kPage)["ok"], true) << last("result", kPage).dump();
  EXPECT_EQ(machine_.plan(2)[1].speed, 70);
  ASSERT_EQ(taken("plans").size(), 2u);
  const Json plan = last("plans")["plans"][1];
  ASSERT_EQ(plan.size(), 2u);
  EXPECT_EQ(plan[1]["speed"], 70);
  EXPECT_EQ(plan[1]["end"], "10:00");

  // One the machine refuses (a speed out of range) sends no plans.
  ASSERT_TRUE(queue({{"op", "plan"}, {"plan", 2}, {"segments", {{{"speed", 500}, {"end", "05:00"}}}}}));
  logic_->step(clock_.now());
  EXPECT_EQ(last("result", kPage)["ok"], false);
  EXPECT_EQ(taken("plans").size(), 2u);
  EXPECT_EQ(machine_.plan(2)[1].speed, 70);
}

TEST_F(PanelLogicTest, Welcome_CoversTheMessagesUpToItsSeq) {
  uint64_t seq = 99;
  EXPECT_EQ(logic_->welcome(seq).size(), 2u);  // the empty history and the limits only
  EXPECT_EQ(seq, 0u);
  run_for(2s);
  const std::vector<std::string> welcome = logic_->welcome(seq);
  ASSERT_EQ(welcome.size(), 4u);
  EXPECT_EQ(seq, sent_.back().seq);
  EXPECT_EQ(welcome[0], sent_.back().text);     // the last state
  const Json limits = Json::parse(welcome[3]);  // the page's limits, from the device layer
  EXPECT_EQ(limits["type"], "limits");
  EXPECT_EQ(limits["limits"]["plans"], 4);
  EXPECT_EQ(limits["limits"]["segments"], 50);
  for (size_t i = 0; i < sent_.size(); ++i) EXPECT_EQ(sent_[i].seq, i + 1);
}

TEST_F(PanelLogicTest, OnTheBusWorker_TheQueuedCommandRuns) {
  BusWorker worker([this](Clock::time_point now) { return logic_->step(now); }, {.clock = &clock_});
  worker.run_once();
  ASSERT_TRUE(queue({{"op", "start"}, {"mode", "free"}, {"speed", 55}}));
  worker.wake();
  worker.run_once();
  EXPECT_EQ(last("result", kPage)["ok"], true);
  EXPECT_EQ(last("state")["speed"], 55);
  EXPECT_EQ(machine_.speed(), 55);
}

}  // namespace
}  // namespace rtukit::programs
