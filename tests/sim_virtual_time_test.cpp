// A simulator on virtual time, in process: SimHost with a ManualClock
// (SimOptions::clock) serves the Inverjet on a pty; our Master talks to it
// over the real pty, but the machine's time moves only when the test says.
// So "paused for a minute" takes no minute, and the run time it shows is
// exact, not "about": no sleep stands in for device time.
#include <gtest/gtest.h>

#include <thread>

#include "process.hpp"
#include "rtukit/base/clock.hpp"
#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/sim.hpp"
#include "rtukit/devices/profile/sim_host.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/asio.hpp"

namespace rtukit {
namespace {

using namespace std::chrono_literals;
using test::TempDir;

class InverjetOnVirtualTime : public ::testing::Test {
 protected:
  void SetUp() override {
    profile::SimOptions o;
    o.listen = *io::parse_port("pty:" + tty_, true);
    o.clock = &clock_;
    o.tick = std::chrono::milliseconds(5);
    Outcome<std::unique_ptr<profile::SimHost>> host =
        profile::SimHost::start(ctx_, inverjet::make_sim_device(), o);
    ASSERT_TRUE(host.ok()) << host.error().reason();
    host_ = std::move(*host);
    thread_ = std::thread([this] { ctx_.run(); });
    master_ = std::make_unique<Master>(io::make_link(*io::parse_port(tty_, false)),
                                       MasterOptions{.response_timeout = 1000ms});
  }
  void TearDown() override {
    master_.reset();
    asio::post(ctx_, [this] { host_.reset(); });
    ctx_.stop();
    if (thread_.joinable()) thread_.join();
    host_.reset();
  }
  uint16_t run_time(inverjet::Client& jet) {
    const auto s = jet.status();
    EXPECT_TRUE(s.ok());
    return s.ok() ? s->run_time : 0;
  }

  TempDir dir_;
  std::string tty_ = dir_ / "tty";
  ManualClock clock_;
  asio::io_context ctx_;
  std::unique_ptr<profile::SimHost> host_;
  std::thread thread_;
  std::unique_ptr<Master> master_;
};

TEST_F(InverjetOnVirtualTime, APauseFreezesTheTimer_AResumeCountsOnToTheSecond) {
  inverjet::Client jet(*master_);
  ASSERT_FALSE(jet.start_timer(50, 600));
  EXPECT_EQ(run_time(jet), 600);  // no device time has passed
  clock_.advance(10s);            // the client starts it running: no 3-s initial phase
  EXPECT_EQ(run_time(jet), 590);
  ASSERT_FALSE(jet.pause());
  clock_.advance(std::chrono::minutes(5));  // five minutes in the pool, paused
  EXPECT_EQ(run_time(jet), 590);
  ASSERT_FALSE(jet.resume());
  clock_.advance(30s);
  EXPECT_EQ(run_time(jet), 560);
  ASSERT_FALSE(jet.stop());
  EXPECT_EQ(jet.status()->state, 0);
}

TEST_F(InverjetOnVirtualTime, ATimerEndsAtItsDeviceTime_NotBefore) {
  inverjet::Client jet(*master_);
  ASSERT_FALSE(jet.start_timer(40, 60));
  clock_.advance(59s);
  EXPECT_NE(jet.status()->state_name(), "timer ended");
  EXPECT_EQ(run_time(jet), 1);
  clock_.advance(1s);
  EXPECT_EQ(jet.status()->state_name(), "timer ended");
  EXPECT_EQ(run_time(jet), 0);
}

}  // namespace
}  // namespace rtukit
