// Faults chosen frame by frame (driver/fault_plan.hpp): the rule text, and
// which frame each rule takes, on literal frames and a clock passed in.
#include <gtest/gtest.h>

#include "rtukit/driver/fault_plan.hpp"

namespace rtukit {
namespace {

using namespace std::chrono_literals;
using Way = FaultRule::Way;
using Kind = FaultPlan::Decision::Kind;

// Rehand 6600 frames, typed from the seed's layout (unit 1).
const std::vector<uint8_t> kRelease = {0x01, 0x06, 0x00, 0x63, 0x00, 0x00, 0x79, 0xD4};  // seat lift = 0
const std::vector<uint8_t> kPress = {0x01, 0x06, 0x00, 0x63, 0x00, 0x01, 0xB8, 0x14};    // seat lift = 1
const std::vector<uint8_t> kPoll = {0x01, 0x03, 0x00, 0x00, 0x00, 0x30, 0x45, 0xDE};     // table 1
const std::vector<uint8_t> kPollReply = {0x01, 0x03, 0x02, 0x00, 0x68, 0xB9, 0xAA};       // (one register)

TEST(FaultRule, TextIsReadAndWrittenBack) {
  const auto r = parse_fault_rule("drop request fc06 0x0063=0");
  ASSERT_TRUE(r.ok()) << r.error().reason();
  EXPECT_EQ(r->action, FaultRule::Action::drop);
  EXPECT_EQ(r->way, Way::request);
  EXPECT_EQ(r->function, 0x06);
  EXPECT_EQ(r->address, 0x0063);
  EXPECT_EQ(r->value, 0);
  EXPECT_EQ(r->count, 1U);
  EXPECT_EQ(r->text(), "drop request fc06 0x0063=0");
  const auto window = parse_fault_rule("drop replies for 400ms");
  ASSERT_TRUE(window.ok());
  EXPECT_EQ(window->count, 0U);
  EXPECT_EQ(window->window, 400ms);
  EXPECT_EQ(parse_fault_rule(window->text())->text(), window->text());
  const auto delay = parse_fault_rule("delay reply 1.5s x2 after 3");
  ASSERT_TRUE(delay.ok()) << delay.error().reason();
  EXPECT_EQ(delay->delay, 1500ms);
  EXPECT_EQ(delay->count, 2U);
  EXPECT_EQ(delay->after, 3U);
  // A value alone means FC06 (what writes one value).
  EXPECT_EQ(parse_fault_rule("corrupt all 99=1")->function, 0x06);
}

TEST(FaultRule, BadTextGetsAReason) {
  const auto reason = [](const char* t) { return std::string(parse_fault_rule(t).error().reason()); };
  EXPECT_NE(reason("dorp request").find("unknown action 'dorp'"), std::string::npos);
  EXPECT_NE(reason("drop sideways").find("unknown way"), std::string::npos);
  EXPECT_NE(reason("delay replies").find("duration"), std::string::npos);
  EXPECT_NE(reason("drop all for").find("duration"), std::string::npos);
  EXPECT_NE(reason("drop all x3 for 1s").find("not both"), std::string::npos);
  EXPECT_NE(reason("drop all 0x10000").find("0x10000"), std::string::npos);
  EXPECT_NE(reason("drop all fc99").find("fc01..fc7f"), std::string::npos);
  EXPECT_NE(reason("drop").find("ACTION WAY"), std::string::npos);
}

TEST(FaultPlan, ARuleTakesOnlyItsFrames_CountThenEnds) {
  FaultPlan plan;
  const FaultPlan::TimePoint t{};
  plan.add(*parse_fault_rule("drop request fc06 0x0063=0"), t);
  EXPECT_EQ(plan.decide(Way::request, kPress, {}, t).kind, Kind::pass) << "another value";
  EXPECT_EQ(plan.decide(Way::request, kPoll, {}, t).kind, Kind::pass) << "another function";
  EXPECT_EQ(plan.decide(Way::reply, kRelease, kRelease, t).kind, Kind::pass) << "a reply";
  const auto d = plan.decide(Way::request, kRelease, {}, t);
  EXPECT_EQ(d.kind, Kind::drop);
  EXPECT_EQ(d.rule, "drop request fc06 0x0063=0");
  EXPECT_EQ(plan.decide(Way::request, kRelease, {}, t).kind, Kind::pass) << "once";
  EXPECT_TRUE(plan.rules(t).empty());
}

TEST(FaultPlan, AReplyMatchesAsTheRequestItAnswers_AfterLetsSomePass) {
  FaultPlan plan;
  const FaultPlan::TimePoint t{};
  plan.add(*parse_fault_rule("corrupt reply fc03 0x0000 after 1"), t);
  EXPECT_EQ(plan.decide(Way::reply, kPollReply, kPoll, t).kind, Kind::pass) << "the first passes";
  EXPECT_EQ(plan.decide(Way::reply, kPollReply, kRelease, t).kind, Kind::pass) << "answers another request";
  EXPECT_EQ(plan.decide(Way::reply, kPollReply, kPoll, t).kind, Kind::corrupt);
  const auto bad = FaultPlan::corrupted(kPollReply);
  EXPECT_EQ(bad.size(), kPollReply.size());
  EXPECT_NE(bad.back(), kPollReply.back());
}

TEST(FaultPlan, AWindowTakesEveryMatchUntilItEnds) {
  FaultPlan plan;
  const FaultPlan::TimePoint t{std::chrono::seconds(10)};
  plan.add(*parse_fault_rule("drop all for 600ms"), t);
  EXPECT_EQ(plan.decide(Way::request, kPoll, {}, t).kind, Kind::drop);
  EXPECT_EQ(plan.decide(Way::reply, kPollReply, kPoll, t + 599ms).kind, Kind::drop);
  EXPECT_EQ(plan.decide(Way::request, kPoll, {}, t + 600ms).kind, Kind::pass);
  plan.add(*parse_fault_rule("delay replies 150ms"), t);
  const auto d = plan.decide(Way::reply, kPollReply, kPoll, t + 700ms);
  EXPECT_EQ(d.kind, Kind::delay);
  EXPECT_EQ(d.delay, 150ms);
}

}  // namespace
}  // namespace rtukit
