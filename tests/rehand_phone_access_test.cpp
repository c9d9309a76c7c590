// The Rehand 6600 host daemon's rules for who is in (PhoneAccess, issue 38:
// the daemon's decisions on virtual time, apart from its sockets): a phone
// connection is out until it signs its challenge with a paired key or pairs
// with the display's code; wrong guesses are limited per source; one
// connection per phone, the newest wins; an unauthenticated connection times
// out; an unused phone is forgotten. Every time here is a ManualClock's.
#include <gtest/gtest.h>

#include <deque>
#include <filesystem>
#include <string>

#include "phone_key.hpp"
#include "rtukit/base/clock.hpp"
#include "rtukit/programs/phone_access.hpp"
#include "rtukit/web/webcrypto.hpp"

namespace rtukit::programs {
namespace {

using namespace std::chrono_literals;
using Guess = PairingWindow::Guess;
using rtukit::testing::PhoneKey;

class RehandPhoneAccess : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_FALSE(store.load(clock.unix_seconds())); }
  void TearDown() override { std::filesystem::remove(path_); }

  // A phone pairs on connection `id` with the code shown: its id.
  std::string pair(uint64_t id, const PhoneKey& key, const std::string& peer = "192.0.2.7") {
    access.connected(id, "challenge-" + std::to_string(id));
    const auto a = access.pair(id, peer, access.code(), "Anna's phone", key.public_raw(),
                               key.sign(PhoneAccess::signed_text("challenge-" + std::to_string(id))));
    EXPECT_FALSE(a.error) << a.error.reason();
    return a.phone;
  }
  PhoneAccess::Admission auth(uint64_t id, const std::string& phone, const PhoneKey& key,
                              const std::string& peer = "192.0.2.7") {
    access.connected(id, "challenge-" + std::to_string(id));
    return access.authenticate(id, peer, phone,
                               key.sign(PhoneAccess::signed_text("challenge-" + std::to_string(id))));
  }

  const std::string path_ = (std::filesystem::temp_directory_path() /
                             ("rtukit-access-" + std::to_string(::getpid()) + "-" +
                              ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".json"))
                                .string();
  ManualClock clock;
  PairingStore store{path_};
  std::deque<std::string> codes{"111111", "222222", "333333", "444444", "555555", "666666"};
  PhoneAccess access{store,
                     clock,
                     [this] {
                       if (codes.empty()) return std::string();
                       std::string c = codes.front();
                       codes.pop_front();
                       return c;
                     },
                     {}};
};

TEST_F(RehandPhoneAccess, APhonePairsWithTheCodeShown_TheWindowCloses_ItIsIn) {
  const PhoneKey key;
  ASSERT_TRUE(access.open_window());
  EXPECT_EQ(access.code(), "111111");
  const std::string phone = pair(1, key);
  ASSERT_FALSE(phone.empty());
  EXPECT_TRUE(access.is_in(1));
  EXPECT_EQ(access.phone_of(1), phone);
  EXPECT_TRUE(access.is_connected(phone));
  EXPECT_FALSE(access.window_open()) << "one \"Pair a phone\", one phone";
  ASSERT_NE(store.phone(phone), nullptr);
  EXPECT_EQ(store.phone(phone)->code, "111111");
  EXPECT_FALSE(store.confirmed(phone)) << "a new phone drives only once the display allows it (R-18)";
  EXPECT_EQ(access.left(1), phone);
  EXPECT_FALSE(access.is_connected(phone));
}

TEST_F(RehandPhoneAccess, APairedPhoneSignsItsOwnConnectionsChallenge_NoOther) {
  const PhoneKey key, stranger;
  ASSERT_TRUE(access.open_window());
  const std::string phone = pair(1, key);
  (void)access.left(1);

  EXPECT_FALSE(auth(2, phone, key).error);
  EXPECT_EQ(access.phone_of(2), phone);
  // Another connection's signature: refused, with the same answer as an unknown phone.
  access.connected(3, "challenge-3");
  const auto replayed =
      access.authenticate(3, "192.0.2.7", phone, key.sign(PhoneAccess::signed_text("challenge-2")));
  ASSERT_TRUE(replayed.error);
  EXPECT_EQ(replayed.error.code(), Errc::refused);
  const auto unknown = auth(4, "nobody", key);
  EXPECT_EQ(unknown.error.reason(), replayed.error.reason()) << "one answer for unknown and wrong";
  EXPECT_TRUE(auth(5, phone, stranger).error);
  EXPECT_FALSE(access.is_in(3));
  EXPECT_FALSE(access.is_in(5));
  // The bare challenge, without the prefix, is no proof (a signature made for something else).
  access.connected(6, "challenge-6");
  EXPECT_TRUE(access.authenticate(6, "192.0.2.7", phone, key.sign("challenge-6")).error);
}

TEST_F(RehandPhoneAccess, OneConnectionPerPhone_TheNewestWins_TheOlderIsNamedToClose) {
  const PhoneKey key;
  ASSERT_TRUE(access.open_window());
  const std::string phone = pair(1, key);
  const auto again = auth(2, phone, key);
  ASSERT_FALSE(again.error);
  EXPECT_EQ(again.replaced, std::vector<uint64_t>{1});
  EXPECT_FALSE(access.is_in(1)) << "out at once, before its close completes";
  EXPECT_EQ(access.left(1), "") << "its close lets nobody out";
  EXPECT_TRUE(access.is_connected(phone));
  EXPECT_EQ(access.drop(phone), std::vector<uint64_t>{2});  // forgotten: every connection out
  EXPECT_FALSE(access.is_connected(phone));
}

TEST_F(RehandPhoneAccess, TenWrongGuessesFromOneSourceRefuseItForAMinute_OthersStillTry) {
  const PhoneKey key;
  ASSERT_TRUE(access.open_window());
  const std::string phone = pair(1, key);
  for (uint64_t i = 0; i < 10; ++i) {
    const auto a = auth(100 + i, phone, PhoneKey(), "198.51.100.9");
    ASSERT_TRUE(a.error);
    EXPECT_FALSE(a.limited) << i;
  }
  // The right signature now: refused for the source, before any key is looked at.
  const auto limited = auth(200, phone, key, "198.51.100.9");
  ASSERT_TRUE(limited.error);
  EXPECT_TRUE(limited.limited);
  EXPECT_NE(limited.error.reason().find("wait a minute"), std::string::npos);
  EXPECT_FALSE(auth(201, phone, key, "203.0.113.5").error) << "another source is not refused";
  clock.advance(61s);
  EXPECT_FALSE(auth(202, phone, key, "198.51.100.9").error) << "the window ended";
}

TEST_F(RehandPhoneAccess, WrongCodesReplaceTheCode_ThenCloseTheWindow_NothingIsSaved) {
  ASSERT_TRUE(access.open_window());
  const PhoneKey key;
  std::vector<Guess> seen;
  for (uint64_t i = 0; i < 10; ++i) {
    // Ten sources, one guess each: the window's own count closes it, not the per-source limit.
    const std::string peer = "192.0.2." + std::to_string(10 + i);
    access.connected(i, "c");
    const auto a =
        access.pair(i, peer, "000000", "x", key.public_raw(), key.sign(PhoneAccess::signed_text("c")));
    ASSERT_TRUE(a.error);
    seen.push_back(a.guess);
  }
  EXPECT_EQ(seen[2], Guess::code_replaced);
  EXPECT_EQ(seen[5], Guess::code_replaced);
  EXPECT_EQ(seen[9], Guess::window_closed);
  EXPECT_EQ(seen[0], Guess::wrong);
  EXPECT_FALSE(access.window_open());
  EXPECT_EQ(store.size(), 0u);
}

TEST_F(RehandPhoneAccess, TheRightCodeWithAKeyItDoesNotHoldPairsNothing_NorCountsAsAGuess) {
  ASSERT_TRUE(access.open_window());
  const PhoneKey key, other;
  access.connected(1, "c1");
  const auto a = access.pair(1, "192.0.2.7", access.code(), "x", key.public_raw(),
                             other.sign(PhoneAccess::signed_text("c1")));
  ASSERT_TRUE(a.error);
  EXPECT_NE(a.error.reason().find("signature does not match"), std::string::npos);
  EXPECT_EQ(store.size(), 0u);
  EXPECT_TRUE(access.window_open()) << "the owner can still pair";
  EXPECT_FALSE(pair(2, key).empty());
}

TEST_F(RehandPhoneAccess, TheCodeExpiresAfterTwoMinutes_NeverExtended) {
  ASSERT_TRUE(access.open_window());
  clock.advance(119s);
  EXPECT_FALSE(access.expire_window());
  EXPECT_EQ(access.window_left(), 1s);
  clock.advance(2s);
  EXPECT_TRUE(access.expire_window());
  EXPECT_FALSE(access.window_open());
  const PhoneKey key;
  access.connected(1, "c");
  EXPECT_TRUE(
      access.pair(1, "192.0.2.7", "111111", "x", key.public_raw(), key.sign(PhoneAccess::signed_text("c")))
          .error);
}

TEST_F(RehandPhoneAccess, AConnectionThatDoesNotAuthenticateIn5sTimesOut_OneThatDidStays) {
  const PhoneKey key;
  ASSERT_TRUE(access.open_window());
  ASSERT_FALSE(pair(1, key).empty());
  access.connected(2, "c2");
  clock.advance(5s);
  EXPECT_TRUE(access.timed_out().empty()) << "5 s exactly is still in time";
  clock.advance(1ms);
  EXPECT_EQ(access.timed_out(), std::vector<uint64_t>{2});
  EXPECT_TRUE(access.timed_out().empty()) << "named once";
  EXPECT_TRUE(access.is_in(1));
}

TEST_F(RehandPhoneAccess, APhoneUnusedFor30DaysIsForgotten_CheckedOnceAMinute) {
  const PhoneKey key;
  ASSERT_TRUE(access.open_window());
  const std::string phone = pair(1, key);
  (void)access.left(1);
  EXPECT_TRUE(access.expire_unused().empty());  // the first call checks: nothing is old
  clock.advance(std::chrono::hours(24 * 30) - 30s);
  EXPECT_TRUE(access.expire_unused().empty());  // checked: 30 s short of its age
  clock.advance(45s);
  EXPECT_TRUE(access.expire_unused().empty()) << "past its age, but checked 45 s ago: not yet";
  clock.advance(20s);
  const auto forgotten = access.expire_unused();
  ASSERT_EQ(forgotten.size(), 1u);
  EXPECT_EQ(forgotten[0].id, phone);
  EXPECT_EQ(store.phone(phone), nullptr);
}

TEST_F(RehandPhoneAccess, AContactKeepsAPhone) {
  const PhoneKey key;
  ASSERT_TRUE(access.open_window());
  const std::string phone = pair(1, key);
  clock.advance(std::chrono::hours(24 * 29));
  ASSERT_FALSE(access.touch(phone));
  clock.advance(std::chrono::hours(24 * 2));
  EXPECT_TRUE(access.expire_unused().empty());
  EXPECT_NE(store.phone(phone), nullptr);
}

}  // namespace
}  // namespace rtukit::programs
