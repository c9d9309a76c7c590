// The Inverjet pool panel.
//
// InverjetPanelSecurity.*: who may use the panel (`rtukit inverjet panel`
// over the simulated machine on a pty, driven with raw HTTP and WebSocket
// requests, plain and TLS): a forged Origin or a Host not allowed is refused
// and the machine does not start; with a password every page, file and the
// WebSocket need the session cookie the login gives; wrong passwords are
// refused and rate-limited; the cookie is Secure, HttpOnly, SameSite=Strict;
// an address that is not loopback without a password file or without TLS is
// refused at start (one line, exit 2); the password file is a salted slow
// hash, 0600, never replaced without --force. ctest label `security`.
//
// InverjetPanelBrowser.PanelInChromium: the page in Debian's Chromium
// (tests/browser/inverjet_panel_browser.py), over TLS with a password.
#include <gtest/gtest.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <sys/un.h>

#include <filesystem>
#include <optional>
#include <regex>
#include <string>

#include "process.hpp"

namespace {

using namespace std::chrono_literals;
using rtukit::test::eventually;
using rtukit::test::Process;
using rtukit::test::TempDir;

constexpr const char* kPassword = "lane-four-fast";

// A connection to the panel, plain or TLS (the certificate is not checked:
// the test made it).
class Conn {
 public:
  Conn(uint16_t port, bool tls) : fd_(rtukit::test::connect_to(port)) {
    if (fd_ < 0 || !tls) return;
    ctx_ = SSL_CTX_new(TLS_client_method());
    ssl_ = SSL_new(ctx_);
    SSL_set_fd(ssl_, fd_);
    if (SSL_connect(ssl_) != 1) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  ~Conn() {
    if (ssl_) SSL_free(ssl_);
    if (ctx_) SSL_CTX_free(ctx_);
    if (fd_ >= 0) ::close(fd_);
  }
  Conn(const Conn&) = delete;
  Conn& operator=(const Conn&) = delete;
  bool ok() const { return fd_ >= 0; }
  bool send(const std::string& data) {
    if (ssl_)
      return SSL_write(ssl_, data.data(), static_cast<int>(data.size())) == static_cast<int>(data.size());
    return ::send(fd_, data.data(), data.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(data.size());
  }
  // Some bytes ("" at the end of the stream or after 20 s of silence).
  std::string recv_some() {
    timeval tv{20, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    char buf[4096];
    const int n = ssl_ ? SSL_read(ssl_, buf, sizeof buf) : static_cast<int>(::recv(fd_, buf, sizeof buf, 0));
    return n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string();
  }

 private:
  int fd_ = -1;
  SSL_CTX* ctx_ = nullptr;
  SSL* ssl_ = nullptr;
};

struct Response {
  unsigned status = 0;
  std::string head, body;
  std::string header(const std::string& name) const {  // the first field named so, "" when absent
    std::smatch m;
    const std::regex re("\r\n" + name + ":[ \t]*([^\r\n]*)", std::regex::icase);
    return std::regex_search(head, m, re) ? m[1].str() : std::string();
  }
};

// Reads a response's head (and, unless `upgrade`, its body to the end).
Response read_response(Conn& c, bool upgrade) {
  Response r;
  std::string data;
  while (data.find("\r\n\r\n") == std::string::npos) {
    const std::string more = c.recv_some();
    if (more.empty()) return r;
    data += more;
  }
  const size_t end = data.find("\r\n\r\n");
  r.head = data.substr(0, end);
  r.body = data.substr(end + 4);
  if (r.head.size() > 12) r.status = static_cast<unsigned>(std::atoi(r.head.c_str() + 9));
  if (!upgrade) {
    const std::string length = r.header("Content-Length");
    while (length.empty() || r.body.size() < std::stoul(length)) {
      const std::string more = c.recv_some();
      if (more.empty()) break;
      r.body += more;
    }
  }
  return r;
}

// The panel over the simulated machine.
class PanelFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    sim_ = std::make_unique<Process>(
        std::vector<std::string>{RTUKIT_BIN, "sim", "inverjet", "--listen", "pty:" + dir_ / "jet",
                                 "--no-state", "--no-console", "--console", "unix:" + dir_ / "console"});
    ASSERT_TRUE(
        eventually([&] { return rtukit::test::path_exists(dir_ / "jet"); }, rtukit::test::kStartDeadline))
        << sim_->output();
  }

  // Starts the panel with `more` options on 127.0.0.1 (a free port).
  void start_panel(std::vector<std::string> more) {
    std::vector<std::string> argv{RTUKIT_BIN,   "inverjet", "panel",      "--port",
                                  dir_ / "jet", "--http",   "127.0.0.1:0"};
    argv.insert(argv.end(), more.begin(), more.end());
    panel_ = std::make_unique<Process>(argv);
    ASSERT_TRUE(panel_->wait_for_output("inverjet panel: ")) << panel_->output();
    std::smatch m;
    const std::string out = panel_->output();
    ASSERT_TRUE(std::regex_search(out, m, std::regex("(https?)://127\\.0\\.0\\.1:([0-9]+)"))) << out;
    tls_ = m[1].str() == "https";
    port_ = static_cast<uint16_t>(std::stoi(m[2].str()));
  }

  std::string host() const { return "127.0.0.1:" + std::to_string(port_); }
  std::string origin() const { return std::string(tls_ ? "https://" : "http://") + host(); }

  Response request(const std::string& method, const std::string& path, std::vector<std::string> fields = {},
                   const std::string& body = {}) {
    Conn c(port_, tls_);
    if (!c.ok()) return {};
    std::string req = method + " " + path + " HTTP/1.1\r\n";
    bool has_host = false;
    for (const std::string& f : fields) has_host = has_host || f.rfind("Host:", 0) == 0;
    if (!has_host) req += "Host: " + host() + "\r\n";
    for (const std::string& f : fields) req += f + "\r\n";
    if (!body.empty() || method == "POST") req += "Content-Length: " + std::to_string(body.size()) + "\r\n";
    req += "Connection: close\r\n\r\n" + body;
    c.send(req);
    return read_response(c, false);
  }

  // A WebSocket upgrade on /ws; the open connection when it was accepted (101).
  std::unique_ptr<Conn> upgrade(std::vector<std::string> fields, Response* out) {
    auto c = std::make_unique<Conn>(port_, tls_);
    std::string req = "GET /ws HTTP/1.1\r\n";
    bool has_host = false;
    for (const std::string& f : fields) has_host = has_host || f.rfind("Host:", 0) == 0;
    if (!has_host) req += "Host: " + host() + "\r\n";
    req +=
        "Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
        "Sec-WebSocket-Version: 13\r\n";
    for (const std::string& f : fields) req += f + "\r\n";
    c->send(req + "\r\n");
    *out = read_response(*c, true);
    return out->status == 101 ? std::move(c) : nullptr;
  }

  // A masked text frame (a client's).
  static bool send_text(Conn& c, const std::string& text) {
    std::string f;
    f += static_cast<char>(0x81);
    if (text.size() < 126) {
      f += static_cast<char>(0x80 | text.size());
    } else {
      f += static_cast<char>(0x80 | 126);
      f += static_cast<char>(text.size() >> 8);
      f += static_cast<char>(text.size() & 0xFF);
    }
    const char mask[4] = {0x12, 0x34, 0x56, 0x78};
    f.append(mask, 4);
    for (size_t i = 0; i < text.size(); ++i) f += static_cast<char>(text[i] ^ mask[i % 4]);
    return c.send(f);
  }

  // The simulator's console: one line in, one line out.
  std::string ask(const std::string& line) { return rtukit::test::ask_console(dir_ / "console", line); }

  bool machine_off() { return ask("get state").rfind("state = off", 0) == 0; }

  std::string password_file() {
    const std::string file = dir_ / "panel.pw";
    if (!rtukit::test::path_exists(file)) {
      const auto r = rtukit::test::run({"/bin/sh", "-c",
                                        std::string("printf '%s\\n' '") + kPassword + "' | '" + RTUKIT_BIN +
                                            "' inverjet panel-password '" + file + "'"});
      EXPECT_EQ(r.code, 0) << r.output;
    }
    return file;
  }

  // A self-signed certificate for 127.0.0.1 (openssl), as --tls-cert/--tls-key.
  std::vector<std::string> tls_options() {
    const std::string cert = dir_ / "panel.crt", key = dir_ / "panel.key";
    const auto r =
        rtukit::test::run({"openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256",
                           "-nodes", "-keyout", key, "-out", cert, "-days", "2", "-subj", "/CN=127.0.0.1",
                           "-addext", "subjectAltName=IP:127.0.0.1"});
    EXPECT_EQ(r.code, 0) << r.output;
    return {"--tls-cert", cert, "--tls-key", key};
  }

  Response login(const std::string& password) {
    return request("POST", "/login",
                   {"Origin: " + origin(), "Content-Type: application/x-www-form-urlencoded"},
                   "password=" + password);
  }

  TempDir dir_;
  std::unique_ptr<Process> sim_, panel_;
  uint16_t port_ = 0;
  bool tls_ = false;
};

using InverjetPanelSecurity = PanelFixture;

TEST_F(InverjetPanelSecurity, AForgedOriginIsRefusedOnTheWebSocket_TheMachineDoesNotStart) {
  start_panel({});
  Response r;
  auto forged = upgrade({"Origin: http://evil.example"}, &r);
  EXPECT_EQ(r.status, 403u) << r.head;
  EXPECT_EQ(forged, nullptr);
  // The same request from the panel's own page does reach the machine.
  auto own = upgrade({"Origin: " + origin()}, &r);
  ASSERT_NE(own, nullptr) << r.head;
  EXPECT_TRUE(machine_off()) << ask("get state");
  ASSERT_TRUE(send_text(*own, R"({"op":"start","mode":"free","speed":35,"id":1})"));
  EXPECT_TRUE(eventually([&] { return ask("get state").find("free") != std::string::npos; }))
      << ask("get state");
  ASSERT_TRUE(send_text(*own, R"({"op":"stop","id":2})"));
  EXPECT_TRUE(eventually([&] { return machine_off(); })) << ask("get state");
  // A forged Origin with a page's request is refused too.
  EXPECT_EQ(request("GET", "/", {"Origin: http://evil.example"}).status, 403u);
}

TEST_F(InverjetPanelSecurity, AHostNotAllowedIsRefused_AHostNameGivenIsServed) {
  start_panel({"--host-name", "pool.local"});
  const std::string port = std::to_string(port_);
  EXPECT_EQ(request("GET", "/", {"Host: evil.example:" + port}).status, 403u);
  Response r;
  EXPECT_EQ(upgrade({"Host: evil.example:" + port, "Origin: http://evil.example:" + port}, &r), nullptr);
  EXPECT_EQ(r.status, 403u) << r.head;
  EXPECT_EQ(request("GET", "/", {"Host: pool.local:" + port}).status, 200u);
  EXPECT_NE(upgrade({"Host: pool.local:" + port, "Origin: http://pool.local:" + port}, &r), nullptr)
      << r.head;
  EXPECT_TRUE(machine_off()) << ask("get state");
}

TEST_F(InverjetPanelSecurity, WithAPasswordNothingButTheLoginPageIsServedWithoutASession) {
  start_panel({"--password-file", password_file()});
  Response r = request("GET", "/");
  EXPECT_EQ(r.status, 303u);
  EXPECT_EQ(r.header("Location"), "/login");
  EXPECT_EQ(request("GET", "/inverjet/panel.html").status, 303u);
  EXPECT_EQ(request("GET", "/inverjet/panel.js").status, 401u);
  EXPECT_EQ(request("GET", "/api/session").status, 401u);
  EXPECT_EQ(upgrade({"Origin: " + origin()}, &r), nullptr);
  EXPECT_EQ(r.status, 401u) << r.head;
  r = request("GET", "/login");
  EXPECT_EQ(r.status, 200u);
  EXPECT_NE(r.body.find("<form method=\"post\" action=\"/login\">"), std::string::npos) << r.body;
  EXPECT_EQ(request("GET", "/inverjet/login.css").status, 200u);
  // A cookie nobody was given opens nothing.
  EXPECT_EQ(
      upgrade({"Origin: " + origin(), "Cookie: rtukit_panel=AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA"},
              &r),
      nullptr);
  EXPECT_EQ(r.status, 401u);
  // On plain HTTP on loopback the cookie cannot be Secure (the browser would drop it); the rest holds.
  r = login(kPassword);
  EXPECT_EQ(r.status, 303u) << r.head << r.body;
  const std::string cookie = r.header("Set-Cookie");
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos) << cookie;
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos) << cookie;
  EXPECT_EQ(cookie.find("Secure"), std::string::npos) << cookie;
  EXPECT_TRUE(machine_off()) << ask("get state");
}

TEST_F(InverjetPanelSecurity, WrongPasswordsAreRefused_TenAMinuteThenEvenTheRightOneWaits) {
  start_panel({"--password-file", password_file()});
  for (int i = 0; i < 10; ++i) {
    const Response r = login("guess" + std::to_string(i));
    EXPECT_EQ(r.status, 401u) << i;
    EXPECT_NE(r.body.find("Wrong password"), std::string::npos) << r.body;
    EXPECT_TRUE(r.header("Set-Cookie").empty());
  }
  Response r = login("guess10");
  EXPECT_EQ(r.status, 429u);
  const int wait = std::atoi(r.header("Retry-After").c_str());
  EXPECT_GE(wait, 1) << r.head;
  EXPECT_LE(wait, 60) << r.head;
  r = login(kPassword);
  EXPECT_EQ(r.status, 429u) << "the right password while the limit lasts";
  EXPECT_TRUE(r.header("Set-Cookie").empty());
  EXPECT_NE(panel_->output().find("wrong password from 127.0.0.1"), std::string::npos) << panel_->output();
}

TEST_F(InverjetPanelSecurity, TheRightPasswordGivesASecureHttpOnlyStrictCookie_ThatOpensTheWebSocket) {
  start_panel([&] {
    auto o = tls_options();
    o.insert(o.end(), {"--password-file", password_file()});
    return o;
  }());
  ASSERT_TRUE(tls_);
  Response r = login(kPassword);
  ASSERT_EQ(r.status, 303u) << r.head << r.body;
  EXPECT_EQ(r.header("Location"), "/");
  const std::string set = r.header("Set-Cookie");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(set, m, std::regex("^rtukit_panel=([A-Za-z0-9_-]{43});"))) << set;
  const std::string cookie = "Cookie: rtukit_panel=" + m[1].str();
  for (const char* attribute : {"; Secure", "; HttpOnly", "; SameSite=Strict", "; Path=/", "; Max-Age=43200"})
    EXPECT_NE(set.find(attribute), std::string::npos) << attribute << " in " << set;
  EXPECT_EQ(request("GET", "/", {cookie}).status, 200u);
  EXPECT_EQ(request("GET", "/inverjet/panel.js", {cookie}).status, 200u);
  // The cookie opens the WebSocket, which runs the machine.
  auto ws = upgrade({"Origin: " + origin(), cookie}, &r);
  ASSERT_NE(ws, nullptr) << r.head;
  ASSERT_TRUE(send_text(*ws, R"({"op":"start","mode":"timer","speed":30,"duration":"10:00","id":1})"));
  EXPECT_TRUE(eventually([&] { return ask("get state").find("timer") != std::string::npos; }))
      << ask("get state");
  ASSERT_TRUE(send_text(*ws, R"({"op":"stop","id":2})"));
  EXPECT_TRUE(eventually([&] { return machine_off(); })) << ask("get state");
  // ...but never from another origin, cookie or not.
  EXPECT_EQ(upgrade({"Origin: https://evil.example", cookie}, &r), nullptr);
  EXPECT_EQ(r.status, 403u);
  // A JSON login works too.
  r = request("POST", "/login", {"Origin: " + origin(), "Content-Type: application/json"},
              std::string(R"({"password":")") + kPassword + "\"}");
  EXPECT_EQ(r.status, 303u);
  // Logging out ends the session: the cookie opens nothing any more.
  r = request("POST", "/logout", {"Origin: " + origin(), cookie});
  EXPECT_EQ(r.status, 303u);
  EXPECT_EQ(r.header("Location"), "/login");
  EXPECT_EQ(upgrade({"Origin: " + origin(), cookie}, &r), nullptr);
  EXPECT_EQ(r.status, 401u);
  EXPECT_EQ(request("GET", "/", {cookie}).status, 303u);
}

TEST_F(InverjetPanelSecurity, OffLoopbackWithoutPasswordOrTlsItRefusesToStart_OneLineExit2) {
  const std::string pw = password_file();
  const std::vector<std::string> tls = tls_options();
  const std::vector<std::vector<std::string>> cases = {
      {},
      {"--password-file", pw},
      tls,
      {"--password-file", pw, "--tls-cert", tls[1]},
  };
  for (const auto& more : cases) {
    std::vector<std::string> argv{RTUKIT_BIN,   "inverjet", "panel",    "--port",
                                  dir_ / "jet", "--http",   "0.0.0.0:0"};
    argv.insert(argv.end(), more.begin(), more.end());
    const auto r = rtukit::test::run(argv);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_TRUE(r.output.find("--password-file") != std::string::npos ||
                r.output.find("--tls-cert") != std::string::npos)
        << r.output;
    EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
  }
  EXPECT_TRUE(machine_off()) << ask("get state");
}

TEST_F(InverjetPanelSecurity, ThePasswordFileIsASaltedSlowHash_0600_NeverReplacedWithoutForce) {
  const std::string file = dir_ / "pw";
  const auto make = [&](const std::string& password, const std::string& more = {}) {
    return rtukit::test::run({"/bin/sh", "-c",
                              "printf '%s\\n' '" + password + "' | '" + RTUKIT_BIN +
                                  "' inverjet panel-password '" + file + "' " + more});
  };
  auto r = make("short");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("at least 8"), std::string::npos) << r.output;
  EXPECT_FALSE(rtukit::test::path_exists(file));
  EXPECT_EQ(make("").code, 2);
  r = make(kPassword);
  ASSERT_EQ(r.code, 0) << r.output;
  struct stat st {};
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  const std::string first = rtukit::test::read_file(file);
  EXPECT_TRUE(std::regex_match(
      first, std::regex("rtukit-panel-password pbkdf2-sha256 200000 [0-9a-f]{32} [0-9a-f]{64}\n")))
      << first;
  EXPECT_EQ(first.find(kPassword), std::string::npos);
  r = make("another-password");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(rtukit::test::read_file(file), first) << "not replaced";
  r = make(kPassword, "--force");
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string second = rtukit::test::read_file(file);
  EXPECT_NE(second, first) << "a new salt each time";
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
}

TEST(InverjetPanelBrowser, PanelInChromium) {
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/chromium")) << "scripts/setup.sh installs chromium";
  const std::string out = std::string(ARTIFACTS_DIR) + "/inverjet-panel";
  const rtukit::test::RunResult r = rtukit::test::run(
      {"/usr/bin/python3", std::string(SCRIPTS_DIR) + "/inverjet_panel_browser.py", RTUKIT_BIN, out},
      280000ms);
  std::cout << r.output;
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("\nPASS"), std::string::npos);
  EXPECT_EQ(r.output.find("FAIL "), std::string::npos);
  for (const char* shot : {"panel-phone-390x844.png", "panel-tablet-1280x800.png", "panel-phone-running.png",
                           "panel-phone-lost.png", "panel-tablet-lost.png", "panel-fault.png"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + shot)) << shot;
}

}  // namespace
