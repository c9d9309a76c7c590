// The Rehand host's pairing store on a virtual calendar: a phone unused for
// longer than the daemon's --forget-after is forgotten, and the forgetting
// survives a restart (the file is rewritten). No test here waits 30 days.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "phone_key.hpp"
#include "rtukit/base/clock.hpp"
#include "rtukit/programs/rehand_host.hpp"
#include "rtukit/web/webcrypto.hpp"

namespace rtukit {
namespace {

using namespace std::chrono_literals;
using programs::PairingStore;

class PairingExpiry : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* tmp = std::getenv("TMPDIR");
    dir_ = std::filesystem::path(tmp && *tmp ? tmp : "/tmp") /
           ("rtukit-pairing-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
    path_ = (dir_ / "pairing.json").string();
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
  std::string path_;
  ManualClock clock;
  // A phone's key (the page makes one at each pairing), as the store keeps it.
  static std::string new_key() { return web::base64url(rtukit::testing::PhoneKey().public_raw()); }
  const int64_t max_age = std::chrono::seconds(std::chrono::hours(24 * 30)).count();
};

TEST_F(PairingExpiry, AnUnusedPhoneIsForgottenAfterItsAge_AUsedOneIsKept) {
  PairingStore store(path_);
  ASSERT_FALSE(store.load(clock.unix_seconds()));
  const auto old = store.add("Anna's phone", "123456", new_key(), clock.unix_seconds());
  const auto used = store.add("Ben's phone", "654321", new_key(), clock.unix_seconds());
  ASSERT_TRUE(old && used);
  clock.advance(std::chrono::hours(24 * 20));
  ASSERT_FALSE(store.touch(*used, clock.unix_seconds()));
  // 30 days to the second: still paired.
  clock.advance(std::chrono::hours(24 * 10));
  EXPECT_TRUE(store.expire(clock.unix_seconds(), max_age).empty());
  clock.advance(1s);
  const auto gone = store.expire(clock.unix_seconds(), max_age);
  ASSERT_EQ(gone.size(), 1u);
  EXPECT_EQ(gone[0].name, "Anna's phone");
  ASSERT_EQ(store.size(), 1u);
  EXPECT_EQ(store.phones()[0].name, "Ben's phone");
  EXPECT_EQ(store.phone(*old), nullptr);
  EXPECT_NE(store.phone(*used), nullptr);
  // After a restart the forgotten phone stays forgotten.
  PairingStore again(path_);
  ASSERT_FALSE(again.load(clock.unix_seconds()));
  EXPECT_EQ(again.size(), 1u);
  EXPECT_EQ(again.phone(*old), nullptr);
  // Ben's phone goes too, 30 days after its last contact.
  clock.advance(std::chrono::hours(24 * 20));
  EXPECT_EQ(again.expire(clock.unix_seconds(), max_age).size(), 1u);
  EXPECT_EQ(again.size(), 0u);
}

TEST_F(PairingExpiry, AShorterAgeForgetsSooner) {
  PairingStore store(path_);
  ASSERT_FALSE(store.load(clock.unix_seconds()));
  ASSERT_TRUE(store.add("phone", "111111", new_key(), clock.unix_seconds()));
  clock.advance(std::chrono::hours(24) + 1s);
  EXPECT_EQ(store.expire(clock.unix_seconds(), 86'400).size(), 1u);
}

// A board without a real-time clock boots in 1970. A phone that connects
// then is recorded at the file's time (and on), not in 1970: before, its
// last contact went back to 1970 and the moment the clock was set (NTP, the
// phone's own time) it was 56 years unused and forgotten.
TEST_F(PairingExpiry, WithoutAClockAContactIsNeverRecordedBeforeTheFilesTime) {
  std::string id;
  {
    PairingStore store(path_);
    ASSERT_FALSE(store.load(clock.unix_seconds()));
    const auto added = store.add("Anna's phone", "123456", new_key(), clock.unix_seconds());
    ASSERT_TRUE(added);
    id = *added;
  }
  const int64_t paired = clock.unix_seconds();
  PairingStore store(path_);  // the board restarts, its calendar at 1970
  ASSERT_FALSE(store.load(0));
  const int64_t at_boot = store.time(0, 5);
  EXPECT_GE(at_boot, paired) << "never before what the file recorded";
  ASSERT_FALSE(store.touch(id, store.time(0, 65)));
  EXPECT_EQ(store.phone(id)->last_contact, at_boot + 60) << "the monotonic minute since";
  // The clock is set, a day after the pairing: the phone was used a minute ago.
  clock.advance(std::chrono::hours(24));
  EXPECT_TRUE(store.expire(store.time(clock.unix_seconds(), 125), max_age).empty());
  // Never set: 30 days of the board's own running time forget it all the same.
  PairingStore alone(path_);
  ASSERT_FALSE(alone.load(0));
  (void)alone.time(0, 1000);  // its monotonic origin: the daemon's start
  EXPECT_TRUE(alone.expire(alone.time(0, 1000 + max_age - 100), max_age).empty());
  EXPECT_EQ(alone.expire(alone.time(0, 1000 + max_age + 61), max_age).size(), 1U);
}

// A contact stored while the calendar was ahead (set wrong, then corrected
// back) does not keep a phone paired for years: it counts as now.
TEST_F(PairingExpiry, AContactFromACalendarThatWasAheadCountsAsNow) {
  PairingStore store(path_);
  ASSERT_FALSE(store.load(clock.unix_seconds()));
  const auto added = store.add("phone", "111111", new_key(), clock.unix_seconds());
  ASSERT_TRUE(added);
  const int64_t today = clock.unix_seconds();
  ASSERT_FALSE(store.touch(*added, today + 10LL * 365 * 86'400));  // the calendar said 10 years on
  EXPECT_TRUE(store.expire(today, max_age).empty());
  EXPECT_EQ(store.phone(*added)->last_contact, today);
  EXPECT_EQ(store.expire(today + max_age + 1, max_age).size(), 1U) << "30 days after, not 10 years";
}

// R-18: a phone paired from now on may not drive until the display's user
// allows it; that leave is saved (a restart keeps it), a Bluetooth phone's
// too, and forgetting a phone takes it away.
TEST_F(PairingExpiry, ANewPhoneDrivesOnceAllowed_TheLeaveIsSaved) {
  {
    PairingStore store(path_);
    ASSERT_FALSE(store.load(clock.unix_seconds()));
    const auto added = store.add("Anna's phone", "123456", new_key(), clock.unix_seconds());
    ASSERT_TRUE(added);
    EXPECT_FALSE(store.confirmed(*added)) << "new: not yet";
    EXPECT_FALSE(store.confirmed("ble:AA:BB:CC:DD:EE:FF"));
    ASSERT_FALSE(store.confirm(*added));
    ASSERT_FALSE(store.confirm("ble:AA:BB:CC:DD:EE:FF"));
    EXPECT_EQ(store.confirm("nobody").code(), Errc::invalid_argument);
  }
  PairingStore again(path_);  // a restart
  ASSERT_FALSE(again.load(clock.unix_seconds()));
  ASSERT_EQ(again.size(), 1U);
  EXPECT_TRUE(again.confirmed(again.phones()[0].id));
  EXPECT_TRUE(again.confirmed("ble:AA:BB:CC:DD:EE:FF"));
  ASSERT_FALSE(again.remove("ble:AA:BB:CC:DD:EE:FF"));  // its bond forgotten
  EXPECT_FALSE(again.confirmed("ble:AA:BB:CC:DD:EE:FF"));
  PairingStore third(path_);
  ASSERT_FALSE(third.load(clock.unix_seconds()));
  EXPECT_FALSE(third.confirmed("ble:AA:BB:CC:DD:EE:FF")) << "saved too";
}

// A Wi-Fi phone is its public key: it proves it is paired by signing the
// connection's challenge; the file holds nothing that drives.
TEST_F(PairingExpiry, APhoneProvesItIsPairedBySigning_TheFileHoldsNoSecret) {
  const rtukit::testing::PhoneKey key;
  const rtukit::testing::PhoneKey stranger;
  PairingStore store(path_);
  ASSERT_FALSE(store.load(clock.unix_seconds()));
  const auto id = store.add("Anna's phone", "123456", web::base64url(key.public_raw()), clock.unix_seconds());
  ASSERT_TRUE(id);
  EXPECT_TRUE(store.verify(*id, "challenge A", key.sign("challenge A")));
  EXPECT_FALSE(store.verify(*id, "challenge B", key.sign("challenge A")))
      << "a signature opens one challenge";
  EXPECT_FALSE(store.verify(*id, "challenge A", stranger.sign("challenge A"))) << "another key";
  EXPECT_FALSE(store.verify("nobody", "challenge A", key.sign("challenge A")));
  PairingStore again(path_);
  ASSERT_FALSE(again.load(clock.unix_seconds()));
  EXPECT_TRUE(again.verify(*id, "challenge C", key.sign("challenge C"))) << "the key survives a restart";
  std::ifstream f(path_);
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(web::base64url(key.public_raw())), std::string::npos);
  EXPECT_EQ(text.find("token"), std::string::npos);
}

// A file of the token formats: its Wi-Fi phones held a token a phishing
// page could take; they pair again (named, so the daemon can say which),
// and the tokens leave the disk. Its Bluetooth leaves are kept.
TEST_F(PairingExpiry, PhonesOfATokenFilePairAgain_TheirTokensLeaveTheDisk_BluetoothLeavesStay) {
  {
    std::ofstream f(path_, std::ios::trunc);
    f << R"({"format": "rtukit rehand6600 pairing 2", "phones": [{"id": "0123456789ab", "token_sha256": ")"
      << std::string(64, 'a')
      << R"(", "name": "old phone", "code": "111111", "paired_at": "", "last_contact": 1}],)"
      << R"( "bluetooth_confirmed": ["ble:AA:BB:CC:DD:EE:FF", 7, "not ble"]})";
  }
  PairingStore old(path_);
  ASSERT_FALSE(old.load(clock.unix_seconds()));
  EXPECT_EQ(old.size(), 0U);
  ASSERT_EQ(old.legacy_dropped().size(), 1U);
  EXPECT_EQ(old.legacy_dropped()[0], "old phone");
  EXPECT_TRUE(old.confirmed("ble:AA:BB:CC:DD:EE:FF"));
  ASSERT_EQ(old.bluetooth().size(), 1U);
  std::ifstream f(path_);
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.find(std::string(64, 'a')), std::string::npos) << "rewritten without the token";
  EXPECT_NE(text.find("pairing 3"), std::string::npos);
}

// A damaged entry pairs nothing: a key that is no point, or none.
TEST_F(PairingExpiry, AnEntryWithoutAValidKeyPairsNothing) {
  {
    std::ofstream f(path_, std::ios::trunc);
    f << R"({"format": "rtukit rehand6600 pairing 3", "phones": [)"
      << R"({"id": "a1", "public_key": "BAAA", "name": "bad", "confirmed": true},)"
      << R"({"id": "a2", "name": "none", "confirmed": true},)"
      << R"({"id": "a3", "public_key": ")" << new_key() << R"(", "name": "good", "confirmed": "yes"}]})";
  }
  PairingStore store(path_);
  ASSERT_FALSE(store.load(clock.unix_seconds()));
  ASSERT_EQ(store.size(), 1U);
  EXPECT_EQ(store.phones()[0].name, "good");
  EXPECT_FALSE(store.confirmed("a3")) << "a \"confirmed\" that is not true is no leave";
}

// A Bluetooth bond is a phone like a Wi-Fi one: its record starts at its
// bonding, its last contact is saved (at most once a minute: it writes ten
// times a second) and survives a restart, and 30 days unused forget it.
TEST_F(PairingExpiry, ABluetoothPhoneUnusedFor30DaysIsForgotten_ItsLastContactSurvivesARestart) {
  const std::string phone = "ble:AA:BB:CC:DD:EE:01";
  const std::string other = "ble:AA:BB:CC:DD:EE:02";
  {
    PairingStore store(path_);
    ASSERT_FALSE(store.load(clock.unix_seconds()));
    ASSERT_FALSE(store.bonded(phone, clock.unix_seconds()));
    ASSERT_FALSE(store.bonded(other, clock.unix_seconds()));
    EXPECT_FALSE(store.confirmed(phone)) << "a new bond may not drive yet (R-18)";
    const int64_t bonded_at = clock.unix_seconds();
    clock.advance(30s);
    ASSERT_FALSE(store.touch(phone, clock.unix_seconds()));
    EXPECT_EQ(store.bluetooth_phone(phone)->last_contact, bonded_at) << "not a minute yet";
    clock.advance(std::chrono::hours(24 * 20));
    ASSERT_FALSE(store.touch(phone, clock.unix_seconds()));
    EXPECT_EQ(store.bluetooth_phone(phone)->last_contact, clock.unix_seconds());
    ASSERT_FALSE(store.bonded(phone, clock.unix_seconds() + 999));
    EXPECT_EQ(store.bluetooth_phone(phone)->last_contact, clock.unix_seconds()) << "a known bond is not new";
  }
  PairingStore again(path_);  // a restart
  ASSERT_FALSE(again.load(clock.unix_seconds()));
  ASSERT_NE(again.bluetooth_phone(phone), nullptr);
  EXPECT_EQ(again.bluetooth_phone(phone)->last_contact, clock.unix_seconds());
  clock.advance(std::chrono::hours(24 * 10) + 1s);  // the other: 30 days and a second since its bonding
  const auto gone = again.expire(clock.unix_seconds(), max_age);
  ASSERT_EQ(gone.size(), 1U);
  EXPECT_EQ(gone[0].id, other);
  EXPECT_EQ(again.bluetooth_phone(other), nullptr);
  clock.advance(std::chrono::hours(24 * 20));
  ASSERT_EQ(again.expire(clock.unix_seconds(), max_age).size(), 1U);
  PairingStore third(path_);
  ASSERT_FALSE(third.load(clock.unix_seconds()));
  EXPECT_TRUE(third.bluetooth().empty()) << "forgotten, and saved";
}

}  // namespace
}  // namespace rtukit
