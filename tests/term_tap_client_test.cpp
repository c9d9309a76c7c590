// A bus tap end to end inside io: a TapClient reading a TapServer on a
// temporary socket (the header first, then whole lines, then a clear end
// when the server goes), and the tap header's format read back.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <functional>
#include <future>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "rtukit/io/asio.hpp"
#include "rtukit/term/tap_client.hpp"
#include "rtukit/term/tap_server.hpp"

namespace rtukit::term {
namespace {

using std::chrono::milliseconds;

TEST(TapHeader, FormatIsPinnedAndReadsBack) {
  // Other programs read tap files (docs/bus-tools.md): the header's text is a format.
  EXPECT_EQ(tap_header(9600, 11, 42),
            "# rtukit bus tap: start_us end_us sender(-1 stray) sent heard flags(c collision, d dropped); "
            "baud=9600 bits=11 now_us=42\n");
  const std::optional<TapHeader> h = parse_tap_header(tap_header(19200, 10, 1'700'000'000'123'456));
  ASSERT_TRUE(h);
  EXPECT_EQ(h->baud, 19200u);
  EXPECT_EQ(h->bits_per_char, 10u);
  EXPECT_EQ(h->now_us, 1'700'000'000'123'456u);
}

TEST(TapHeader, ALineWithoutRateOrBitsIsNoHeader) {
  EXPECT_FALSE(parse_tap_header("0 520 1 01 01"));
  EXPECT_FALSE(parse_tap_header("# baud=9600"));           // no bits
  EXPECT_FALSE(parse_tap_header("# xbaud=9600 bits=11"));  // a key only counts after a space
  const std::optional<TapHeader> h = parse_tap_header("# baud=9600 bits=11");
  ASSERT_TRUE(h);
  EXPECT_EQ(h->now_us, 0u);  // absent: 0
}

// A TapServer on its own io_context thread (it is not thread-safe: every
// call to it is posted there).
struct TapClientTest : ::testing::Test {
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() / ("rtukit-tap-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    path = (dir / "bus.sock").string();
    server = std::make_unique<TapServer>(*ctx, path, [] { return tap_header(9600, 11, 7); });
    const Status listening = server->listen();
    ASSERT_TRUE(listening.ok()) << listening.reason();
    thread = std::thread([this] { ctx->run(); });
  }
  void TearDown() override {
    stop_server();
    std::filesystem::remove_all(dir);
  }
  // Runs `f` on the server's thread and waits for it.
  void on_server(const std::function<void()>& f) {
    std::promise<void> done;
    asio::post(*ctx, [&] {
      f();
      done.set_value();
    });
    done.get_future().wait();
  }
  // The server goes as a killed bus does: its event loop stops and
  // everything it held, connections included, is closed.
  void stop_server() {
    if (thread.joinable()) {
      ctx->stop();
      thread.join();
    }
    server.reset();
    work.reset();
    ctx.reset();
  }
  // Reads until `n` lines have come, for at most 10 s (a generous deadline, never a sleep).
  std::vector<std::string> read_n(TapClient& c, size_t n) {
    std::vector<std::string> got;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (got.size() < n && std::chrono::steady_clock::now() < until) {
      Outcome<std::vector<std::string>> lines = c.read_lines(milliseconds(50));
      if (!lines.ok()) break;
      got.insert(got.end(), lines->begin(), lines->end());
    }
    return got;
  }

  std::unique_ptr<asio::io_context> ctx = std::make_unique<asio::io_context>();
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work{asio::make_work_guard(*ctx)};
  std::filesystem::path dir;
  std::string path;
  std::unique_ptr<TapServer> server;
  std::thread thread;
};

TEST_F(TapClientTest, HeaderFirstThenWholeLinesInOrder) {
  Outcome<std::unique_ptr<TapClient>> client = TapClient::connect(path);
  ASSERT_TRUE(client.ok()) << client.error().reason();
  // The header is made as the server accepts: once it is here, the client is served.
  const std::vector<std::string> header = read_n(**client, 1);
  ASSERT_EQ(header.size(), 1u);
  EXPECT_EQ(header[0] + "\n", tap_header(9600, 11, 7));

  // A line that arrives in two pieces comes back once, whole: the first
  // piece is given time to arrive alone (if it does not, the line is
  // simply read whole).
  on_server([this] { server->publish("0 1146 0 15 15\n1146 2292 0 "); });
  EXPECT_EQ(read_n(**client, 1), (std::vector<std::string>{"0 1146 0 15 15"}));
  Outcome<std::vector<std::string>> nothing_whole = (*client)->read_lines(milliseconds(100));
  ASSERT_TRUE(nothing_whole.ok());
  EXPECT_TRUE(nothing_whole->empty());
  on_server([this] { server->publish("03 03\n2292 3438 -1 FF 7F d\n"); });
  EXPECT_EQ(read_n(**client, 2), (std::vector<std::string>{"1146 2292 0 03 03", "2292 3438 -1 FF 7F d"}));
}

TEST_F(TapClientTest, AServerThatGoesEndsTheClientWithNotConnected) {
  Outcome<std::unique_ptr<TapClient>> client = TapClient::connect(path);
  ASSERT_TRUE(client.ok()) << client.error().reason();
  ASSERT_EQ(read_n(**client, 1).size(), 1u);
  on_server([this] { server->publish("an unfinished line"); });
  stop_server();

  Status end;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (end.ok() && std::chrono::steady_clock::now() < until) {
    Outcome<std::vector<std::string>> lines = (*client)->read_lines(milliseconds(50));
    if (!lines.ok()) {
      end = lines.error();
      continue;
    }
    EXPECT_TRUE(lines->empty()) << "an unfinished line is never returned";
  }
  EXPECT_EQ(end.code(), Errc::not_connected) << end.reason();
  EXPECT_EQ(end.reason(), "the tap's server closed the connection");
  // And stays ended.
  Outcome<std::vector<std::string>> again = (*client)->read_lines(milliseconds(0));
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code(), Errc::not_connected);
}

TEST_F(TapClientTest, ReadWithNothingSentReturnsNoLinesAfterTheTimeout) {
  Outcome<std::unique_ptr<TapClient>> client = TapClient::connect(path);
  ASSERT_TRUE(client.ok()) << client.error().reason();
  ASSERT_EQ(read_n(**client, 1).size(), 1u);
  Outcome<std::vector<std::string>> lines = (*client)->read_lines(milliseconds(1));
  ASSERT_TRUE(lines.ok()) << lines.error().reason();
  EXPECT_TRUE(lines->empty());
}

TEST(TapClient, NoServerOnThePathIsNotConnectedWithTheOsReason) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("rtukit-no-tap-" + std::to_string(::getpid()) + ".sock"))
          .string();
  Outcome<std::unique_ptr<TapClient>> client = TapClient::connect(path);
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.error().code(), Errc::not_connected);
  EXPECT_EQ(client.error().os_error(), ENOENT);
  EXPECT_EQ(client.error().reason(), path + ": " + std::strerror(ENOENT));
}

TEST(TapClient, APathTooLongForAUnixSocketIsInvalidArgument) {
  Outcome<std::unique_ptr<TapClient>> client = TapClient::connect("/tmp/" + std::string(200, 'x'));
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.error().code(), Errc::invalid_argument);
}

}  // namespace
}  // namespace rtukit::term
