// Faults chosen frame by frame (fault_plan.hpp). A rule is matched on the
// request's fields; a reply carries no address of its own (an FC03 answer is
// a byte count and data), so it is matched as the request it answers.
#include "rtukit/driver/fault_plan.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <charconv>

namespace rtukit {
namespace {

Status bad(std::string reason) {
  return Status(Errc::invalid_argument, std::move(reason));
}

std::optional<uint32_t> number(std::string_view w) {
  int base = 10;
  if (w.starts_with("0x") || w.starts_with("0X")) {
    w.remove_prefix(2);
    base = 16;
  }
  uint32_t v = 0;
  const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v, base);
  if (w.empty() || ec != std::errc() || end != w.data() + w.size()) return std::nullopt;
  return v;
}

// "400ms", "2s", "1.5s" (as milliseconds).
std::optional<std::chrono::milliseconds> duration(std::string_view w) {
  double scale = 1;
  if (w.ends_with("ms")) {
    w.remove_suffix(2);
  } else if (w.ends_with("s")) {
    w.remove_suffix(1);
    scale = 1000;
  } else {
    return std::nullopt;
  }
  double v = 0;
  const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
  if (w.empty() || ec != std::errc() || end != w.data() + w.size() || v < 0 || v * scale > 3'600'000)
    return std::nullopt;
  return std::chrono::milliseconds(static_cast<int64_t>(v * scale + 0.5));
}

std::vector<std::string_view> words(std::string_view text) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    const size_t start = i;
    while (i < text.size() && text[i] != ' ' && text[i] != '\t') ++i;
    if (i > start) out.push_back(text.substr(start, i - start));
  }
  return out;
}

// The first register a request names, and the value an FC06 writes.
struct Fields {
  uint8_t function = 0;
  std::optional<uint16_t> address, value;
};

Fields fields_of(std::span<const uint8_t> adu) {
  Fields f;
  if (adu.size() < 4) return f;
  f.function = adu[1] & 0x7F;
  const bool addressed = (f.function >= 0x01 && f.function <= 0x06) || f.function == 0x0F ||
                         f.function == 0x10 || f.function == 0x16 || f.function == 0x17;
  if (addressed && adu.size() >= 6) f.address = static_cast<uint16_t>(adu[2] << 8 | adu[3]);
  if (f.function == 0x06 && adu.size() >= 8) f.value = static_cast<uint16_t>(adu[4] << 8 | adu[5]);
  return f;
}

}  // namespace

std::string_view fault_rule_help() noexcept {
  return "rules: ACTION WAY [fcNN] [ADDR[=VALUE]] [xN | for DURATION] [after N]\n"
         "  drop request fc06 0x0063=0   the next request writing 0 to 0x0063 is lost\n"
         "  drop replies for 400ms       every reply for 400 ms\n"
         "  drop all for 600ms           the cable out (both ways)\n"
         "  corrupt reply fc03 x2        the next two FC03 replies with a bad CRC\n"
         "  delay replies 150ms          the next reply 150 ms late\n"
         "  delay request 600ms          the next request 600 ms late (a stalled master)\n";
}

std::string FaultRule::text() const {
  std::string out = action == Action::drop ? "drop" : action == Action::corrupt ? "corrupt" : "delay";
  out += way == Way::request ? " request" : way == Way::reply ? " reply" : " all";
  if (action == Action::delay) out += fmt::format(" {}ms", delay.count());
  if (function) out += fmt::format(" fc{:02x}", *function);
  if (address) out += fmt::format(" 0x{:04x}", *address);
  if (value) out += fmt::format("={}", *value);
  if (count == 0)
    out += fmt::format(" for {}ms", window.count());
  else if (count != 1)
    out += fmt::format(" x{}", count);
  if (after) out += fmt::format(" after {}", after);
  return out;
}

Outcome<FaultRule> parse_fault_rule(std::string_view text) {
  const std::vector<std::string_view> w = words(text);
  if (w.size() < 2) return bad("a rule is ACTION WAY [fcNN] [ADDR[=VALUE]] [xN | for DURATION] [after N]");
  FaultRule r;
  size_t i = 0;
  if (w[i] == "drop")
    r.action = FaultRule::Action::drop;
  else if (w[i] == "corrupt")
    r.action = FaultRule::Action::corrupt;
  else if (w[i] == "delay")
    r.action = FaultRule::Action::delay;
  else
    return bad(fmt::format("unknown action '{}': drop, corrupt or delay", w[i]));
  ++i;
  if (w[i] == "request" || w[i] == "requests")
    r.way = FaultRule::Way::request;
  else if (w[i] == "reply" || w[i] == "replies")
    r.way = FaultRule::Way::reply;
  else if (w[i] == "all")
    r.way = FaultRule::Way::both;
  else
    return bad(fmt::format("unknown way '{}': request(s), reply/replies or all", w[i]));
  ++i;
  if (r.action == FaultRule::Action::delay) {
    const auto d = i < w.size() ? duration(w[i]) : std::nullopt;
    if (!d) return bad("delay needs a duration after the way: delay replies 150ms");
    r.delay = *d;
    ++i;
  }
  bool counted = false;
  for (; i < w.size(); ++i) {
    const std::string_view t = w[i];
    if (t.starts_with("fc") && t.size() > 2) {
      const auto f = number("0x" + std::string(t.substr(2)));
      if (!f || *f == 0 || *f > 0x7F) return bad(fmt::format("'{}': a function code is fc01..fc7f", t));
      r.function = static_cast<uint8_t>(*f);
    } else if (t == "for") {
      const auto d = i + 1 < w.size() ? duration(w[i + 1]) : std::nullopt;
      if (!d || d->count() == 0) return bad("for needs a duration: for 400ms");
      r.window = *d;
      r.count = 0;
      ++i;
    } else if (t == "after") {
      const auto n = i + 1 < w.size() ? number(w[i + 1]) : std::nullopt;
      if (!n || *n > 1'000'000) return bad("after needs a number: after 3");
      r.after = *n;
      ++i;
    } else if (t.starts_with("x") && t.size() > 1 && number(t.substr(1))) {
      const auto n = number(t.substr(1));
      if (*n == 0 || *n > 1'000'000) return bad(fmt::format("'{}': a count is x1 or more", t));
      r.count = *n;
      counted = true;
    } else {
      const size_t eq = t.find('=');
      const auto a = number(t.substr(0, eq));
      if (!a || *a > 0xFFFF)
        return bad(fmt::format("'{}' is not fcNN, ADDR[=VALUE], xN, for DURATION or after N", t));
      r.address = static_cast<uint16_t>(*a);
      if (eq != std::string_view::npos) {
        const auto v = number(t.substr(eq + 1));
        if (!v || *v > 0xFFFF) return bad(fmt::format("'{}': a value is 0..65535", t));
        r.value = static_cast<uint16_t>(*v);
        if (!r.function) r.function = 0x06;  // a value is what an FC06 writes
      }
    }
  }
  if (counted && r.window.count() != 0) return bad("a rule takes xN or for DURATION, not both");
  return r;
}

void FaultPlan::add(const FaultRule& rule, TimePoint now) {
  rules_.push_back(Armed{rule, now + rule.window, 0, 0});
}

std::vector<FaultRule> FaultPlan::rules(TimePoint now) const {
  std::vector<FaultRule> out;
  for (const Armed& a : rules_)
    if (a.rule.count == 0 ? now < a.until : a.acted < a.rule.count) out.push_back(a.rule);
  return out;
}

FaultPlan::Decision FaultPlan::decide(FaultRule::Way way, std::span<const uint8_t> adu,
                                      std::span<const uint8_t> answers, TimePoint now) {
  // Rules that ended go first: a plan that runs for hours stays small.
  std::erase_if(rules_,
                [&](const Armed& a) { return a.rule.count == 0 ? now >= a.until : a.acted >= a.rule.count; });
  const Fields own = fields_of(adu);
  const Fields asked = way == FaultRule::Way::reply ? fields_of(answers) : own;
  for (Armed& a : rules_) {
    const FaultRule& r = a.rule;
    if (r.way != FaultRule::Way::both && r.way != way) continue;
    if (r.function && own.function != *r.function) continue;
    if (r.address && asked.address != r.address) continue;
    if (r.value && asked.value != r.value) continue;
    if (++a.seen <= r.after) continue;
    ++a.acted;
    Decision d;
    d.kind = r.action == FaultRule::Action::drop      ? Decision::Kind::drop
             : r.action == FaultRule::Action::corrupt ? Decision::Kind::corrupt
                                                      : Decision::Kind::delay;
    d.delay = r.delay;
    d.rule = r.text();
    return d;
  }
  return {};
}

std::vector<uint8_t> FaultPlan::corrupted(std::span<const uint8_t> adu) {
  std::vector<uint8_t> out(adu.begin(), adu.end());
  if (!out.empty()) out.back() ^= 0xA5;
  return out;
}

}  // namespace rtukit
