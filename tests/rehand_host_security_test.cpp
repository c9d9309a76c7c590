// Every attack on the Rehand 6600 host daemon we know of, replayed against
// `rtukit rehand6600 host` and the simulated controller
// (tests/security/rehand_host_attacks.py: TLS only on the phone listener,
// Origin and Host checks, no credential in a URL, one connection per phone,
// the dead-man's latch, connection budgets, revocation, pairing probes and
// guessing, empty fragments). Each check failed on the daemon before the
// trusted-remote work; docs/security.md says how each was closed.
#include <gtest/gtest.h>

#include <string>

#include "process.hpp"

namespace {

using namespace std::chrono_literals;

TEST(RehandHostSecurity, EveryKnownAttackIsRefused) {
  const rtukit::test::RunResult r = rtukit::test::run(
      {"/usr/bin/python3", std::string(SCRIPTS_DIR) + "/rehand_host_attacks.py", RTUKIT_BIN}, 280000ms);
  std::cout << r.output;
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("\nPASS"), std::string::npos);
  EXPECT_EQ(r.output.find("FAIL "), std::string::npos);
}

}  // namespace
