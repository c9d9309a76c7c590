// The shared web layer's protections, each against the attack it stops: a
// page on another site (Origin), DNS rebinding (Host), a flood of idle
// connections on one listener, many connections from one address, a client
// that trickles its request (slowloris), an endless message of empty
// fragments, a ping flood; and the TLS listener with its self-signed
// certificate. Clients are Boost.Beast's and raw sockets bound to distinct
// loopback addresses (all of 127.0.0.0/8 is this machine on Linux).
// Deadlines are generous and every wait ends on an event.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <openssl/ssl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "rtukit/io/asio_fwd.hpp"  // rtukit::asio
#include "rtukit/web/server.hpp"
#include "rtukit/web/tls.hpp"

namespace rtukit::web {
namespace {

namespace ssl = asio::ssl;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using Response = http::response<http::string_body>;

template <class F>
bool eventually(F f, std::chrono::milliseconds limit = 5000ms) {
  const auto end = Clock::now() + limit;
  while (Clock::now() < end) {
    if (f()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return f();
}

// A server with one HTTP answer that shows what the handler saw, and an echo
// on its WebSockets.
struct Rig {
  explicit Rig(std::vector<Listener> listeners, ServerOptions o = {}) {
    o.listen = std::move(listeners);
    Handlers h;
    h.http = [](const HttpRequest& r) -> HttpResponse {
      if (r.path != "/echo") return {.status = 404, .body = R"({"error":"not found"})"};
      return {.content_type = "text/plain",
              .body = r.host + "|" + r.origin + "|" + r.cookie + "|" + (r.secure ? "secure" : "plain"),
              .headers = {{"Set-Cookie", "sid=1; HttpOnly"}, {"X-Smuggled", "a\r\nInjected: 1"}}};
    };
    h.opened = [this](const SocketPtr& s) {
      std::lock_guard lock(mutex);
      peer_address = s->peer_address();
      ++opened;
    };
    h.message = [](const SocketPtr& s, std::string_view text) { s->send(std::string(text)); };
    h.closed = [this](const SocketPtr&) { ++closed; };
    server = std::make_unique<Server>(o, h);
    const rtukit::Status e = server->start();
    EXPECT_FALSE(e) << e.reason();
    ports = server->ports();
  }
  ~Rig() { server->stop(); }
  std::string peer() {
    std::lock_guard lock(mutex);
    return peer_address;
  }
  std::unique_ptr<Server> server;
  std::vector<uint16_t> ports;
  std::atomic<int> opened{0}, closed{0};
  std::mutex mutex;
  std::string peer_address;
};

std::string here(uint16_t port) {
  return "127.0.0.1:" + std::to_string(port);
}

// A TCP connection from `source` (any 127.0.0.x) to 127.0.0.1:port.
tcp::socket connect_from(asio::io_context& io, const std::string& source, uint16_t port) {
  tcp::socket s(io);
  s.open(tcp::v4());
  s.bind(tcp::endpoint(asio::ip::make_address(source), 0));
  s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  return s;
}

// True when the server ends the connection (EOF or reset) within `limit`.
bool closed_within(tcp::socket& s, std::chrono::milliseconds limit) {
  const auto end = Clock::now() + limit;
  char buf[4096];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
    if (left <= 0) return false;
    pollfd p{s.native_handle(), POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
    beast::error_code ec;
    s.read_some(asio::buffer(buf), ec);
    if (ec) return true;
  }
}

// Still open: nothing to read (an idle server-side session sends nothing).
bool still_open(tcp::socket& s) {
  pollfd p{s.native_handle(), POLLIN, 0};
  return ::poll(&p, 1, 0) == 0;
}

struct Ask {
  std::string target = "/echo";
  std::optional<std::string> host;  ///< default: 127.0.0.1:PORT; "" sends none
  std::optional<std::string> origin;
  std::string source = "127.0.0.1";
  bool upgrade = false;
  std::string cookie;
};

http::request<http::string_body> request_of(uint16_t port, const Ask& a) {
  http::request<http::string_body> req(http::verb::get, a.target, 11);
  const std::string host = a.host.value_or(here(port));
  if (!host.empty()) req.set(http::field::host, host);
  if (a.origin) req.set(http::field::origin, *a.origin);
  if (!a.cookie.empty()) req.set(http::field::cookie, a.cookie);
  if (a.upgrade) {
    req.set(http::field::upgrade, "websocket");
    req.set(http::field::connection, "Upgrade");
    req.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
    req.set(http::field::sec_websocket_version, "13");
  }
  return req;
}

// One request on a new plain connection; a 101 is read as its header.
Response ask(uint16_t port, const Ask& a = {}) {
  asio::io_context io;
  tcp::socket s = connect_from(io, a.source, port);
  http::write(s, request_of(port, a));
  beast::flat_buffer b;
  Response res;
  http::read(s, b, res);
  return res;
}

void expect_security_headers(const Response& r, const std::string& what) {
  EXPECT_EQ(r["Content-Security-Policy"], "default-src 'self'; frame-ancestors 'none'") << what;
  EXPECT_EQ(r["X-Content-Type-Options"], "nosniff") << what;
  EXPECT_EQ(r["Referrer-Policy"], "no-referrer") << what;
}

// ------------------------------------------------------------ Origin and Host

TEST(WebSecurity, AForeignOriginIsRefusedOnGetAndOnUpgrade) {
  Rig rig({"127.0.0.1:0"});
  const uint16_t port = rig.ports[0];
  for (const std::string& origin : std::vector<std::string>{
           "http://evil.example", "null", "https://" + here(port), "http://" + here(port) + ".evil.example",
           "http://127.0.0.1:" + std::to_string(port + 1)}) {
    const Response get = ask(port, {.origin = origin});
    EXPECT_EQ(get.result_int(), 403u) << origin;
    EXPECT_EQ(get.body(), "Origin not allowed\n") << origin;
    const Response up = ask(port, {.target = "/ws", .origin = origin, .upgrade = true});
    EXPECT_EQ(up.result_int(), 403u) << origin;
  }
  // A browser's WebSocket from another site's page: Beast's client with that Origin.
  asio::io_context io;
  websocket::stream<tcp::socket> ws(io);
  ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  ws.set_option(websocket::stream_base::decorator(
      [](websocket::request_type& r) { r.set(http::field::origin, "http://evil.example"); }));
  beast::error_code ec;
  ws.handshake(here(port), "/ws", ec);
  EXPECT_EQ(ec, websocket::error::upgrade_declined);
  EXPECT_EQ(rig.opened, 0);
}

TEST(WebSecurity, ARebindingHostIsRefused) {
  Rig rig({"127.0.0.1:0"});
  const uint16_t port = rig.ports[0];
  const std::string p = std::to_string(port);
  for (const std::string& host :
       std::vector<std::string>{"evil.example:" + p, "evil.example", "127.0.0.1:" + std::to_string(port + 1),
                                "127.0.0.1", "localhost.evil.example:" + p, "127.0.0.1.evil.example:" + p,
                                "::1:" + p, "[::1]x" + p, "[::1", "127.0.0.1:" + p + "x", std::string()}) {
    const Response get = ask(port, {.host = host});
    EXPECT_EQ(get.result_int(), 403u) << "Host: " << host;
    EXPECT_EQ(get.body(), "Host not allowed\n") << host;
    // The page a rebinding attack runs is same-origin with its own name: the Origin matches, the Host does
    // not.
    const Response up =
        ask(port, {.target = "/ws", .host = host, .origin = "http://" + host, .upgrade = true});
    EXPECT_EQ(up.result_int(), 403u) << "Host: " << host;
  }
  EXPECT_EQ(rig.opened, 0);
}

TEST(WebSecurity, SameOriginAndNoOriginAreAccepted) {
  Listener named("127.0.0.1:0");
  named.host_names = {"chair.local"};
  Rig rig({named});
  const uint16_t port = rig.ports[0];
  const std::string p = std::to_string(port);
  // No Origin: not a browser, nothing a web page can steer.
  Response r = ask(port, {.cookie = "sid=abc; theme=dark"});
  EXPECT_EQ(r.result_int(), 200u);
  EXPECT_EQ(r.body(), here(port) + "||sid=abc; theme=dark|plain");
  // The page's own origin, by IP literal, localhost (a loopback listener) or a configured name.
  for (const std::string& host :
       std::vector<std::string>{here(port), "localhost:" + p, "LocalHost:" + p, "[::1]:" + p,
                                "chair.local:" + p, "CHAIR.local:" + p}) {
    r = ask(port, {.host = host, .origin = "http://" + host});
    EXPECT_EQ(r.result_int(), 200u) << host;
    EXPECT_EQ(r.body(), host + "|http://" + host + "||plain");
    EXPECT_EQ(
        ask(port, {.target = "/ws", .host = host, .origin = "http://" + host, .upgrade = true}).result_int(),
        101u)
        << host;
  }
  // And a real WebSocket from the page's origin carries messages.
  asio::io_context io;
  websocket::stream<tcp::socket> ws(io);
  ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  ws.set_option(websocket::stream_base::decorator(
      [port](websocket::request_type& req) { req.set(http::field::origin, "http://" + here(port)); }));
  ws.handshake(here(port), "/ws");
  ws.write(asio::buffer(std::string("hello")));
  beast::flat_buffer b;
  ws.read(b);
  EXPECT_EQ(beast::buffers_to_string(b.data()), "hello");
  EXPECT_EQ(rig.peer(), "127.0.0.1");
}

TEST(WebSecurity, LocalhostIsRefusedOnANonLoopbackListener) {
  // 0.0.0.0 is reachable from the LAN: "localhost" there is a name the attacker's DNS can answer.
  Rig rig({"0.0.0.0:0"});
  const uint16_t port = rig.ports[0];
  EXPECT_EQ(ask(port, {.host = "localhost:" + std::to_string(port)}).result_int(), 403u);
  EXPECT_EQ(ask(port, {.host = here(port)}).result_int(), 200u);
}

TEST(WebSecurity, EveryResponseCarriesTheSecurityHeaders) {
  Rig rig({"127.0.0.1:0"});
  const uint16_t port = rig.ports[0];
  const Response ok = ask(port);
  expect_security_headers(ok, "200");
  EXPECT_EQ(ok["Cache-Control"], "no-store");
  EXPECT_EQ(ok["Set-Cookie"], "sid=1; HttpOnly");  // the handler's own header
  EXPECT_EQ(ok.find("X-Smuggled"), ok.end());      // a line break in a field: dropped
  EXPECT_EQ(ok.find("Injected"), ok.end());
  expect_security_headers(ask(port, {.target = "/nothing"}), "404");
  expect_security_headers(ask(port, {.host = "evil.example"}), "403 Host");
  expect_security_headers(ask(port, {.origin = "http://evil.example"}), "403 Origin");
  const Response up = ask(port, {.target = "/ws", .upgrade = true});
  EXPECT_EQ(up.result_int(), 101u);
  expect_security_headers(up, "101");
}

// ------------------------------------------------------------ connection budgets

TEST(WebSecurity, AFloodOfIdleConnectionsOnOneListenerLeavesAnotherServed) {
  Rig rig({"127.0.0.1:0", "127.0.0.1:0"});  // A, B: 32 connections each
  const uint16_t a = rig.ports[0], b = rig.ports[1];
  // 70 strangers, one connection each from its own address, that never send
  // a byte: more than any one listener's budget, more than the old global 64.
  asio::io_context io;
  std::vector<tcp::socket> idle;
  for (int i = 2; i < 72; ++i) idle.push_back(connect_from(io, "127.0.0." + std::to_string(i), b));
  // B is full: one more is closed at once (it is accepted after the 70).
  tcp::socket late = connect_from(io, "127.0.0.200", b);
  EXPECT_TRUE(closed_within(late, 5000ms)) << "listener B took more than its budget";
  // A still serves its own client.
  const Response r = ask(a);
  EXPECT_EQ(r.result_int(), 200u);
  // B's first 32 are still held; the 38 over the budget were closed.
  int open = 0;
  for (tcp::socket& s : idle) open += still_open(s) ? 1 : 0;
  EXPECT_EQ(open, 32);
}

TEST(WebSecurity, OneSourceGetsAtMostMaxPerSource) {
  Rig rig({"127.0.0.1:0"});  // 8 per source
  const uint16_t port = rig.ports[0];
  asio::io_context io;
  std::vector<tcp::socket> mine;
  for (int i = 0; i < 8; ++i) mine.push_back(connect_from(io, "127.0.0.5", port));
  tcp::socket ninth = connect_from(io, "127.0.0.5", port);
  EXPECT_TRUE(closed_within(ninth, 5000ms)) << "a ninth connection from one address was served";
  for (tcp::socket& s : mine) EXPECT_TRUE(still_open(s));
  EXPECT_EQ(ask(port, {.source = "127.0.0.6"}).result_int(), 200u);  // another address is served
  // A slot comes back when its connection ends.
  mine.back().close();
  EXPECT_TRUE(eventually([&] {
    try {
      return ask(port, {.source = "127.0.0.5"}).result_int() == 200u;
    } catch (const std::exception&) {
      return false;
    }
  }));
}

TEST(WebSecurity, ListenerFromGivesALoopbackListenerItsWholeBudgetPerSource) {
  EXPECT_EQ(Listener::from("127.0.0.1:8080").max_per_source,
            Listener::from("127.0.0.1:8080").max_connections);
  EXPECT_EQ(Listener::from("0.0.0.0:8443").max_per_source, Listener().max_per_source);
  Listener zero("127.0.0.1:0");
  zero.max_per_source = 0;
  Server bad({.listen = {zero}}, {});
  EXPECT_EQ(bad.start().code(), Errc::invalid_argument);
}

TEST(WebSecurity, ASlowlorisClientIsClosedWithinItsDeadline) {
  ssl::context ignored(ssl::context::tls_client);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rtukit-slow-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  struct RemoveAtEnd {  // also when an assertion below ends the test
    const std::filesystem::path& dir;
    ~RemoveAtEnd() {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  } remove_at_end{dir};
  ASSERT_FALSE(ensure_self_signed((dir / "c.pem").string(), (dir / "k.pem").string(), "127.0.0.1"));
  Listener tls("127.0.0.1:0");
  tls.tls = TlsFiles{(dir / "c.pem").string(), (dir / "k.pem").string()};
  Rig rig({"127.0.0.1:0", tls});  // the default deadline: 10 s for a whole request
  asio::io_context io;
  // A header line every 500 ms, never the blank line that ends the request.
  tcp::socket trickle = connect_from(io, "127.0.0.7", rig.ports[0]);
  asio::write(trickle, asio::buffer("GET /echo HTTP/1.1\r\nHost: " + here(rig.ports[0]) + "\r\n"));
  // On the TLS listener: not even a client hello.
  tcp::socket silent = connect_from(io, "127.0.0.8", rig.ports[1]);
  const auto start = Clock::now();
  bool trickle_closed = false, silent_closed = false;
  while (Clock::now() - start < 25s && !(trickle_closed && silent_closed)) {
    if (!trickle_closed) {
      beast::error_code ec;
      asio::write(trickle, asio::buffer(std::string("X-Slow: 1\r\n")), ec);
      trickle_closed = ec || closed_within(trickle, 500ms);
    }
    if (!silent_closed) silent_closed = closed_within(silent, trickle_closed ? 500ms : 1ms);
  }
  const auto took = Clock::now() - start;
  EXPECT_TRUE(trickle_closed);
  EXPECT_TRUE(silent_closed);
  // 10 s, and a generous margin for a busy machine: the old deadline was 30 s per request.
  EXPECT_LT(took, 20s);
}

// ------------------------------------------------------------ WebSocket frames

// Writes raw client frames (masked with a zero key, so the payload is as written).
void write_frames(tcp::socket& s, const std::string& frames, beast::error_code& ec) {
  asio::write(s, asio::buffer(frames), ec);
}
std::string frame(uint8_t first, const std::string& payload = {}) {
  std::string f;
  f += static_cast<char>(first);
  f += static_cast<char>(0x80 | payload.size());  // masked; payloads here are < 126 bytes
  f += std::string(4, '\0');
  return f + payload;
}

TEST(WebSecurity, AnEndlessMessageOfEmptyFragmentsIsCut) {
  Rig rig({"127.0.0.1:0"});
  asio::io_context io;
  websocket::stream<tcp::socket> ws(io);
  ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), rig.ports[0]));
  ws.handshake(here(rig.ports[0]), "/ws");
  ASSERT_TRUE(eventually([&] { return rig.opened == 1; }));
  // A fragmented message within the limits still arrives whole.
  beast::error_code ec;
  write_frames(ws.next_layer(), frame(0x01, "ab") + frame(0x00) + frame(0x00, "cd") + frame(0x80, "ef"), ec);
  ASSERT_FALSE(ec);
  beast::flat_buffer b;
  ws.read(b);
  EXPECT_EQ(beast::buffers_to_string(b.data()), "abcdef");
  // Then a text frame that is not final, and empty continuations for ever:
  // no byte of payload, so the message size limit never sees them.
  write_frames(ws.next_layer(), frame(0x01), ec);
  std::string batch;
  for (int i = 0; i < 1000; ++i) batch += frame(0x00);
  size_t sent = 0;
  for (; sent < 2'000'000 && !ec; sent += 1000) write_frames(ws.next_layer(), batch, ec);
  EXPECT_TRUE(ec) << "the server took " << sent << " empty fragments of one message";
  EXPECT_TRUE(eventually([&] { return rig.closed == 1; }));
  EXPECT_EQ(rig.server->connections(), 0u);
}

TEST(WebSecurity, APingFloodIsCutLikeAMessageFlood) {
  ServerOptions o;
  o.max_messages_per_s = 50;
  Rig rig({"127.0.0.1:0"}, o);
  asio::io_context io;
  websocket::stream<tcp::socket> ws(io);
  ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), rig.ports[0]));
  ws.handshake(here(rig.ports[0]), "/ws");
  std::string batch;
  for (int i = 0; i < 100; ++i) batch += frame(0x89);  // ping, final, empty
  beast::error_code ec;
  size_t sent = 0;
  for (; sent < 1'000'000 && !ec; sent += 100) write_frames(ws.next_layer(), batch, ec);
  EXPECT_TRUE(ec) << "the server answered " << sent << " pings";
  EXPECT_TRUE(eventually([&] { return rig.closed == 1; }));
}

// ------------------------------------------------------------ TLS

struct TempDir {
  TempDir() {
    path = std::filesystem::temp_directory_path() /
           ("rtukit-tls-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::remove_all(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string file(const std::string& name) const { return (path / name).string(); }
  std::filesystem::path path;
  static inline int counter = 0;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

unsigned mode_of(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? (st.st_mode & 0777) : 0;
}

TEST(WebSecurity, EnsureSelfSignedMakesAPrivatePairOnce) {
  TempDir d;
  const std::string cert = d.file("sub/phone.crt"), key = d.file("sub/phone.key");
  const rtukit::Status made = ensure_self_signed(cert, key, "192.168.4.1");
  ASSERT_FALSE(made) << made.reason();
  EXPECT_EQ(mode_of(cert), 0600u);
  EXPECT_EQ(mode_of(key), 0600u);
  EXPECT_NE(slurp(cert).find("-----BEGIN CERTIFICATE-----"), std::string::npos);
  EXPECT_NE(slurp(key).find("-----BEGIN PRIVATE KEY-----"), std::string::npos);
  const Outcome<std::string> fp = certificate_fingerprint(cert);
  ASSERT_TRUE(fp.ok()) << fp.error().reason();
  EXPECT_TRUE(std::regex_match(*fp, std::regex("([0-9A-F]{2}:){31}[0-9A-F]{2}"))) << *fp;
  const Outcome<std::string> spki = spki_sha256_base64(cert);
  ASSERT_TRUE(spki.ok());
  EXPECT_TRUE(std::regex_match(*spki, std::regex("[A-Za-z0-9+/]{43}="))) << *spki;
  // No temporary file left beside them.
  size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(d.path / "sub")) ++files;
  EXPECT_EQ(files, 2u);
  // Idempotent: a second call keeps the pair the phones already trust.
  const std::string before = slurp(cert) + slurp(key);
  EXPECT_FALSE(ensure_self_signed(cert, key, "192.168.4.1"));
  EXPECT_EQ(slurp(cert) + slurp(key), before);
  EXPECT_EQ(*certificate_fingerprint(cert), *fp);
  // Half a pair is refused, and named.
  std::filesystem::rename(key, key + ".away");
  rtukit::Status half = ensure_self_signed(cert, key, "192.168.4.1");
  EXPECT_EQ(half.code(), Errc::refused);
  EXPECT_NE(std::string(half.reason()).find(key), std::string::npos) << half.reason();
  EXPECT_FALSE(std::filesystem::exists(key)) << "the missing half was made up";
  std::filesystem::rename(key + ".away", key);
  // Not PEM, and a key that is not the certificate's.
  std::ofstream(d.file("junk.crt")) << "not a certificate\n";
  EXPECT_EQ(ensure_self_signed(d.file("junk.crt"), key, "x").code(), Errc::malformed);
  EXPECT_EQ(certificate_fingerprint(d.file("junk.crt")).error().code(), Errc::malformed);
  ASSERT_FALSE(ensure_self_signed(d.file("other.crt"), d.file("other.key"), "chair.local"));
  const rtukit::Status mixed = ensure_self_signed(cert, d.file("other.key"), "x");
  EXPECT_EQ(mixed.code(), Errc::malformed) << mixed.reason();
  EXPECT_NE(*certificate_fingerprint(d.file("other.crt")), *fp);
  // A name that could smuggle more SAN entries is refused.
  EXPECT_EQ(ensure_self_signed(d.file("n.crt"), d.file("n.key"), "a,IP:1.2.3.4").code(),
            Errc::invalid_argument);
  EXPECT_EQ(ensure_self_signed(d.file("n.crt"), d.file("n.key"), "").code(), Errc::invalid_argument);
}

// A TLS client that trusts exactly the generated certificate, for 127.0.0.1.
struct TlsClient {
  explicit TlsClient(const std::string& cert) : ctx(ssl::context::tls_client) {
    ctx.load_verify_file(cert);
    ctx.set_verify_mode(ssl::verify_peer);
  }
  Response get(uint16_t port, const Ask& a = {}) {
    asio::io_context io;
    ssl::stream<tcp::socket> s(io, ctx);
    s.set_verify_callback(ssl::host_name_verification("127.0.0.1"));
    s.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    s.handshake(ssl::stream_base::client);
    http::write(s, request_of(port, a));
    beast::flat_buffer b;
    Response res;
    http::read(s, b, res);
    return res;
  }
  ssl::context ctx;
};

TEST(WebSecurity, ATlsListenerServesHttpAndWebSocketAndRefusesPlainHttp) {
  TempDir d;
  ASSERT_FALSE(ensure_self_signed(d.file("c.pem"), d.file("k.pem"), "127.0.0.1"));
  Listener l("127.0.0.1:0");
  l.tls = TlsFiles{d.file("c.pem"), d.file("k.pem")};
  EXPECT_EQ(listener_url(l, 8443), "https://127.0.0.1:8443");
  Rig rig({l});
  const uint16_t port = rig.ports[0];
  TlsClient client(d.file("c.pem"));
  // HTTPS, verified against the generated certificate, and the same checks as plain HTTP.
  Response r = client.get(port, {.origin = "https://" + here(port)});
  EXPECT_EQ(r.result_int(), 200u);
  EXPECT_EQ(r.body(), here(port) + "|https://" + here(port) + "||secure");
  expect_security_headers(r, "https");
  EXPECT_EQ(client.get(port, {.origin = "http://" + here(port)}).result_int(),
            403u);  // the scheme is part of it
  EXPECT_EQ(client.get(port, {.host = "evil.example:" + std::to_string(port)}).result_int(), 403u);
  // WSS.
  {
    asio::io_context io;
    websocket::stream<ssl::stream<tcp::socket>> ws(io, client.ctx);
    ws.next_layer().set_verify_callback(ssl::host_name_verification("127.0.0.1"));
    ws.next_layer().next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    ws.next_layer().handshake(ssl::stream_base::client);
    ws.set_option(websocket::stream_base::decorator(
        [port](websocket::request_type& req) { req.set(http::field::origin, "https://" + here(port)); }));
    ws.handshake(here(port), "/ws");
    for (const std::string& m :
         {std::string("over tls"), std::string(20000, 'z')}) {  // one frame, then several
      ws.write(asio::buffer(m));
      beast::flat_buffer b;
      ws.read(b);
      EXPECT_EQ(beast::buffers_to_string(b.data()), m);
    }
    ws.close(websocket::close_code::normal);
  }
  EXPECT_TRUE(eventually([&] { return rig.closed == 1; }));
  // Plain HTTP to the TLS port gets no HTTP answer.
  {
    asio::io_context io;
    tcp::socket s = connect_from(io, "127.0.0.1", port);
    http::write(s, request_of(port, {}));
    beast::flat_buffer b;
    Response res;
    beast::error_code ec;
    http::read(s, b, res, ec);
    EXPECT_TRUE(ec) << "a plain HTTP answer: " << res.result_int();
  }
  // TLS 1.1 is refused.
  {
    ssl::context old(ssl::context::tls_client);
    SSL_CTX_set_security_level(old.native_handle(), 0);
    SSL_CTX_set_min_proto_version(old.native_handle(), TLS1_VERSION);
    SSL_CTX_set_max_proto_version(old.native_handle(), TLS1_1_VERSION);
    old.set_verify_mode(ssl::verify_none);
    asio::io_context io;
    ssl::stream<tcp::socket> s(io, old);
    s.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    beast::error_code ec;
    s.handshake(ssl::stream_base::client, ec);
    EXPECT_TRUE(ec);
  }
}

TEST(WebSecurity, ATlsListenerWithABrokenPairDoesNotStart) {
  TempDir d;
  ASSERT_FALSE(ensure_self_signed(d.file("a.crt"), d.file("a.key"), "127.0.0.1"));
  ASSERT_FALSE(ensure_self_signed(d.file("b.crt"), d.file("b.key"), "127.0.0.1"));
  Listener mixed("127.0.0.1:0");
  mixed.tls = TlsFiles{d.file("a.crt"), d.file("b.key")};
  Server s1({.listen = {mixed}}, {});
  const rtukit::Status e1 = s1.start();
  EXPECT_EQ(e1.code(), Errc::io_error);
  EXPECT_NE(std::string(e1.reason()).find("b.key"), std::string::npos) << e1.reason();
  Listener missing("127.0.0.1:0");
  missing.tls = TlsFiles{d.file("none.crt"), d.file("none.key")};
  Server s2({.listen = {missing}}, {});
  const rtukit::Status e2 = s2.start();
  EXPECT_EQ(e2.code(), Errc::io_error);
  EXPECT_NE(std::string(e2.reason()).find("none.crt"), std::string::npos) << e2.reason();
}

}  // namespace
}  // namespace rtukit::web
