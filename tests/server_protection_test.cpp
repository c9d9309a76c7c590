// No client can stall a server (issue 9, section 5), and the serial-line
// turnaround (section 6). Each attack is reproduced for real: a client that
// sends and never reads, idle connections past the limit, a process out of
// file descriptors; the test then proves the other clients, the timers on
// the server's loop and SIGTERM still work.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <asio.hpp>
#include <atomic>
#include <fstream>
#include <thread>

#include "process.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/slave_server.hpp"

using namespace rtukit;
using namespace std::chrono_literals;
using test::connect_to;
using test::eventually;
using test::Process;
using test::TempDir;

namespace {

const std::string kRtukit = RTUKIT_BIN;

// A MemoryBank slave on its own thread, with a 10-ms timer on the same loop
// standing for the device models and watchdogs that share it.
class Server {
 public:
  Server(const std::string& listen, ServerOptions options) : ticker_(ctx_) {
    EXPECT_TRUE(engine_.add_unit(UnitId{1}, bank_).ok());
    auto l = SlaveListener::start(ctx_, engine_, *io::parse_port(listen, true), {}, std::move(options));
    EXPECT_TRUE(l.ok()) << l.error().reason();
    listener = std::move(*l);
    tick();
    thread_ = std::thread([this] { ctx_.run(); });
  }
  ~Server() {
    asio::post(ctx_, [this] {
      listener.reset();
      ticker_.cancel();
      ctx_.stop();
    });
    thread_.join();
  }
  uint64_t ticks() const { return ticks_; }
  ServerStats stats() {
    std::promise<ServerStats> p;
    asio::post(ctx_, [&] { p.set_value(listener->stats()); });
    return p.get_future().get();
  }
  unsigned connections() {
    std::promise<unsigned> p;
    asio::post(ctx_, [&] { p.set_value(listener->connections()); });
    return p.get_future().get();
  }

  std::unique_ptr<SlaveListener> listener;

 private:
  void tick() {
    ticker_.expires_after(10ms);
    ticker_.async_wait([this](const std::error_code& ec) {
      if (ec) return;
      ++ticks_;
      tick();
    });
  }
  asio::io_context ctx_;
  asio::steady_timer ticker_;
  MemoryBank bank_{200};
  SlaveEngine engine_;
  std::atomic<uint64_t> ticks_{0};
  std::thread thread_;
};

// The attack: ~200 KB of FC03 x125 requests in 0.3 s, never reading a byte
// of the (much larger) answers.
size_t flood_without_reading(int fd) {
  const uint8_t request[] = {0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 125};
  std::vector<uint8_t> burst;
  for (int i = 0; i < 1000; ++i) burst.insert(burst.end(), std::begin(request), std::end(request));
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
  size_t sent = 0;
  const auto until = std::chrono::steady_clock::now() + 300ms;
  while (sent < 200000 && std::chrono::steady_clock::now() < until) {
    const ssize_t n = ::send(fd, burst.data(), burst.size(), MSG_NOSIGNAL);
    if (n > 0)
      sent += static_cast<size_t>(n);
    else
      std::this_thread::sleep_for(1ms);
  }
  return sent;
}

// Reading returns 0 (closed by the server) within `within`.
bool closed_by_peer(int fd, std::chrono::milliseconds within) {
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
  return eventually(
      [&] {
        uint8_t b[4096];
        const ssize_t n = ::recv(fd, b, sizeof b, 0);
        return n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK);
      },
      within);
}

bool read_ok(const std::string& port) {
  Master m(io::make_link(*io::parse_port(port, false)), MasterOptions{.response_timeout = 500ms});
  std::array<uint16_t, 4> regs{};
  return m.read_holding_registers(UnitId{1}, 0, regs).ok();
}

// CPU seconds (user + system) a process has used.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string field;
  std::vector<std::string> fields;
  while (in >> field) fields.push_back(field);
  if (fields.size() < 15) return 0;
  return (std::stod(fields[13]) + std::stod(fields[14])) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

}  // namespace

TEST(ServerProtection, AClientThatNeverReadsStallsNobody) {
  Server server("tcp://127.0.0.1:0", ServerOptions{});
  const std::string port = server.listener->where();
  const int attacker = connect_to(server.listener->tcp_port(), 4096);
  ASSERT_GE(attacker, 0);
  const size_t sent = flood_without_reading(attacker);
  EXPECT_GT(sent, 100000u);
  const uint64_t ticks_before = server.ticks();
  // Everybody else is served, one request after another, as usual.
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(read_ok(port)) << "request " << i;
  // The loop's timers kept running (10 ms each) while the attacker sat there.
  EXPECT_TRUE(eventually([&] { return server.ticks() > ticks_before + 5; }, 2000ms));
  // And the attacker was shown the door.
  EXPECT_TRUE(eventually([&] { return server.stats().slow_closed == 1; }, 2000ms));
  ::close(attacker);
}

TEST(ServerProtection, ConnectionLimitAndIdleTimeout) {
  ServerOptions o;
  o.max_connections = 4;
  o.idle_timeout = 300ms;
  Server server("tcp://127.0.0.1:0", o);
  std::vector<int> idle;
  for (int i = 0; i < 4; ++i) idle.push_back(connect_to(server.listener->tcp_port()));
  ASSERT_TRUE(eventually([&] { return server.connections() == 4; }));
  const int fifth = connect_to(server.listener->tcp_port());
  ASSERT_GE(fifth, 0);
  EXPECT_TRUE(closed_by_peer(fifth, 1000ms));  // refused at once, not left hanging
  EXPECT_EQ(server.stats().connections_refused, 1u);
  // Silent connections are closed after the idle timeout; then there is room again.
  for (int fd : idle) EXPECT_TRUE(closed_by_peer(fd, 2000ms));
  EXPECT_EQ(server.stats().idle_closed, 4u);
  EXPECT_TRUE(read_ok(server.listener->where()));
  for (int fd : idle) ::close(fd);
  ::close(fifth);
}

TEST(ServerProtection, OutOfFileDescriptors_NoSpin_ThenServesAgain) {
  // The real process with 32 descriptors, a connection limit it cannot reach:
  // accept() fails with EMFILE while 60 connections wait.
  const uint16_t port = test::free_tcp_port();
  const std::string where = "tcp://127.0.0.1:" + std::to_string(port);
  Process slave(
      {"prlimit", "--nofile=32:32", kRtukit, "slave", "--listen", where, "--max-connections", "1000"});
  ASSERT_TRUE(slave.wait_for_output("listening on")) << slave.output();
  std::vector<int> fds;
  for (int i = 0; i < 60; ++i) fds.push_back(connect_to(port));
  std::this_thread::sleep_for(200ms);  // let it run into EMFILE
  const double before = cpu_seconds(slave.pid());
  std::this_thread::sleep_for(1000ms);
  const double used = cpu_seconds(slave.pid()) - before;
  EXPECT_LT(used, 0.2) << "the accept loop spins";  // a spin would use ~1 s
  for (int fd : fds) ::close(fd);
  EXPECT_TRUE(eventually([&] { return read_ok(where); }, 3000ms));
  ::kill(slave.pid(), SIGTERM);
  EXPECT_EQ(slave.wait(3000ms), 0) << slave.output();
}

TEST(ServerProtection, SigtermEndsTheServerWhileAClientFloodsIt) {
  const uint16_t port = test::free_tcp_port();
  Process slave({kRtukit, "slave", "--listen", "tcp://127.0.0.1:" + std::to_string(port)});
  ASSERT_TRUE(slave.wait_for_output("listening on")) << slave.output();
  const int attacker = connect_to(port, 4096);
  ASSERT_GE(attacker, 0);
  flood_without_reading(attacker);
  ::kill(slave.pid(), SIGTERM);
  EXPECT_EQ(slave.wait(3000ms), 0) << slave.output();
  ::close(attacker);
}

// The Rehand 6600's watchdog lives on the simulator's loop: while a client
// floods the simulator, a held phone drive must still be dropped when the
// host falls silent.
TEST(ServerProtection, RehandWatchdogKeepsRunningUnderAttack) {
  const uint16_t port = test::free_tcp_port();
  const std::string where = "tcp://127.0.0.1:" + std::to_string(port);
  Process sim({kRtukit, "sim", "rehand6600", "--listen", where}, /*stdin_pipe=*/true);
  ASSERT_TRUE(sim.wait_for_output("listening on")) << sim.output();
  Master host(io::make_link(*io::parse_port(where, false)), MasterOptions{.response_timeout = 500ms});
  const UnitId unit{1};
  std::array<uint16_t, 1> id{};
  ASSERT_TRUE(host.read_holding_registers(unit, 0x0000, id).ok());
  ASSERT_TRUE(host.write_single_register(unit, 0x006B, 1).ok());  // host ready
  ASSERT_TRUE(host.write_single_register(unit, 0x006E, 1).ok());  // phone forward, held
  const int attacker = connect_to(port, 4096);
  flood_without_reading(attacker);
  // The host says nothing more (the attacker is cut off after 16 KB of
  // unread answers); the console (on the same loop) keeps answering and
  // the watchdog trips, attack or not.
  EXPECT_TRUE(eventually(
      [&] {
        sim.send("status\n");
        return sim.wait_for_output("1 trip(s)", 300ms);
      },
      10000ms))  // a bound for slow (sanitizer) builds; it trips 0.5 s after the last frame
      << sim.output();
  ASSERT_TRUE(sim.send("get phone_forward\n"));
  EXPECT_TRUE(sim.wait_for_output("phone_forward = off (0)")) << sim.output();  // the drive was dropped
  ::close(attacker);
}

// Section 6: an answer on a serial line waits t3.5 (here set to 20 ms on a
// pty, whose default is to answer at once).
TEST(ServerProtection, TurnaroundBeforeTheAnswer) {
  TempDir dir;
  ServerOptions o;
  o.turnaround = 20ms;
  Server server("pty:" + (dir / "tty"), o);
  Master m(io::make_link(*io::parse_port(dir / "tty", false)), MasterOptions{.response_timeout = 500ms});
  std::array<uint16_t, 1> r{};
  ASSERT_TRUE(m.read_holding_registers(UnitId{1}, 0, r).ok());  // opened, warm
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(m.read_holding_registers(UnitId{1}, 0, r).ok());
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 20ms);
}
