// The Rehand 6600 host daemon's pairing window (issue 38: the daemon's rules
// on virtual time, apart from its sockets): one window of 2 minutes that
// nothing extends, a code replaced after 3 wrong guesses, the window closed
// after 10 in all, one answer for no window, expired and wrong. The time is
// passed in; the codes come from a list.
#include <gtest/gtest.h>

#include <deque>
#include <string>

#include "rtukit/programs/pairing_window.hpp"

namespace rtukit::programs {
namespace {

using namespace std::chrono_literals;
using Guess = PairingWindow::Guess;

struct Rig {
  std::deque<std::string> codes{"111111", "222222", "333333", "444444", "555555"};
  PairingWindow window{[this] {
    if (codes.empty()) return std::string();
    std::string c = codes.front();
    codes.pop_front();
    return c;
  }};
  TimePoint t0{std::chrono::hours(1)};
};

TEST(RehandPairingWindow, TheRightCodeInTimePairs_OneAnswerForNoWindowExpiredAndWrong) {
  Rig rig;
  EXPECT_EQ(rig.window.guess("111111", rig.t0), Guess::wrong);  // no window yet: nothing counted
  ASSERT_TRUE(rig.window.open(rig.t0));
  EXPECT_EQ(rig.window.code(), "111111");
  EXPECT_EQ(rig.window.left(rig.t0 + 30s), 90s);
  EXPECT_EQ(rig.window.guess("111111", rig.t0 + 2min), Guess::right);  // its last instant still counts
  EXPECT_EQ(rig.window.guess("11111", rig.t0), Guess::wrong);          // a prefix is no code
  EXPECT_EQ(rig.window.guess("1111111", rig.t0), Guess::wrong);
  ASSERT_TRUE(rig.window.open(rig.t0));  // again: a fresh window and code, the two wrong guesses forgotten
  EXPECT_EQ(rig.window.code(), "222222");
  EXPECT_EQ(rig.window.guess("222222", rig.t0 + 2min + 1ms), Guess::wrong);  // expired, not yet closed
  EXPECT_FALSE(rig.window.expire(rig.t0 + 2min));
  EXPECT_TRUE(rig.window.expire(rig.t0 + 2min + 1ms));
  EXPECT_FALSE(rig.window.is_open());
  EXPECT_EQ(rig.window.code(), "");
  EXPECT_EQ(rig.window.left(rig.t0), 0s);
  EXPECT_EQ(rig.window.guess("222222", rig.t0 + 3min), Guess::wrong);
}

TEST(RehandPairingWindow, ACodeGuessedAtThreeTimesIsReplaced_TheWindowsEndKept) {
  Rig rig;
  ASSERT_TRUE(rig.window.open(rig.t0));
  EXPECT_EQ(rig.window.guess("000000", rig.t0 + 10s), Guess::wrong);
  EXPECT_EQ(rig.window.guess("000001", rig.t0 + 20s), Guess::wrong);
  EXPECT_EQ(rig.window.guess("000002", rig.t0 + 30s), Guess::code_replaced);
  EXPECT_EQ(rig.window.code(), "222222");
  EXPECT_EQ(rig.window.guess("111111", rig.t0 + 31s), Guess::wrong);  // the old code is gone
  EXPECT_EQ(rig.window.left(rig.t0 + 30s), 90s);                      // never a fresh 2 minutes
  EXPECT_EQ(rig.window.guess("222222", rig.t0 + 40s), Guess::right);  // the owner still pairs
}

TEST(RehandPairingWindow, TenWrongCodesInAllCloseTheWindow_OnlyOpeningItAgainHelps) {
  Rig rig;
  ASSERT_TRUE(rig.window.open(rig.t0));
  int replaced = 0;
  for (int n = 1; n <= 9; ++n) {
    const Guess g = rig.window.guess("000000", rig.t0 + n * 1s);
    ASSERT_NE(g, Guess::window_closed) << n;
    replaced += g == Guess::code_replaced ? 1 : 0;
  }
  EXPECT_EQ(replaced, 3);  // after the 3rd, 6th and 9th
  const std::string last = rig.window.code();
  EXPECT_EQ(rig.window.guess("000000", rig.t0 + 10s), Guess::window_closed);
  EXPECT_FALSE(rig.window.is_open());
  EXPECT_EQ(rig.window.guess(last, rig.t0 + 11s), Guess::wrong);  // not even the last code shown
  // The display opens it again: a fresh window, its counts from zero.
  ASSERT_TRUE(rig.window.open(rig.t0 + 20s));
  EXPECT_EQ(rig.window.left(rig.t0 + 20s), 2min);
  EXPECT_EQ(rig.window.guess("000000", rig.t0 + 21s), Guess::wrong);
  EXPECT_EQ(rig.window.guess(rig.window.code(), rig.t0 + 22s), Guess::right);
}

TEST(RehandPairingWindow, NoCodeToBeHad_TheWindowStaysClosed) {
  Rig rig;
  rig.codes = {"111111"};
  EXPECT_TRUE(rig.window.open(rig.t0));
  for (int n = 1; n <= 2; ++n) EXPECT_EQ(rig.window.guess("000000", rig.t0), Guess::wrong);
  // The third wrong guess needs a new code and there is none: closed, never the old code kept.
  EXPECT_EQ(rig.window.guess("000000", rig.t0), Guess::window_closed);
  EXPECT_FALSE(rig.window.is_open());
  EXPECT_FALSE(rig.window.open(rig.t0));
  EXPECT_FALSE(rig.window.is_open());
}

}  // namespace
}  // namespace rtukit::programs
