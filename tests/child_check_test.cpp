// The check every test makes of the programs it starts (tests/process.hpp,
// ~Process): a sanitizer report in a child's output, or an unclean end of our
// own binary after SIGTERM, fails the test that started it. Each case here
// starts a child that does it on purpose and expects exactly that failure.
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "process.hpp"

using namespace rtukit::test;

namespace {

const std::string kLeaky = LEAKY_CHILD_BIN;

// Whether this build has the sanitizers (then the child, built with the same
// flags, reports for real).
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAsan = true;
#else
constexpr bool kAsan = false;
#endif

TEST(ChildCheck, ASanitizerLineInAChildsOutputFailsTheTest) {
  EXPECT_NONFATAL_FAILURE(
      {
        Process p({"/bin/sh", "-c", "echo '==7==ERROR: LeakSanitizer: detected memory leaks' >&2"});
        p.wait();
      },
      "LeakSanitizer: detected memory leaks");
}

TEST(ChildCheck, ALeakingChildFailsTheTestInASanitizerBuild) {
  if (kAsan) {
    EXPECT_NONFATAL_FAILURE(
        {
          Process p({kLeaky, "leak"});
          p.wait();
        },
        "LeakSanitizer");
  } else {
    // Without the sanitizers the leak is not seen: the same child then ends
    // clean and fails nothing (the claim holds in the sanitizer builds,
    // which run this test: the README's suite and CI's first stage).
    Process p({kLeaky, "leak"});
    EXPECT_EQ(p.wait(), 0);
    EXPECT_NE(p.output().find("leaked 4096 bytes"), std::string::npos);
  }
}

TEST(ChildCheck, UndefinedBehaviourInAChildFailsTheTestInASanitizerBuild) {
  if (kAsan) {
    EXPECT_NONFATAL_FAILURE(
        {
          Process p({kLeaky, "ub"});
          p.wait();
        },
        "runtime error");
  } else {
    Process p({kLeaky, "ub"});
    EXPECT_EQ(p.wait(), 0);
  }
}

TEST(ChildCheck, OurBinaryKilledBySigtermFailsTheTest) {
  // Our binary's name on a program that dies by SIGTERM's default action (a
  // server without its handler): the check sees the signal, not an exit.
  TempDir dir;
  const std::string fake = dir / "rtukit";
  std::filesystem::create_symlink("/bin/sleep", fake);
  EXPECT_NONFATAL_FAILURE(
      {
        Process p({fake, "60"});
        p.stop();
      },
      "ended unclean after SIGTERM: killed by signal 15");
}

TEST(ChildCheck, OurBinaryThatIgnoresSigtermFailsTheTest) {
  TempDir dir;
  const std::string fake = dir / "rtukit";
  std::filesystem::create_symlink(kLeaky, fake);
  EXPECT_NONFATAL_FAILURE(
      {
        Process p({fake, "hang"});
        ASSERT_TRUE(p.wait_for_output("ignoring SIGTERM"));
        p.stop(200ms);
      },
      "did not end within its deadline after SIGTERM");
}

TEST(ChildCheck, ACleanChildFailsNothing) {
  // The check itself must not fail a healthy child: no failure recorded.
  Process p({"/bin/sh", "-c", "echo fine"});
  EXPECT_EQ(p.wait(), 0);
  TempDir dir;
  const std::string fake = dir / "rtukit";
  std::filesystem::create_symlink("/bin/sh", fake);
  Process ours({fake, "-c", "trap 'exit 0' TERM; echo up; while :; do sleep 0.05; done"});
  ASSERT_TRUE(ours.wait_for_output("up"));
  ours.stop();
}

}  // namespace
