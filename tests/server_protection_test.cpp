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

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <thread>

#include "process.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/driver/gateway.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/memory_link.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio.hpp"

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
    ticker_.async_wait([this](const boost::system::error_code& ec) {
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

bool read_ok(const std::string& port, std::chrono::milliseconds timeout = 500ms) {
  Master m(io::make_link(*io::parse_port(port, false)), MasterOptions{.response_timeout = timeout});
  std::array<uint16_t, 4> regs{};
  return m.read_holding_registers(UnitId{1}, 0, regs).ok();
}

// Raw Modbus TCP: requests to unit 1.
std::vector<uint8_t> fc03_request(uint16_t transaction) {
  return {static_cast<uint8_t>(transaction >> 8),
          static_cast<uint8_t>(transaction),
          0,
          0,
          0,
          6,
          1,
          3,
          0,
          0,
          0,
          4};
}
std::vector<uint8_t> fc06_request(uint16_t address, uint16_t value) {
  return {0,
          1,
          0,
          0,
          0,
          6,
          1,
          6,
          static_cast<uint8_t>(address >> 8),
          static_cast<uint8_t>(address),
          static_cast<uint8_t>(value >> 8),
          static_cast<uint8_t>(value)};
}

bool send_all(int fd, const std::vector<uint8_t>& bytes) {
  return ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size());
}

// One whole ADU (header + length), waiting up to 10 s; empty on EOF or time out.
std::vector<uint8_t> read_adu(int fd) {
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  const timeval wait{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof wait);
  const auto read_exactly = [&](uint8_t* p, size_t n) {
    for (size_t got = 0; got < n;) {
      const ssize_t r = ::recv(fd, p + got, n - got, 0);
      if (r <= 0) return false;
      got += static_cast<size_t>(r);
    }
    return true;
  };
  std::vector<uint8_t> adu(7);
  if (!read_exactly(adu.data(), 7)) return {};
  const size_t length = (size_t{adu[4]} << 8) | adu[5];
  if (length < 2) return {};
  adu.resize(6 + length);
  if (!read_exactly(adu.data() + 7, length - 1)) return {};
  return adu;
}

// Leaves `partial` on the connection as the start of a request, known to
// have reached the server: it goes in one send() (one segment, read at once)
// behind a whole request, whose answer is then read.
bool send_partial_request(int fd, const std::vector<uint8_t>& partial) {
  std::vector<uint8_t> bytes = fc03_request(99);
  bytes.insert(bytes.end(), partial.begin(), partial.end());
  return send_all(fd, bytes) && read_adu(fd).size() == 9u + 2 * 4;
}

// Not closed by the server: nothing to read, no EOF.
bool still_open(int fd) {
  uint8_t b[256];
  const ssize_t n = ::recv(fd, b, sizeof b, MSG_DONTWAIT);
  return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
}

// A gateway (in process) in front of a bus whose device answers only when
// the test releases it: a request stays in flight for as long as needed.
class GatewayOnHeldBus {
 public:
  explicit GatewayOnHeldBus(unsigned max_connections, bool hold = true)
      : hold_(hold),
        bus_(std::make_unique<MemoryLink>(
                 clock_, [this](std::span<const uint8_t> request) { return answer(request); }),
             MasterOptions{.response_timeout = 30000ms}) {
    EXPECT_TRUE(engine_.add_unit(UnitId{1}, bank_).ok());
    GatewayOptions o;
    o.server.max_connections = max_connections;
    const io::PortSpec listen = *io::parse_port("tcp://127.0.0.1:0", true);
    auto g = Gateway::start(ctx_, bus_, std::span<const io::PortSpec>(&listen, 1), o);
    EXPECT_TRUE(g.ok()) << g.error().reason();
    gateway_ = std::move(*g);
    thread_ = std::thread([this] {
      auto work = asio::make_work_guard(ctx_);
      ctx_.run();
    });
  }
  ~GatewayOnHeldBus() {
    release();
    asio::post(ctx_, [this] {
      gateway_.reset();
      ctx_.stop();
    });
    thread_.join();
  }
  uint16_t port() const { return gateway_->tcp_port(); }
  uint64_t requests() { return gateway_->stats().requests; }
  // Requests that reached the device and wait there.
  bool wait_until_held(unsigned n) {
    std::unique_lock lock(mutex_);
    return cv_.wait_for(lock, 10s, [&] { return held_ >= n; });
  }
  void release() {
    std::lock_guard lock(mutex_);
    hold_ = false;
    cv_.notify_all();
  }
  uint16_t holding(size_t address) {
    std::lock_guard lock(mutex_);
    return bank_.holding[address];
  }

 private:
  MemoryLink::Reply answer(std::span<const uint8_t> request) {
    std::unique_lock lock(mutex_);
    ++held_;
    cv_.notify_all();
    cv_.wait_for(lock, 20s, [&] { return !hold_; });
    std::array<uint8_t, kMaxRtuAduSize> tx{};
    const auto [n, bank] = engine_.handle_rtu(request, tx);
    return {{tx.begin(), tx.begin() + static_cast<std::ptrdiff_t>(n)}, 100us};
  }

  asio::io_context ctx_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool hold_;
  unsigned held_ = 0;
  MemoryBank bank_{200};
  SlaveEngine engine_;
  SteadyClock clock_;
  Master bus_;
  std::unique_ptr<Gateway> gateway_;
  std::thread thread_;
};

// CPU seconds (user + system) a process has used.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string field;
  std::vector<std::string> fields;
  while (in >> field) fields.push_back(field);
  if (fields.size() < 15) return 0;
  return (std::stod(fields[13]) + std::stod(fields[14])) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

/// How many descriptors process `pid` has open (its /proc/PID/fd entries).
size_t open_descriptors(pid_t pid) {
  std::error_code ec;
  size_t n = 0;
  for (auto it = std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
    ++n;
  return n;
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

TEST(ServerProtection, IdleTimeout) {
  ServerOptions o;
  o.max_connections = 4;
  o.idle_timeout = 300ms;
  Server server("tcp://127.0.0.1:0", o);
  std::vector<int> idle;
  for (int i = 0; i < 4; ++i) idle.push_back(connect_to(server.listener->tcp_port()));
  ASSERT_TRUE(eventually([&] { return server.connections() == 4; }));
  // Silent connections are closed after the idle timeout.
  for (int fd : idle) EXPECT_TRUE(closed_by_peer(fd, 2000ms));
  EXPECT_EQ(server.stats().idle_closed, 4u);
  EXPECT_TRUE(read_ok(server.listener->where()));
  for (int fd : idle) ::close(fd);
}

// Issue 28, item 1 (a): a full server closes the connection idle longest to
// admit a new one (the Modbus TCP implementation guide's rule). Before, N
// idle connections locked every new client out until their idle timeout.
TEST(ServerProtection, TheOldestIdleConnectionMakesRoom) {
  ServerOptions o;
  o.max_connections = 8;  // idle_timeout stays 60 s: nothing here may wait for it
  Server server("tcp://127.0.0.1:0", o);
  std::vector<int> idle;
  for (unsigned i = 0; i < 8; ++i) {
    idle.push_back(connect_to(server.listener->tcp_port()));
    ASSERT_TRUE(eventually([&] { return server.connections() == i + 1; }));  // accepted in this order
  }
  // One that has been served is idle too, and now the most recent.
  ASSERT_TRUE(send_all(idle[1], fc03_request(7)));
  ASSERT_EQ(read_adu(idle[1]).size(), 9u + 2 * 4);
  const auto t0 = std::chrono::steady_clock::now();
  const int good = connect_to(server.listener->tcp_port());
  ASSERT_TRUE(send_all(good, fc03_request(8)));
  EXPECT_EQ(read_adu(good).size(), 9u + 2 * 4);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 10s);  // far from the 60-s idle timeout
  EXPECT_TRUE(closed_by_peer(idle[0], 2000ms));           // the oldest idle one made room
  for (size_t i = 1; i < idle.size(); ++i) EXPECT_TRUE(still_open(idle[i])) << i;
  ServerStats stats = server.stats();
  EXPECT_EQ(stats.idle_evicted, 1u);
  EXPECT_EQ(stats.connections_refused, 0u);
  // The next newcomer takes the slot of the next oldest idle: idle[2] (idle[1] was served since).
  const int next = connect_to(server.listener->tcp_port());
  ASSERT_TRUE(send_all(next, fc03_request(9)));
  EXPECT_EQ(read_adu(next).size(), 9u + 2 * 4);
  EXPECT_TRUE(closed_by_peer(idle[2], 2000ms));
  EXPECT_TRUE(still_open(idle[1]));
  EXPECT_TRUE(still_open(good));
  stats = server.stats();
  EXPECT_EQ(stats.idle_evicted, 2u);
  EXPECT_EQ(stats.connections_refused, 0u);
  for (int fd : idle) ::close(fd);
  ::close(good);
  ::close(next);
}

// When no connection is idle (each holds a partial request) a newcomer is
// refused at once, as before.
TEST(ServerProtection, RefusedWhenNoConnectionIsIdle) {
  ServerOptions o;
  o.max_connections = 4;
  Server server("tcp://127.0.0.1:0", o);
  std::vector<int> busy;
  for (unsigned i = 0; i < 4; ++i) {
    busy.push_back(connect_to(server.listener->tcp_port()));
    ASSERT_TRUE(send_partial_request(busy.back(), {0, 1, 0}));  // 3 bytes of a header
  }
  const int fifth = connect_to(server.listener->tcp_port());
  ASSERT_GE(fifth, 0);
  EXPECT_TRUE(closed_by_peer(fifth, 2000ms));  // refused at once, not left hanging
  EXPECT_EQ(server.stats().connections_refused, 1u);
  for (int fd : busy) EXPECT_TRUE(still_open(fd));
  for (int fd : busy) ::close(fd);
  ::close(fifth);
}

// Issue 28, item 1 (b): slowloris. N clients send a request one byte a
// second; each is closed when its request is not whole request_timeout after
// its first byte, and a good client is served. Before, each byte re-armed the
// 60-s idle timeout: the slots stayed taken and the good client was refused.
TEST(ServerProtection, SlowlorisIsClosedAtTheRequestDeadline) {
  ServerOptions o;
  o.max_connections = 8;
  o.request_timeout = 2000ms;
  Server server("tcp://127.0.0.1:0", o);
  std::vector<int> slow;
  // An FC10 of 123 registers: 260 bytes, 260 s at this pace. Its first byte
  // goes with a whole request, so it is known to be there before the good
  // client comes (none of the slow ones is idle, none may be taken for it).
  const std::vector<uint8_t> frame = {0, 1, 0, 0, 0, 254, 1, 0x10, 0, 0, 0, 123, 246};
  const auto t0 = std::chrono::steady_clock::now();
  for (unsigned i = 0; i < 8; ++i) {
    slow.push_back(connect_to(server.listener->tcp_port()));
    ASSERT_TRUE(send_partial_request(slow.back(), {frame[0]}));
  }
  std::atomic<bool> stop{false};
  std::thread loris([&] {
    for (size_t i = 1; !stop; ++i) {
      for (int t = 0; t < 100 && !stop; ++t) std::this_thread::sleep_for(10ms);
      for (int fd : slow) ::send(fd, &frame[i % frame.size()], 1, MSG_NOSIGNAL | MSG_DONTWAIT);
    }
  });
  // The good client gets in once the slow ones are gone: deadline + a generous margin.
  EXPECT_TRUE(eventually([&] { return read_ok(server.listener->where(), 1000ms); }, 2000ms + 8000ms));
  for (int fd : slow) EXPECT_TRUE(closed_by_peer(fd, 2000ms + 8000ms));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2000ms + 10000ms);
  EXPECT_EQ(server.stats().request_timeouts, 8u);
  EXPECT_EQ(server.stats().idle_evicted, 0u);
  stop = true;
  loris.join();
  for (int fd : slow) ::close(fd);
}

// Issue 39: one address trickling requests on 100 connections (a header a
// byte at a time: each connection stays "receiving", never idle) took every
// slot; a fresh, well-behaved client from another address lost 3 of its 6
// requests. Now an address holds at most its share (max_per_source, 16 by
// default): the rest of its connections are refused at once, and the client
// is served every time, with nothing evicted.
TEST(ServerProtection, OneAddressCannotTakeEveryConnection) {
  Server server("tcp://127.0.0.1:0", ServerOptions{});
  const uint16_t port = server.listener->tcp_port();
  std::vector<int> attacker;
  unsigned admitted = 0;
  for (int i = 0; i < 100; ++i) {
    const int fd = connect_to(port, 0, "127.0.0.2");
    ASSERT_GE(fd, 0);
    attacker.push_back(fd);
    admitted += send_partial_request(fd, {0}) ? 1 : 0;  // refused ones are closed: no answer
  }
  EXPECT_EQ(admitted, ServerOptions{}.max_per_source);
  EXPECT_EQ(server.stats().connections_refused, 100u - ServerOptions{}.max_per_source);
  for (int request = 0; request < 6; ++request)
    EXPECT_TRUE(read_ok(server.listener->where())) << "request " << request;  // from 127.0.0.1
  EXPECT_EQ(server.stats().share_evicted, 0u);
  EXPECT_EQ(server.stats().idle_evicted, 0u);
  for (int fd : attacker) ::close(fd);
}

// With a few addresses the attacker can fill the table within each share;
// then a newcomer from an address with fewer connections takes the place of
// the least active connection of the address holding the most. An address
// never evicts one holding as many as it would, so the attacker's addresses
// cannot take each other's places beyond an even share.
TEST(ServerProtection, AFewAddressesCannotStarveAnother) {
  ServerOptions o;
  o.max_connections = 8;
  o.max_per_source = 4;
  Server server("tcp://127.0.0.1:0", o);
  const uint16_t port = server.listener->tcp_port();
  const char* sources[] = {"127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"};
  std::vector<int> attacker;
  for (int round = 0; round < 2; ++round)
    for (const char* source : sources) {
      attacker.push_back(connect_to(port, 0, source));
      ASSERT_TRUE(send_partial_request(attacker.back(), {0, 1})) << source;
    }
  ASSERT_EQ(server.connections(), 8u);
  // The newcomer (127.0.0.1, holding none): served, in place of the first
  // connection of an address holding two (the least active).
  EXPECT_TRUE(read_ok(server.listener->where()));
  EXPECT_EQ(server.stats().share_evicted, 1u);
  EXPECT_TRUE(closed_by_peer(attacker[0], 2000ms));
  ASSERT_TRUE(eventually([&] { return server.connections() == 7u; }, 5000ms));  // the newcomer has gone
  // A free place goes to whoever asks within its share: 127.0.0.3 now holds
  // three (127.0.0.2 one, the others two). Full again, nothing idle:
  const int more = connect_to(port, 0, "127.0.0.3");
  ASSERT_TRUE(send_partial_request(more, {0, 1}));
  const auto refused = [&](const char* source) {
    const int fd = connect_to(port, 0, source);
    const bool closed = closed_by_peer(fd, 2000ms);
    ::close(fd);
    return closed;
  };
  EXPECT_TRUE(refused("127.0.0.4")) << "it would hold three, as many as the largest";
  EXPECT_TRUE(refused("127.0.0.3")) << "an address never evicts itself";
  EXPECT_EQ(server.stats().share_evicted, 1u);
  // 127.0.0.2 (one) takes the place of 127.0.0.3's least active connection.
  const int back = connect_to(port, 0, "127.0.0.2");
  EXPECT_TRUE(send_partial_request(back, {0, 1}));
  EXPECT_EQ(server.stats().share_evicted, 2u);
  EXPECT_TRUE(closed_by_peer(attacker[1], 2000ms));
  for (size_t i = 2; i < attacker.size(); ++i) EXPECT_TRUE(still_open(attacker[i])) << i;
  EXPECT_TRUE(still_open(more));
  ::close(back);
  for (int fd : attacker) ::close(fd);
  ::close(more);
}

// Issue 28, item 1 (c): a connection whose request is on the bus (a gateway
// in front of a device that has not answered yet) is never the one closed
// to make room, even though it is the oldest; and when every connection has
// a request in flight, a newcomer is refused.
TEST(ServerProtection, ARequestInFlightIsNeverClosedToMakeRoom) {
  GatewayOnHeldBus gw(4);
  const int waiting = connect_to(gw.port());
  ASSERT_TRUE(send_all(waiting, fc03_request(1)));
  ASSERT_TRUE(gw.wait_until_held(1));  // on the bus, not answered
  std::vector<int> idle;
  for (int i = 0; i < 3; ++i) idle.push_back(connect_to(gw.port()));
  // Accepted in the order they connected (the listen backlog is FIFO), so
  // the newcomer comes after the three.
  const int newcomer = connect_to(gw.port());
  ASSERT_TRUE(send_all(newcomer, fc03_request(2)));
  EXPECT_TRUE(closed_by_peer(idle[0], 5000ms));  // the oldest idle one, not `waiting`
  EXPECT_TRUE(still_open(waiting));
  EXPECT_TRUE(still_open(idle[1]));
  gw.release();
  EXPECT_EQ(read_adu(waiting).size(), 9u + 2 * 4);   // its answer came
  EXPECT_EQ(read_adu(newcomer).size(), 9u + 2 * 4);  // and the newcomer's
  for (int fd : idle) ::close(fd);
  ::close(waiting);
  ::close(newcomer);
}

TEST(ServerProtection, EveryConnectionInFlight_NewcomerRefused) {
  GatewayOnHeldBus gw(3);
  std::vector<int> busy;
  for (uint16_t i = 0; i < 3; ++i) {
    busy.push_back(connect_to(gw.port()));
    ASSERT_TRUE(send_all(busy.back(), fc03_request(i)));
  }
  ASSERT_TRUE(gw.wait_until_held(1));
  ASSERT_TRUE(eventually([&] { return gw.requests() == 3; }));  // two queued behind the first
  const int newcomer = connect_to(gw.port());
  EXPECT_TRUE(closed_by_peer(newcomer, 2000ms));
  for (int fd : busy) EXPECT_TRUE(still_open(fd));
  gw.release();
  for (int fd : busy) EXPECT_EQ(read_adu(fd).size(), 9u + 2 * 4);
  for (int fd : busy) ::close(fd);
  ::close(newcomer);
}

// Issue 28, item 2: a write followed in the same segment by an impossible
// MBAP header. The write ran; its answer must reach the client before the
// connection closes. Before, the answer was dropped with the connection.
TEST(ServerProtection, AnExecutedWriteIsConfirmedBeforeAnOutOfStepClose) {
  Server server("tcp://127.0.0.1:0", ServerOptions{});
  const std::vector<std::vector<uint8_t>> garbage = {
      {0, 2, 0, 1, 0, 6, 1, 3, 0, 0, 0, 1},  // protocol id 1
      {0, 2, 0, 0, 0xFF, 0xFF, 1},           // length out of range
      {0, 2, 0, 0, 0, 1, 1},                 // length under 2
  };
  uint16_t value = 0x1230;
  for (const auto& bad : garbage) {
    ++value;
    std::vector<uint8_t> bytes = fc06_request(5, value);
    const std::vector<uint8_t> echo = bytes;
    bytes.insert(bytes.end(), bad.begin(), bad.end());
    const int fd = connect_to(server.listener->tcp_port());
    ASSERT_TRUE(send_all(fd, bytes));  // one write(): one segment
    EXPECT_EQ(read_adu(fd), echo);
    EXPECT_TRUE(closed_by_peer(fd, 2000ms));
    ::close(fd);
    Master m(io::make_link(*io::parse_port(server.listener->where(), false)),
             MasterOptions{.response_timeout = 2000ms});
    std::array<uint16_t, 1> r{};
    ASSERT_TRUE(m.read_holding_registers(UnitId{1}, 5, r).ok());
    EXPECT_EQ(r[0], value);
  }
}

// The same through the gateway: the write goes to the bus after the bad
// header has been seen; its answer still comes before the close.
TEST(ServerProtection, GatewayConfirmsAWriteBeforeAnOutOfStepClose) {
  GatewayOnHeldBus gw(4, /*hold=*/false);
  std::vector<uint8_t> bytes = fc06_request(5, 0x4321);
  const std::vector<uint8_t> echo = bytes;
  bytes.insert(bytes.end(), {0, 2, 0, 1, 0, 6, 1, 3, 0, 0, 0, 1});
  const int fd = connect_to(gw.port());
  ASSERT_TRUE(send_all(fd, bytes));
  EXPECT_EQ(read_adu(fd), echo);
  EXPECT_TRUE(closed_by_peer(fd, 2000ms));
  EXPECT_EQ(gw.holding(5), 0x4321);
  ::close(fd);
}

TEST(ServerProtection, OutOfFileDescriptors_NoSpin_ThenServesAgain) {
#if defined(__SANITIZE_ADDRESS__)
  // The ASan build is ASan + UBSan. UBSan's vptr check tests memory with a
  // pipe; out of descriptors that fails, and it reports a false "invalid
  // vptr" in Boost.System, which reads its category while it constructs the
  // EMFILE error_code (inside Boost.Asio's accept, before our code runs).
  // No UBSAN_OPTIONS suppression reaches that check. The default, busy and
  // TSan suites run this test.
  GTEST_SKIP() << "UBSan's vptr check cannot run without a free descriptor";
#endif
  // The real process with 32 descriptors, a connection limit it cannot reach:
  // accept() fails with EMFILE while 60 connections wait.
  const uint16_t port = test::free_tcp_port();
  const std::string where = "tcp://127.0.0.1:" + std::to_string(port);
  Process slave({"prlimit", "--nofile=32:32", kRtukit, "slave", "--listen", where, "--max-connections",
                 "1000", "--max-per-source", "0"});  // all 60 from one address
  ASSERT_TRUE(slave.wait_for_output("listening on")) << slave.output();
  std::vector<int> fds;
  for (int i = 0; i < 60; ++i) fds.push_back(connect_to(port));
  // The event, not a sleep: every one of its 32 descriptors in use, so the
  // next accept() fails with EMFILE (and keeps failing while 60 wait).
  ASSERT_TRUE(eventually([&] { return open_descriptors(slave.pid()) >= 32; }, 10000ms))
      << open_descriptors(slave.pid()) << " descriptors open";
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
