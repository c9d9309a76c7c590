// What one request costs the TCP server, counted (issue 39): no heap
// allocation once a connection is up. Asio allocates every operation's
// state; its per-thread cache holds two blocks, and a connection's read,
// write and idle timer churned through three, so each request cost two
// allocations (seen: 2.0 a request with the old session, 0 with each
// operation in its connection's own memory and the idle timer armed once).
// A program of its own: it replaces the global operator new to count.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdlib>
#include <new>
#include <thread>

#include "process.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio.hpp"

namespace {
std::atomic<bool> counting{false};
std::atomic<unsigned long> allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
// What our operator new took from malloc goes back to free. Inlined into a
// caller, g++ -O2 sees free() on a pointer from "new" and warns
// (-Wmismatched-new-delete): both are ours, and they match.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

namespace rtukit {
namespace {

// One FC03 request on `fd` and its whole answer, with stack buffers only
// (the client allocates nothing while the count runs).
bool ask(int fd, uint16_t transaction) {
  const std::array<uint8_t, 12> request = {static_cast<uint8_t>(transaction >> 8),
                                           static_cast<uint8_t>(transaction),
                                           0,
                                           0,
                                           0,
                                           6,
                                           1,
                                           0x03,
                                           0,
                                           0,
                                           0,
                                           4};
  if (::send(fd, request.data(), request.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(request.size()))
    return false;
  std::array<uint8_t, 17> answer{};  // MBAP 7 + function, count, 8 bytes
  for (size_t got = 0; got < answer.size();) {
    const ssize_t n = ::recv(fd, answer.data() + got, answer.size() - got, 0);
    if (n <= 0) return false;
    got += static_cast<size_t>(n);
  }
  return answer[7] == 0x03 && answer[8] == 8;
}

TEST(ServerCost, ARequestOnAnOpenConnectionAllocatesNothing) {
  asio::io_context ctx;
  MemoryBank bank;
  SlaveEngine engine;
  ASSERT_TRUE(engine.add_unit(UnitId{1}, bank).ok());
  auto listener = SlaveListener::start(ctx, engine, *io::parse_port("tcp://127.0.0.1:0", true));
  ASSERT_TRUE(listener.ok()) << listener.error().reason();
  std::thread loop([&] { ctx.run(); });
  const int fd = test::connect_to((*listener)->tcp_port());
  ASSERT_GE(fd, 0);
  const timeval wait{10, 0};  // a bound on a lost answer, not a speed
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof wait);
  // The connection's first requests may fill caches (the session's buffers).
  for (uint16_t t = 1; t <= 50; ++t) ASSERT_TRUE(ask(fd, t));
  counting = true;
  unsigned answered = 0;
  for (uint16_t t = 51; t <= 1050; ++t) answered += ask(fd, t) ? 1 : 0;
  counting = false;
  EXPECT_EQ(answered, 1000u);
  EXPECT_EQ(allocations.load(), 0u) << "heap allocations in 1000 requests";
  ::close(fd);
  asio::post(ctx, [&] {
    listener->reset();
    ctx.stop();
  });
  loop.join();
}

}  // namespace
}  // namespace rtukit
