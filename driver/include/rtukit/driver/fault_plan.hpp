// rtukit driver: faults on an RTU line, chosen frame by frame. A FaultPlan
// is a list of rules ("drop the request that writes 0 to 0x0063", "drop every
// reply for 400 ms", "hold the next request 600 ms") and the decision, for
// each frame that crosses the line, of what happens to it. Sans-IO: the
// caller passes the frame and the time; the relay (`rtukit relay`,
// fault_relay.hpp) and the simulated links of the tests carry out the
// decision.
//
// Rules, as text (the relay's console and `--fault`; parse_fault_rule):
//   drop request fc06 0x0063=0       the next request writing 0 to 0x0063 (FC06) is lost
//   drop replies for 400ms           every reply for 400 ms from now is lost
//   drop all for 600ms               the cable out for 600 ms (both ways)
//   corrupt reply fc03 x2            the next two FC03 replies arrive with a bad CRC
//   delay replies 150ms              the next reply arrives 150 ms late
//   delay request 600ms              the next request leaves 600 ms late (a stalled master)
//   ... after 3                      let the first 3 matching frames pass
// A rule without `for` acts on `xN` frames (1 by default) and then ends; with
// `for` it acts on every matching frame until its time is up (counted from
// when it was added). Matching: `fcNN` (function code), `ADDR` or
// `ADDR=VALUE` (the first register a request names, and the value an FC06
// writes; a reply matches as the request it answers does).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"

namespace rtukit {

struct FaultRule {
  enum class Action : uint8_t { drop, corrupt, delay };
  enum class Way : uint8_t { request, reply, both };
  Action action = Action::drop;
  Way way = Way::both;
  std::optional<uint8_t> function;      ///< the function code (a reply's without its exception bit)
  std::optional<uint16_t> address;      ///< the first register the request names
  std::optional<uint16_t> value;        ///< the value an FC06 request writes
  unsigned count = 1;                   ///< frames it acts on; 0: every one until `window` ends
  unsigned after = 0;                   ///< matching frames let through first
  std::chrono::milliseconds window{0};  ///< with count 0: how long it lasts from when it was added
  std::chrono::milliseconds delay{0};   ///< Action::delay: how late the frame arrives

  /// The rule as text, in the form parse_fault_rule reads.
  std::string text() const;
};

/// The grammar above as help text: the rule form, examples, one per line.
std::string_view fault_rule_help() noexcept;

/// Reads one rule (the grammar above). Errors: invalid_argument with the
/// reason ("unknown action 'dorp': drop, corrupt or delay").
Outcome<FaultRule> parse_fault_rule(std::string_view text);

class FaultPlan {
 public:
  using TimePoint = rtukit::TimePoint;

  /// What becomes of one frame.
  struct Decision {
    enum class Kind : uint8_t { pass, drop, corrupt, delay } kind = Kind::pass;
    std::chrono::milliseconds delay{0};  ///< Kind::delay
    std::string rule;                    ///< the rule that decided, as text ("" for pass)
  };

  /// Adds `rule`, armed at `now` (a `for` window starts then).
  void add(const FaultRule& rule, TimePoint now);
  /// Removes every rule.
  void clear() { rules_.clear(); }
  /// Rules still in force at `now`, in the order added.
  std::vector<FaultRule> rules(TimePoint now) const;

  /// The fate of `adu` (a whole RTU frame: unit, PDU, CRC) going `way`
  /// (request or reply) at `now`. For a reply, `answers` is the request it
  /// answers (its address and value match the rule), else empty. The first
  /// rule in force that matches decides; a rule that has acted its count
  /// ends.
  Decision decide(FaultRule::Way way, std::span<const uint8_t> adu, std::span<const uint8_t> answers,
                  TimePoint now);

  /// `adu` with a bad CRC: its last byte flipped (what a corrupt decision sends).
  static std::vector<uint8_t> corrupted(std::span<const uint8_t> adu);

 private:
  struct Armed {
    FaultRule rule;
    TimePoint until{};  ///< count 0: the window's end
    unsigned seen = 0;  ///< matching frames so far
    unsigned acted = 0;
  };
  std::vector<Armed> rules_;
};

}  // namespace rtukit
