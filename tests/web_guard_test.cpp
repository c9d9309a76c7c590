// The guards every program's listeners share (web/guard.hpp), on virtual
// time: a token bucket, wrong guesses per source (an IPv6 network as one, in
// bounded memory), hex and SHA-256. The Rehand host daemon's pairing and
// Bluetooth link and the pool panel's login use these, not copies.
#include <gtest/gtest.h>

#include <string>

#include "rtukit/web/guard.hpp"

namespace rtukit::web {
namespace {

using namespace std::chrono_literals;

// Guesses are counted per source: an IPv4 address, an IPv6 network per /64
// (one subscriber has all of it: counted per address, 2^64 addresses were
// 2^64 budgets).
TEST(GuessSource, AnIpv4AddressItself_AnIpv6NetworkAsOne) {
  EXPECT_EQ(guess_source("192.0.2.7"), "192.0.2.7");
  EXPECT_NE(guess_source("192.0.2.8"), guess_source("192.0.2.7"));
  EXPECT_EQ(guess_source("2001:db8:1:2:aaaa:bbbb:cccc:dddd"), "2001:db8:1:2::/64");
  EXPECT_EQ(guess_source("2001:db8:1:2::1"), guess_source("2001:db8:1:2:ffff::9"));
  EXPECT_NE(guess_source("2001:db8:1:3::1"), guess_source("2001:db8:1:2::1"));
  EXPECT_EQ(guess_source("::1"), "::/64");
  EXPECT_EQ(guess_source("not an address"), "not an address");
}

TEST(GuessLimit, TenWrongFromOneNetworkAreRefusedUntilItsMinuteEnds) {
  GuessLimit limit(10, 1min, 4096);
  TimePoint t{1h};
  for (int i = 0; i < 10; ++i) {
    const std::string peer = "2001:db8:1:2::" + std::to_string(i + 1);  // a new address each time
    ASSERT_FALSE(limit.refused(peer, t)) << i;
    limit.count(peer, t);
  }
  EXPECT_TRUE(limit.refused("2001:db8:1:2::99", t)) << "the same /64 from an address not seen before";
  EXPECT_FALSE(limit.refused("2001:db8:1:3::1", t)) << "another network";
  EXPECT_FALSE(limit.refused("192.0.2.7", t));
  EXPECT_TRUE(limit.refused("2001:db8:1:2::1", t + 59s));
  EXPECT_FALSE(limit.refused("2001:db8:1:2::1", t + 60s)) << "its minute is over";
}

TEST(GuessLimit, ForgetsEndedMinutes_AFullTableRefusesNewSources) {
  GuessLimit limit(10, 1min, 3);
  TimePoint t{1h};
  for (const char* peer : {"192.0.2.1", "192.0.2.2", "192.0.2.3"}) {
    ASSERT_FALSE(limit.refused(peer, t));
    limit.count(peer, t);
  }
  EXPECT_EQ(limit.sources(), 3U);
  EXPECT_TRUE(limit.refused("192.0.2.4", t + 1s)) << "full of live sources: a new one waits (fail closed)";
  EXPECT_FALSE(limit.refused("192.0.2.1", t + 1s)) << "a known source keeps its own count";
  EXPECT_FALSE(limit.refused("192.0.2.4", t + 61s)) << "the ended minutes are forgotten";
  EXPECT_EQ(limit.sources(), 0U);
}

// A rate with bursts: two seconds' worth at once, then the rate. The BLE
// link had its own copy on the real clock (issue 38), the web server another.
TEST(TokenBucket, ABurstOfTwoSecondsThenTheRate) {
  TokenBucket bucket(10);  // 10 a second
  TimePoint t{1h};
  int taken = 0;
  while (bucket.take(t)) ++taken;
  EXPECT_EQ(taken, 20);                 // the burst: two seconds' worth
  EXPECT_FALSE(bucket.take(t + 50ms));  // half a token back
  EXPECT_TRUE(bucket.take(t + 100ms));  // one a tenth of a second
  EXPECT_FALSE(bucket.take(t + 100ms));
  // A long pause fills it to the burst, never beyond.
  taken = 0;
  while (bucket.take(t + 1h)) ++taken;
  EXPECT_EQ(taken, 20);
}

// What the pool panel's "try again in N s" says: the rest of the source's
// window; a full table, the first window to end.
TEST(GuessLimit, WaitIsWhatIsLeftOfTheWindow) {
  GuessLimit limit(2, 1min, 2);
  TimePoint t{1h};
  EXPECT_EQ(limit.wait("192.0.2.1", t), 0s);
  EXPECT_EQ(limit.count("192.0.2.1", t), 1);
  EXPECT_EQ(limit.count("192.0.2.1", t + 10s), 2);
  EXPECT_EQ(limit.wait("192.0.2.1", t + 15s), 45s);
  EXPECT_EQ(limit.count("192.0.2.2", t + 20s), 1);
  EXPECT_EQ(limit.wait("192.0.2.3", t + 30s), 30s) << "full: the first window ends at t + 60 s";
  EXPECT_EQ(limit.wait("192.0.2.1", t + 60s), 0s);
}

TEST(Hex, BothWays_Sha256OfAKnownText) {
  EXPECT_EQ(hex(std::string("\x00\x7f\xff", 3)), "007fff");
  EXPECT_EQ(from_hex("007fff"), std::string("\x00\x7f\xff", 3));
  EXPECT_EQ(from_hex("7"), std::nullopt);
  EXPECT_EQ(from_hex("0G"), std::nullopt);
  EXPECT_EQ(from_hex("0A"), std::nullopt);  // lowercase only, as written
  // FIPS 180-2's "abc".
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

}  // namespace
}  // namespace rtukit::web
