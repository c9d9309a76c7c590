// io's blocking readers on real descriptors: the stdin console on a pipe
// (lines reach the io_context in order; it stops while a read would block)
// and a listen-only port on a pty (bytes arrive, stamped; silence is empty).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "rtukit/io/asio.hpp"
#include "rtukit/io/listen_port.hpp"
#include "rtukit/io/now.hpp"
#include "rtukit/io/pty.hpp"
#include "rtukit/term/stdin_console.hpp"

namespace rtukit::term {
namespace {

using namespace rtukit::io;  // the transports they run on

using std::chrono::milliseconds;

struct Pipe {
  Pipe() { EXPECT_EQ(::pipe(fd), 0); }
  ~Pipe() {
    close_writer();
    ::close(fd[0]);
  }
  void write(const std::string& s) { ASSERT_EQ(::write(fd[1], s.data(), s.size()), ssize_t(s.size())); }
  void close_writer() {
    if (fd[1] >= 0) ::close(fd[1]);
    fd[1] = -1;
  }
  int fd[2] = {-1, -1};
};

TEST(StdinConsole, LinesRunOnTheIoContextInOrder) {
  asio::io_context ctx;
  Pipe in;
  std::vector<std::string> lines;
  const std::thread::id ctx_thread = std::this_thread::get_id();
  bool on_ctx_thread = true;
  StdinConsole console(
      ctx,
      [&](const std::string& line, const ConsoleReply&) {
        on_ctx_thread = on_ctx_thread && std::this_thread::get_id() == ctx_thread;
        lines.push_back(line);
        if (lines.size() == 3) ctx.stop();
      },
      in.fd[0]);
  in.write("status\nspeed ");
  in.write("50\n\nignored: no newline yet");
  // A generous deadline: a console that loses a line fails here, not by hanging.
  asio::steady_timer deadline(ctx, std::chrono::seconds(10));
  deadline.async_wait([&](const boost::system::error_code& ec) {
    if (!ec) ctx.stop();
  });
  auto work = asio::make_work_guard(ctx);
  ctx.run();
  EXPECT_EQ(lines, (std::vector<std::string>{"status", "speed 50", ""}));
  EXPECT_TRUE(on_ctx_thread);
}

TEST(StdinConsole, StopsWhileAReadWouldBlock) {
  asio::io_context ctx;
  Pipe in;  // the writer stays open: the console's thread waits for input
  const auto start = std::chrono::steady_clock::now();
  {
    StdinConsole console(
        ctx, [](const std::string&, const ConsoleReply&) {}, in.fd[0]);
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(StdinConsole, TheLastLineBeforeEndOfInputStillArrives) {
  asio::io_context ctx;
  Pipe in;
  std::vector<std::string> lines;
  StdinConsole console(
      ctx, [&](const std::string& line, const ConsoleReply&) { lines.push_back(line); }, in.fd[0]);
  in.write("quit\n");
  in.close_writer();  // end of input right behind the line
  auto work = asio::make_work_guard(ctx);
  asio::steady_timer deadline(ctx, std::chrono::seconds(10));
  deadline.async_wait([&](const boost::system::error_code&) { work.reset(); });
  while (lines.empty() && ctx.run_one() > 0) {
  }
  EXPECT_EQ(lines, (std::vector<std::string>{"quit"}));
}

struct ListenPortTest : ::testing::Test {
  void SetUp() override {
    Outcome<Pty> p = Pty::create("");
    ASSERT_TRUE(p.ok()) << p.error().reason();
    pty = std::move(*p);
  }
  Pty pty;
};

TEST_F(ListenPortTest, BytesArriveStampedAndSilenceIsEmpty) {
  Result<std::unique_ptr<ListenPort>> port = ListenPort::open(pty.path(), SerialSettings{});
  ASSERT_TRUE(port.ok()) << port.error().text();

  const uint64_t before = now_us();
  Result<ListenPort::Chunk> quiet = (*port)->read(milliseconds(1));
  ASSERT_TRUE(quiet.ok());
  EXPECT_TRUE(quiet->bytes.empty());
  EXPECT_GE(quiet->at_us, before);

  const std::vector<uint8_t> frame{0x15, 0x03, 0x00, 0x21, 0x00, 0x01, 0xD6, 0xD5};
  ASSERT_EQ(::write(pty.master_fd(), frame.data(), frame.size()), ssize_t(frame.size()));
  const uint64_t written = now_us();
  std::vector<uint8_t> got;
  uint64_t first_at = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (got.size() < frame.size() && std::chrono::steady_clock::now() < until) {
    Result<ListenPort::Chunk> c = (*port)->read(milliseconds(50));
    ASSERT_TRUE(c.ok()) << c.error().text();
    if (!c->bytes.empty() && first_at == 0) first_at = c->at_us;
    got.insert(got.end(), c->bytes.begin(), c->bytes.end());
  }
  EXPECT_EQ(got, frame);
  EXPECT_GE(first_at, written);
}

TEST_F(ListenPortTest, AChunkIsAtMostKMaxChunkBytes) {
  Result<std::unique_ptr<ListenPort>> port = ListenPort::open(pty.path(), SerialSettings{});
  ASSERT_TRUE(port.ok()) << port.error().text();
  const std::vector<uint8_t> burst(ListenPort::kMaxChunk + 100, 0x55);
  ASSERT_EQ(::write(pty.master_fd(), burst.data(), burst.size()), ssize_t(burst.size()));
  size_t total = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (total < burst.size() && std::chrono::steady_clock::now() < until) {
    Result<ListenPort::Chunk> c = (*port)->read(milliseconds(50));
    ASSERT_TRUE(c.ok()) << c.error().text();
    EXPECT_LE(c->bytes.size(), ListenPort::kMaxChunk);
    total += c->bytes.size();
  }
  EXPECT_EQ(total, burst.size());
}

TEST(ListenPort, APortThatCannotBeOpenedIsIoErrorWithTheOsError) {
  Result<std::unique_ptr<ListenPort>> port = ListenPort::open("/dev/rtukit-no-such-port", SerialSettings{});
  ASSERT_FALSE(port.ok());
  EXPECT_EQ(port.error().code(), Errc::io_error);
  EXPECT_EQ(port.error().os_error(), ENOENT);
}

}  // namespace
}  // namespace rtukit::term
