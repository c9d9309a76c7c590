// The shared web layer against clients that misbehave: a client that stops
// reading, one that floods, one that sends a huge message, one too many;
// and the assets and HTTP answers. The well-behaved client beside them must
// keep receiving its ticks on time. Clients are Boost.Beast's own.
#include <gtest/gtest.h>

#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <string>
#include <thread>

#include "rtukit/io/asio_fwd.hpp"  // rtukit::asio
#include "rtukit/web/assets.hpp"
#include "rtukit/web/server.hpp"

namespace rtukit::web {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

template <class F>
bool eventually(F f, std::chrono::milliseconds limit = 5000ms) {
  const auto end = Clock::now() + limit;
  while (Clock::now() < end) {
    if (f()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return f();
}

// A server that echoes, and ticks every 20 ms to every client ("tick N").
struct Rig {
  Rig(ServerOptions o = {}) {
    if (o.listen.empty()) o.listen = {"127.0.0.1:0"};
    Handlers h;
    h.http = [](const HttpRequest& r) -> HttpResponse {
      if (auto a = asset_response(r.path)) return *a;
      return {.status = 404, .body = R"({"error":"not found"})"};
    };
    h.opened = [this](const SocketPtr& s) { sockets.push_back(s); };
    h.closed = [this](const SocketPtr&) { ++closed; };
    h.message = [](const SocketPtr& s, std::string_view text) {
      if (text == "big") {
        for (int i = 0; i < 64; ++i) s->send(std::string(64 * 1024, 'x'));  // 4 MiB to a client
        return;
      }
      s->send(std::string(text));
    };
    server = std::make_unique<Server>(o, h);
    server->every(20, [this] {
      ++ticks;
      for (auto& s : sockets)
        if (s->is_open()) s->send("tick " + std::to_string(ticks));
    });
    EXPECT_FALSE(server->start());
    port = server->ports().at(0);
  }
  // The server's thread stops first (TSan saw its ticker read `sockets` as
  // they were freed), then the sockets go while their io_context still
  // exists (a Beast stream outliving it is a use after free), then the server.
  ~Rig() {
    server->stop();
    sockets.clear();
  }
  std::unique_ptr<Server> server;
  std::vector<SocketPtr> sockets;  // server thread only
  std::atomic<int> closed{0};
  int ticks = 0;
  uint16_t port = 0;
};

struct Client {
  explicit Client(uint16_t port, size_t read_max = 16 * 1024 * 1024) : ws(io) {
    tcp::resolver resolver(io);
    asio::connect(ws.next_layer(), resolver.resolve("127.0.0.1", std::to_string(port)));
    ws.read_message_max(read_max);
    ws.handshake("127.0.0.1:" + std::to_string(port), "/ws");  // Host must carry the port
  }
  std::string read() {
    beast::flat_buffer b;
    ws.read(b);
    return beast::buffers_to_string(b.data());
  }
  asio::io_context io;
  websocket::stream<tcp::socket> ws;
};

std::pair<unsigned, std::string> get(uint16_t port, const std::string& target) {
  asio::io_context io;
  tcp::socket s(io);
  tcp::resolver resolver(io);
  asio::connect(s, resolver.resolve("127.0.0.1", std::to_string(port)));
  http::request<http::empty_body> req(http::verb::get, target, 11);
  req.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  http::write(s, req);
  beast::flat_buffer b;
  http::response<http::string_body> res;
  http::read(s, b, res);
  return {res.result_int(), res.body()};
}

TEST(WebServer, ServesEmbeddedAssetsAnd404) {
  Rig rig;
  const auto [status, body] = get(rig.port, "/rehand/hmi.html");
  EXPECT_EQ(status, 200u);
  EXPECT_NE(body.find("<title>Rehand 6600</title>"), std::string::npos);
  EXPECT_EQ(get(rig.port, "/nothing/here").first, 404u);
  ASSERT_NE(find_asset("/rehand/phone.js"), nullptr);
  EXPECT_EQ(find_asset("/rehand/phone.js")->content_type, "text/javascript; charset=utf-8");
}

TEST(WebServer, EchoesOnItsConnection) {
  Rig rig;
  Client c(rig.port);
  c.ws.write(asio::buffer(std::string("hello")));
  std::string got;
  for (int i = 0; i < 100 && got != "hello"; ++i) got = c.read();  // ticks may come first
  EXPECT_EQ(got, "hello");
}

TEST(WebServer, AClientThatStopsReadingIsDropped_OthersKeepTheirTicks) {
  Rig rig;
  Client slow(rig.port), good(rig.port);
  slow.ws.write(asio::buffer(std::string("big")));  // 4 MiB it will never read
  // The good client reads its ticks meanwhile: no gap longer than 200 ms.
  auto last = Clock::now();
  std::chrono::milliseconds worst{0};
  const auto end = Clock::now() + 1500ms;
  while (Clock::now() < end) {
    const std::string m = good.read();
    if (m.rfind("tick", 0) != 0) continue;
    worst = std::max(worst, std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - last));
    last = Clock::now();
  }
  EXPECT_LT(worst, 200ms);
  EXPECT_TRUE(eventually([&] { return rig.closed >= 1; })) << "the slow client was not dropped";
  EXPECT_EQ(rig.server->connections(), 1u);
}

TEST(WebServer, AFloodingClientIsDropped) {
  ServerOptions o;
  o.max_messages_per_s = 50;
  Rig rig(o);
  Client flood(rig.port);
  beast::error_code ec;
  for (int i = 0; i < 500 && !ec; ++i) flood.ws.write(asio::buffer(std::string("x")), ec);
  // Reading on, the client answers the server's close frame, which says why.
  for (int i = 0; i < 2000; ++i) {
    beast::flat_buffer b;
    flood.ws.read(b, ec);
    if (ec) break;
  }
  EXPECT_EQ(ec, websocket::error::closed);
  EXPECT_EQ(std::string(flood.ws.reason().reason.c_str()), "too many messages");
  EXPECT_TRUE(eventually([&] { return rig.closed >= 1; }));
}

TEST(WebServer, AMessageOverTheLimitClosesTheConnection) {
  ServerOptions o;
  o.max_message = 1024;
  Rig rig(o);
  Client c(rig.port);
  c.ws.write(asio::buffer(std::string(4096, 'y')));
  EXPECT_TRUE(eventually([&] { return rig.closed >= 1; }));
  EXPECT_EQ(rig.server->connections(), 0u);
}

TEST(WebServer, ConnectionsOverTheLimitAreClosedAtOnce) {
  Listener l("127.0.0.1:0");
  l.max_connections = 2;
  ServerOptions o;
  o.listen = {l};
  Rig rig(o);
  Client a(rig.port), b(rig.port);
  EXPECT_TRUE(eventually([&] { return rig.server->connections() == 2; }));
  EXPECT_ANY_THROW(Client c(rig.port));  // the handshake finds a closed socket
  EXPECT_EQ(rig.server->connections(), 2u);
}

TEST(WebServer, ListenAddressesAreCheckedWithAReason) {
  ServerOptions o;
  o.listen = {"nonsense"};
  Server bad(o, {});
  const rtukit::Status e = bad.start();
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  EXPECT_NE(std::string(e.reason()).find("nonsense"), std::string::npos);
  Rig taken;
  ServerOptions same;
  same.listen = {"127.0.0.1:" + std::to_string(taken.port)};
  Server again(same, {});
  EXPECT_EQ(again.start().code(), Errc::io_error);
  EXPECT_EQ(url_of("[::1]:0", 8080), "http://[::1]:8080");
  EXPECT_TRUE(is_loopback("127.0.0.1:80"));
  EXPECT_TRUE(is_loopback("[::1]:80"));
  EXPECT_FALSE(is_loopback("0.0.0.0:80"));
}

}  // namespace
}  // namespace rtukit::web
