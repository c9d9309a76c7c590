// The pool panel: PanelLogic (polls, commands, history, plans) on a bus
// worker (driver/bus_worker.hpp), and the web thread (pages). Commands cross
// from the web thread to the logic with PanelLogic::queue_command (and a
// wake); its messages cross back with Server::post, numbered, so a page that
// connects between a message and its delivery gets it once: in welcome() or
// as the message, never both.
//
// Who may use it (docs/inverjet.md, "Pool panel"): the web layer checks
// Origin and Host on every request; with a password file, every request but
// the login page needs a session cookie. A session is a 256-bit random token
// the browser keeps in an HttpOnly, SameSite=Strict cookie (Secure unless the
// listener is plain HTTP on loopback); the panel keeps only its SHA-256, in
// memory, for 12 hours. Wrong passwords: 10 per source (an IPv4 address, an
// IPv6 /64) per minute, counted by the guard every program shares (web/guard.hpp).
#include "rtukit/programs/inverjet_panel.hpp"

#include <fcntl.h>
#include <fmt/chrono.h>
#include <fmt/core.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <deque>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/typed.hpp"
#include "rtukit/devices/inverjet/verbs.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/driver/bus_worker.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/poll_schedule.hpp"
#include "rtukit/io/atomic_file.hpp"
#include "rtukit/web/assets.hpp"
#include "rtukit/web/guard.hpp"
#include "rtukit/web/server.hpp"
#include "rtukit/web/tls.hpp"
#include "rtukit/web/webcrypto.hpp"

namespace rtukit::programs {
namespace {

using Json = nlohmann::json;
namespace ij = inverjet;

constexpr std::string_view kRecordTag = "rtukit-panel-password";
constexpr std::string_view kRecordAlgorithm = "pbkdf2-sha256";
constexpr size_t kSaltBytes = 16, kKeyBytes = 32, kTokenBytes = 32;
constexpr std::string_view kCookie = "rtukit_panel";
constexpr auto kSessionLife = std::chrono::hours(12);
constexpr size_t kMaxSessions = 256;  ///< the oldest goes first beyond this
constexpr int kWrongPerAddress = 10;  ///< wrong passwords per source address per kWrongWindow
constexpr auto kWrongWindow = std::chrono::minutes(1);
constexpr size_t kWrongSources = 4096;  ///< sources remembered at once; a new one waits past it (fail closed)

struct Command {
  uint64_t socket = 0;  ///< the page that sent it: its result goes there
  Json message;
};

// The salt and the key of a password record, as their hex (web/guard.hpp).
std::string hex_of(const unsigned char* data, size_t n) {
  return web::hex({reinterpret_cast<const char*>(data), n});
}
std::optional<std::vector<unsigned char>> bytes_of_hex(std::string_view text) {
  const std::optional<std::string> bytes = web::from_hex(text);
  if (!bytes) return std::nullopt;
  return std::vector<unsigned char>(bytes->begin(), bytes->end());
}

bool derive(std::string_view password, const std::vector<unsigned char>& salt, unsigned iterations,
            unsigned char* key, size_t key_bytes) {
  return PKCS5_PBKDF2_HMAC(password.data(), static_cast<int>(password.size()), salt.data(),
                           static_cast<int>(salt.size()), static_cast<int>(iterations), EVP_sha256(),
                           static_cast<int>(key_bytes), key) == 1;
}

struct Record {
  unsigned iterations = 0;
  std::vector<unsigned char> salt, key;
};

std::optional<Record> parse_record(std::string_view text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
  std::istringstream in{std::string(text)};
  std::string tag, algorithm, iterations, salt, key, extra;
  if (!(in >> tag >> algorithm >> iterations >> salt >> key) || (in >> extra)) return std::nullopt;
  if (tag != kRecordTag || algorithm != kRecordAlgorithm) return std::nullopt;
  Record r;
  if (iterations.empty() || iterations.size() > 9 ||
      iterations.find_first_not_of("0123456789") != std::string::npos)
    return std::nullopt;
  r.iterations = static_cast<unsigned>(std::stoul(iterations));
  auto s = bytes_of_hex(salt), k = bytes_of_hex(key);
  if (r.iterations < 1000 || !s || !k || s->size() < 8 || k->size() != kKeyBytes) return std::nullopt;
  r.salt = std::move(*s);
  r.key = std::move(*k);
  return r;
}

// "a=1; b=2" -> the value of `name`, "" when absent.
std::string cookie_value(std::string_view header, std::string_view name) {
  while (!header.empty()) {
    const size_t semi = header.find(';');
    std::string_view item = header.substr(0, semi);
    header = semi == std::string_view::npos ? std::string_view() : header.substr(semi + 1);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    if (item.size() > name.size() && item.substr(0, name.size()) == name && item[name.size()] == '=')
      return std::string(item.substr(name.size() + 1));
  }
  return {};
}

// application/x-www-form-urlencoded: the value of `key`, %-decoded.
std::optional<std::string> form_value(std::string_view body, std::string_view key) {
  while (!body.empty()) {
    const size_t amp = body.find('&');
    const std::string_view item = body.substr(0, amp);
    body = amp == std::string_view::npos ? std::string_view() : body.substr(amp + 1);
    const size_t eq = item.find('=');
    if (eq == std::string_view::npos || item.substr(0, eq) != key) continue;
    std::string out;
    const std::string_view v = item.substr(eq + 1);
    for (size_t i = 0; i < v.size(); ++i) {
      if (v[i] == '+') {
        out += ' ';
      } else if (v[i] == '%' && i + 2 < v.size()) {
        const auto b = bytes_of_hex(fmt::format("{}{}", static_cast<char>(std::tolower(v[i + 1])),
                                                static_cast<char>(std::tolower(v[i + 2]))));
        if (!b) return std::nullopt;
        out += static_cast<char>((*b)[0]);
        i += 2;
      } else if (v[i] == '%') {
        return std::nullopt;
      } else {
        out += v[i];
      }
    }
    return out;
  }
  return std::nullopt;
}

std::string html_escape(std::string_view text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

int64_t unix_ms(WallClock::time_point at) {
  return std::chrono::duration_cast<std::chrono::milliseconds>(at.time_since_epoch()).count();
}

}  // namespace

rtukit::Outcome<std::string> make_password_record(std::string_view password, unsigned iterations) {
  std::vector<unsigned char> salt(kSaltBytes);
  if (!web::random_bytes(salt.data(), salt.size()))
    return rtukit::Status(Errc::io_error, "no random bytes from the OS (getrandom)");
  std::array<unsigned char, kKeyBytes> key{};
  if (!derive(password, salt, iterations, key.data(), key.size()))
    return rtukit::Status(Errc::io_error, "PBKDF2 failed (OpenSSL)");
  return fmt::format("{} {} {} {} {}\n", kRecordTag, kRecordAlgorithm, iterations,
                     hex_of(salt.data(), salt.size()), hex_of(key.data(), key.size()));
}

rtukit::Outcome<bool> check_password(std::string_view record, std::string_view password) {
  const std::optional<Record> r = parse_record(record);
  if (!r) return rtukit::Status(Errc::malformed, "not a panel password record");
  std::array<unsigned char, kKeyBytes> key{};
  if (!derive(password, r->salt, r->iterations, key.data(), key.size()))
    return rtukit::Status(Errc::io_error, "PBKDF2 failed (OpenSSL)");
  return CRYPTO_memcmp(key.data(), r->key.data(), kKeyBytes) == 0;
}

rtukit::Outcome<std::string> load_password_record(const std::string& path) {
  Outcome<std::string> text = io::read_regular_file(path, 4096);
  if (!text) return rtukit::Status(text.error().error(), fmt::format("{}: {}", path, text.error().reason()));
  if (!parse_record(*text))
    return rtukit::Status(Errc::malformed,
                          fmt::format("{}: not a panel password file (make one with `rtukit inverjet "
                                      "panel-password {}`)",
                                      path, path));
  return *text;
}

size_t password_characters(std::string_view password) noexcept {
  size_t characters = 0;
  // A UTF-8 continuation byte is 10xxxxxx: every other byte starts a character.
  for (const char c : password)
    if ((static_cast<unsigned char>(c) & 0xC0) != 0x80) ++characters;
  return characters;
}

rtukit::Status check_new_password(std::string_view password) {
  const size_t characters = password_characters(password);
  if (characters < kMinPasswordCharacters)
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("the password has {} characters: at least {}, please", characters,
                                      kMinPasswordCharacters));
  return {};
}

namespace {
rtukit::Status existing_file(const std::string& path) {
  return rtukit::Status(Errc::refused, fmt::format("{} exists: not replaced (--force replaces it)", path));
}
}  // namespace

rtukit::Status check_password_file_path(const std::string& path, bool force) {
  // lstat, not stat: a symlink is something there too, even when it points
  // nowhere (the exclusive create would refuse it anyway, after the prompt).
  struct stat st {};
  if (!force && ::lstat(path.c_str(), &st) == 0) return existing_file(path);
  return {};
}

rtukit::Status write_password_file(const std::string& path, std::string_view password, bool force) {
  if (rtukit::Status e = check_new_password(password)) return e;
  if (rtukit::Status e = check_password_file_path(path, force)) return e;
  const Outcome<std::string> record = make_password_record(password);
  if (!record) return record.error();
  if (force) {
    if (rtukit::Status e = io::write_file_atomically(path, *record, 0600))
      return rtukit::Status(e.error(), fmt::format("{}: {}", path, e.reason()));
    return {};
  }
  // Created here or not at all: O_EXCL refuses whatever appeared since the
  // check, O_NOFOLLOW a symlink planted to make us write elsewhere.
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) {
    const int err = errno;
    if (err == EEXIST) return existing_file(path);
    return rtukit::Status(Error(Errc::io_error, err), fmt::format("{}: {}", path, std::strerror(err)));
  }
  std::string_view rest = *record;
  while (!rest.empty()) {
    const ssize_t n = ::write(fd, rest.data(), rest.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    rest.remove_prefix(static_cast<size_t>(n));
  }
  const bool written = rest.empty() && ::fsync(fd) == 0;
  ::close(fd);
  if (!written) {
    // The file is ours (we created it): a half record would only make the
    // panel refuse to start later, so leave nothing.
    ::unlink(path.c_str());
    return rtukit::Status(Errc::io_error, fmt::format("{}: cannot write", path));
  }
  return {};
}

// ---------------------------------------------------------------- the logic

struct PanelLogic::Impl {
  Impl(Master& master, const PanelOptions& o, DriverClock& c, PanelSend s)
      : options(o),
        clock(c),
        send(std::move(s)),
        client(master, UnitId{options.unit}),
        began(clock.now()),
        schedule(PollPolicy::at_hz(options.poll_hz), began) {}

  const PanelOptions& options;
  DriverClock& clock;
  PanelSend send;
  ij::Client client;

  // step()'s only.
  Clock::time_point began;  ///< the samples' "t" counts from here
  PollSchedule schedule;
  bool plans_read = false;
  bool running_before = false;
  bool online = false;
  bool said_offline = false;                 // the page hears of a machine that never answered too
  ij::Family remembered = ij::Family::none;  // the run family through a fault screen

  /// Guards what follows: queue_command() and welcome() run on other threads.
  mutable std::mutex mutex;
  std::deque<Command> commands;
  // What a page that connects is sent (welcome()), as of message `seq`.
  std::string last_state;
  std::vector<Json> history;
  std::string plans;
  uint64_t seq = 0;

  // Numbers the message and sends it; `update` brings what welcome() sends
  // up to it, under the same lock, so a page gets each message once.
  void out(uint64_t to, std::string text, const std::function<void()>& update = {}) {
    PanelMessage m{.to = to, .text = std::move(text)};
    {
      std::lock_guard lock(mutex);
      if (update) update();
      m.seq = ++seq;
    }
    send(m);
  }

  void send_plans() {
    Json p = read_plans();
    std::string text = p.dump();
    out(0, text, [&] { plans = text; });
  }

  Json read_plans() {
    Json all = Json::array();
    for (unsigned p = 1; p <= ij::kPlanCount; ++p) {
      Outcome<std::vector<ij::Segment>> segments = client.read_plan(p);
      Json list = Json::array();
      if (segments)
        for (const ij::Segment& s : *segments)
          list.push_back({{"speed", s.speed}, {"end", profile::format_mm_ss(s.end)}, {"end_s", s.end}});
      all.push_back(list);
    }
    return Json{{"type", "plans"}, {"plans", all}};
  }

  void run(const Command& c) {
    const Json& m = c.message;
    const std::string op = m["op"].get<std::string>();
    Json result{{"type", "result"}, {"op", op}};
    if (m.contains("id")) result["id"] = m["id"];
    rtukit::Status e;
    if (op == "plans") {
      send_plans();
    } else {
      e = inverjet::run_command(client, op, m, result);
      if (!e && op == "plan") send_plans();  // read back what the machine stored
    }
    result["ok"] = !e;
    if (e) inverjet::describe_failure(e, result);  // the page acts on "code" and shows "advice"
    out(c.socket, result.dump());
    schedule.poll_soon();  // show its effect at once
  }

  void poll(Clock::time_point now) {
    const Result<ij::MachineStatus> s = client.status();
    schedule.polled(now, bool(s));
    if (!s) {
      if (schedule.offline() && (online || !said_offline)) {
        online = false;
        said_offline = true;
        std::string text;
        {
          std::lock_guard lock(mutex);
          Json st = last_state.empty() ? Json{{"type", "state"}} : Json::parse(last_state);
          st["online"] = false;
          text = st.dump();
        }
        out(0, text, [&] { last_state = text; });
      }
      return;
    }
    online = true;
    const int64_t contact = unix_ms(clock.wall());
    if (!plans_read) {
      plans_read = true;
      send_plans();
    }
    remembered = inverjet::remember_family(*s, remembered);
    Json st = inverjet::state_document(*s, remembered);
    st["type"] = "state";
    st["online"] = true;
    st["last_contact_ms"] = contact;
    const bool running = s->phase() == ij::Phase::running || s->phase() == ij::Phase::starting ||
                         s->phase() == ij::Phase::paused;
    const bool new_run = running && !running_before;
    running_before = running;
    if (new_run)  // a new run: new charts
      out(0, Json{{"type", "history"}, {"samples", Json::array()}}.dump(), [&] { history.clear(); });
    if (running) {  // the run's samples; kept after it ends, for a look back
      Json sample{{"type", "sample"},
                  {"t", std::chrono::duration<double>(now - began).count()},
                  {"speed", s->phase() == ij::Phase::running ? s->speed : 0},
                  {"current_a", s->current_a},
                  {"mosfet_c", s->mosfet_c},
                  {"motor_c", s->motor_c}};
      out(0, sample.dump(), [&] {
        if (history.size() >= kPanelHistory) history.erase(history.begin());
        history.push_back(sample);
      });
    }
    std::string text = st.dump();
    bool changed;
    {
      std::lock_guard lock(mutex);
      changed = text != last_state;
    }
    if (changed) out(0, text, [&] { last_state = text; });
  }
};

PanelLogic::PanelLogic(Master& master, const PanelOptions& options, DriverClock& clock, PanelSend send)
    : impl_(std::make_unique<Impl>(master, options, clock, std::move(send))) {}

PanelLogic::~PanelLogic() = default;

bool PanelLogic::queue_command(uint64_t socket, Json command) {
  Impl& l = *impl_;
  if (!command.is_object() || !command.contains("op") || !command["op"].is_string()) {
    l.out(socket, Json{{"type", "error"}, {"error", "expected a JSON object with \"op\""}}.dump());
    return false;
  }
  Json busy{{"type", "result"}, {"op", command.value("op", Json())}, {"id", command.value("id", Json())}};
  inverjet::describe_busy("busy: too many commands waiting", busy);
  {
    std::lock_guard lock(l.mutex);
    if (l.commands.size() < kPanelCommandLimit) {
      l.commands.push_back({socket, std::move(command)});
      return true;
    }
  }
  // A page that floods the bus waits for nobody: refused, with an answer.
  l.out(socket, busy.dump(-1, ' ', false, Json::error_handler_t::replace));
  return false;
}

std::vector<std::string> PanelLogic::welcome(uint64_t& seq) const {
  const Impl& l = *impl_;
  std::lock_guard lock(l.mutex);
  std::vector<std::string> out;
  if (!l.last_state.empty()) out.push_back(l.last_state);
  out.push_back(Json{{"type", "history"}, {"samples", l.history}}.dump());
  if (!l.plans.empty()) out.push_back(l.plans);
  // The machine's limits: the page builds its plan list and checks its
  // fields from them, never from constants of its own.
  out.push_back(Json{{"type", "limits"}, {"limits", inverjet::limits_document()}}.dump());
  seq = l.seq;
  return out;
}

Clock::time_point PanelLogic::step(Clock::time_point now) {
  Impl& l = *impl_;
  std::deque<Command> todo;
  {
    std::lock_guard lock(l.mutex);
    todo.swap(l.commands);
  }
  for (const Command& c : todo) l.run(c);
  if (l.schedule.due(now)) l.poll(now);
  return l.schedule.next();
}

// ---------------------------------------------------------------- the panel: web server and bus worker

struct Panel::Impl {
  Impl(std::unique_ptr<io::Link> link, PanelOptions o)
      : options(std::move(o)),
        clock(clock_or_steady(options.clock)),
        master(std::move(link),
               MasterOptions{.response_timeout = std::chrono::milliseconds(options.response_timeout_ms),
                             .clock = &clock}),
        server(web::ServerOptions{.listen = {listener()}, .clock = &clock}, handlers()),
        logic(master, options, clock,
              [this](const PanelMessage& m) { server.post([this, m] { deliver(m); }); }),
        worker([this](Clock::time_point now) { return logic.step(now); }, {.clock = &clock}) {
    if (!options.log)
      options.log = [this](const std::string& line) {
        const std::time_t now = WallClock::to_time_t(clock.wall());
        std::tm tm{};
        ::localtime_r(&now, &tm);
        fmt::print(stderr, "{:%Y-%m-%d %H:%M:%S} inverjet panel: {}\n", tm, line);
        std::fflush(stderr);
      };
  }

  PanelOptions options;
  DriverClock& clock;
  Master master;
  web::Server server;
  PanelLogic logic;
  /// The one thread on the bus: it runs the logic's steps.
  BusWorker worker;

  // Web thread only.
  struct Page {
    web::SocketPtr socket;
    uint64_t welcomed = 0;  ///< the last message its welcome() covered
  };
  std::map<uint64_t, Page> sockets;

  // Who may use it. `record` is set by start() before the server runs; the
  // rest is the web thread's.
  std::string record;  ///< the password file's line; empty: no password (loopback only)
  struct Session {
    Clock::time_point until;
    Clock::time_point made;
  };
  std::map<std::string, Session> sessions;  ///< by the SHA-256 (hex) of the token
  std::map<uint64_t, std::string> socket_session;
  /// Wrong passwords per source (an IPv4 address, an IPv6 /64), in bounded
  /// memory: the guard the Rehand host daemon's pairing uses too.
  web::GuessLimit wrong{kWrongPerAddress, kWrongWindow, kWrongSources};

  web::Listener listener() const {
    web::Listener l = web::Listener::from(options.http);
    l.host_names = options.host_names;
    if (!options.tls_cert.empty() && !options.tls_key.empty())
      l.tls = web::TlsFiles{options.tls_cert, options.tls_key};
    return l;
  }

  void log(const std::string& line) const { options.log(line); }

  static std::string address_of(const std::string& peer) {
    // "192.168.1.5:51234", "[::1]:51234" -> the address alone.
    std::string a = peer.substr(0, peer.rfind(':'));
    if (a.size() >= 2 && a.front() == '[' && a.back() == ']') a = a.substr(1, a.size() - 2);
    if (a.rfind("::ffff:", 0) == 0) a = a.substr(7);
    return a;
  }

  // The session the request's cookie names, or "" (none, unknown, expired).
  std::string session_of(const web::HttpRequest& r) {
    const std::string token = cookie_value(r.cookie, kCookie);
    if (token.empty() || token.size() > 100) return {};
    const std::string id = web::sha256_hex(token);
    const auto it = sessions.find(id);
    if (it == sessions.end()) return {};
    if (clock.now() >= it->second.until) {
      end_session(id, "expired");
      return {};
    }
    return id;
  }

  bool authorized(const web::HttpRequest& r) { return record.empty() || !session_of(r).empty(); }

  void end_session(const std::string& id, const std::string& why) {
    sessions.erase(id);
    for (auto it = socket_session.begin(); it != socket_session.end();) {
      if (it->second == id) {
        if (auto s = sockets.find(it->first); s != sockets.end()) s->second.socket->close(why);
        it = socket_session.erase(it);
      } else {
        ++it;
      }
    }
  }

  void expire_sessions() {
    const auto now = clock.now();
    std::vector<std::string> old;
    for (const auto& [id, s] : sessions)
      if (now >= s.until) old.push_back(id);
    for (const std::string& id : old) {
      end_session(id, "session expired: log in again");
      log("a session expired (12 h)");
    }
  }

  // Wrong passwords from one source, per minute: guessing is slow. The
  // seconds to wait, or nothing.
  std::optional<int64_t> locked_for(const std::string& address) {
    const auto wait = wrong.wait(address, clock.now());
    if (wait <= Clock::duration::zero()) return std::nullopt;
    return std::max<int64_t>(1, std::chrono::ceil<std::chrono::seconds>(wait).count());
  }

  static web::HttpResponse see_other(std::string where) {
    web::HttpResponse r{
        .status = 303, .content_type = "text/plain; charset=utf-8", .body = "see " + where + "\n"};
    r.headers.emplace_back("Location", std::move(where));
    return r;
  }

  static web::HttpResponse login_page(unsigned status, std::string_view why) {
    const web::Asset* a = web::find_asset("/inverjet/login.html");
    std::string body = a ? std::string(a->body) : std::string("<!doctype html><p>login page missing</p>");
    const std::string marker = "<p id=\"why\" class=\"reason\">";
    if (const size_t at = body.find(marker); at != std::string::npos && !why.empty())
      body.insert(at + marker.size(), html_escape(why));
    return {.status = status, .content_type = "text/html; charset=utf-8", .body = std::move(body)};
  }

  web::HttpResponse login(const web::HttpRequest& r) {
    const bool json = !r.body.empty() && r.body.front() == '{';
    const auto refuse = [&](unsigned status, const std::string& why) {
      if (json) return web::HttpResponse{.status = status, .body = Json{{"error", why}}.dump()};
      return login_page(status, why);
    };
    if (record.empty()) return see_other("/");  // no password on this panel
    const std::string from = address_of(r.peer);
    if (const std::optional<int64_t> wait = locked_for(from)) {
      log(fmt::format("login refused from {}: too many wrong passwords", from));
      web::HttpResponse res =
          refuse(429, fmt::format("Too many wrong passwords from this device: try again in {} s.", *wait));
      res.headers.emplace_back("Retry-After", std::to_string(*wait));
      return res;
    }
    std::optional<std::string> password;
    if (json) {
      const Json body = Json::parse(r.body, nullptr, false);
      if (body.is_object() && body.contains("password") && body["password"].is_string())
        password = body["password"].get<std::string>();
    } else {
      password = form_value(r.body, "password");
    }
    if (!password || password->empty()) return refuse(400, "Enter the panel's password.");
    const Outcome<bool> ok = check_password(record, *password);
    if (!ok) return refuse(500, std::string(ok.error().reason()));
    if (!*ok) {
      const int count = wrong.count(from, clock.now());
      log(fmt::format("wrong password from {} ({} this minute)", from, count));
      return refuse(401, "Wrong password: try again. Ask the pool staff for the panel's password.");
    }
    std::array<unsigned char, kTokenBytes> raw{};
    if (!web::random_bytes(raw.data(), raw.size())) return refuse(500, "no random bytes from the OS");
    const std::string token = web::base64url({reinterpret_cast<const char*>(raw.data()), raw.size()});
    if (sessions.size() >= kMaxSessions) {
      auto oldest = sessions.begin();
      for (auto it = sessions.begin(); it != sessions.end(); ++it)
        if (it->second.made < oldest->second.made) oldest = it;
      end_session(oldest->first, "too many sessions: the oldest ended");
    }
    const auto now = clock.now();
    sessions[web::sha256_hex(token)] = {now + kSessionLife, now};
    log(fmt::format("login from {} ({} session(s))", from, sessions.size()));
    // Secure, except on plain HTTP on loopback (the browser would drop it).
    const bool secure = r.secure || !web::is_loopback(options.http);
    web::HttpResponse res = see_other("/");
    res.headers.emplace_back(
        "Set-Cookie", fmt::format("{}={}; Path=/;{} HttpOnly; SameSite=Strict; Max-Age={}", kCookie, token,
                                  secure ? " Secure;" : "",
                                  std::chrono::duration_cast<std::chrono::seconds>(kSessionLife).count()));
    return res;
  }

  web::HttpResponse logout(const web::HttpRequest& r) {
    if (const std::string id = session_of(r); !id.empty()) {
      end_session(id, "logged out");
      log(fmt::format("logout from {}", address_of(r.peer)));
    }
    web::HttpResponse res = see_other(record.empty() ? "/" : "/login");
    const bool secure = r.secure || !web::is_loopback(options.http);
    res.headers.emplace_back("Set-Cookie", fmt::format("{}=; Path=/;{} HttpOnly; SameSite=Strict; Max-Age=0",
                                                       kCookie, secure ? " Secure;" : ""));
    return res;
  }

  web::HttpResponse http(const web::HttpRequest& r) {
    if (r.path == "/login") {
      if (r.method == "POST") return login(r);
      if (record.empty() || authorized(r)) return see_other("/");
      return login_page(200, "");
    }
    if (r.path == "/logout") {
      if (r.method != "POST")
        return {.status = 405, .content_type = "text/plain; charset=utf-8", .body = "POST /logout\n"};
      return logout(r);
    }
    if (r.path == "/inverjet/login.css") return *web::asset_response(r.path);
    if (!authorized(r)) {
      if (r.path == "/" || r.path.ends_with(".html")) return see_other("/login");
      return {.status = 401, .body = R"({"error":"log in first: /login"})"};
    }
    if (r.path == "/api/session") return {.body = Json{{"auth", !record.empty()}}.dump()};
    const std::string path = r.path == "/" ? "/inverjet/panel.html" : r.path;
    if (path != "/inverjet/login.html")
      if (auto a = web::asset_response(path)) return *a;
    return {.status = 404, .content_type = "text/plain; charset=utf-8", .body = "not found\n"};
  }

  web::Handlers handlers() {
    web::Handlers h;
    h.http = [this](const web::HttpRequest& r) { return http(r); };
    h.upgrade = [this](const web::HttpRequest& r) -> std::optional<web::HttpResponse> {
      if (r.path != "/ws") return web::HttpResponse{.status = 404, .body = R"({"error":"no such endpoint"})"};
      if (!authorized(r))
        return web::HttpResponse{.status = 401, .body = R"({"error":"log in first: /login"})"};
      return std::nullopt;
    };
    h.opened = [this](const web::SocketPtr& s) {
      if (!record.empty()) {
        const std::string id = session_of(s->request());
        if (id.empty()) {  // ended between the upgrade and now
          s->close("log in first");
          return;
        }
        socket_session[s->id()] = id;
      }
      Page& page = sockets[s->id()];
      page.socket = s;
      for (const std::string& text : logic.welcome(page.welcomed)) s->send(text);
    };
    h.closed = [this](const web::SocketPtr& s) {
      sockets.erase(s->id());
      socket_session.erase(s->id());
    };
    h.message = [this](const web::SocketPtr& s, std::string_view text) {
      if (!record.empty() && !socket_session.contains(s->id())) return;
      Json m = Json::parse(text, nullptr, false);
      if (m.is_discarded() || !m.is_object() || !m.contains("op") || !m["op"].is_string()) {
        s->send(Json{{"type", "error"}, {"error", "expected a JSON object with \"op\""}}.dump());
        return;
      }
      const std::string op = m["op"].get<std::string>();
      if (op == "ping") {  // the page's check for a half-open connection
        s->send(R"({"type":"pong"})");
        return;
      }
      if (op == "check") {  // what the page typed, read by the device layer: no bus, no queue
        Json r = inverjet::check_typed(m);
        r["ok"] = r["why"].get<std::string>().empty();
        r["type"] = "result";
        r["op"] = "check";
        r["id"] = m.value("id", Json());
        s->send(r.dump(-1, ' ', false, Json::error_handler_t::replace));  // it may echo what was typed
        return;
      }
      if (op == "start" || op == "stop" || op == "plan")
        log(fmt::format("{} from {}", op, s->peer_address()));
      // A page that floods the bus is answered "busy" by the logic.
      if (logic.queue_command(s->id(), std::move(m))) worker.wake();
    };
    return h;
  }

  // ---------------------------------------------------------- web thread

  // A message of the logic's, to its page or to every page but those whose
  // welcome() already had it.
  void deliver(const PanelMessage& m) {
    if (m.to != 0) {
      if (auto it = sockets.find(m.to); it != sockets.end()) it->second.socket->send(m.text);
      return;
    }
    for (auto& [id, page] : sockets)
      if (page.welcomed < m.seq) page.socket->send(m.text);
  }
};

Panel::Panel(std::unique_ptr<io::Link> link, PanelOptions options)
    : impl_(std::make_unique<Impl>(std::move(link), std::move(options))) {}

Panel::~Panel() {
  stop();
}

rtukit::Status Panel::start() {
  Impl& p = *impl_;
  const PanelOptions& o = p.options;
  const auto bad = [](std::string why) { return rtukit::Status(Errc::invalid_argument, std::move(why)); };
  if (o.tls_cert.empty() != o.tls_key.empty()) return bad("--tls-cert and --tls-key go together");
  if (!web::is_loopback(o.http) && (o.password_file.empty() || o.tls_cert.empty()))
    return bad(fmt::format(
        "the panel on {} is reachable from the network: it needs {} (anyone who reaches it could start the "
        "machine; see docs/inverjet.md, \"Pool panel\")",
        o.http,
        o.password_file.empty() && o.tls_cert.empty()
            ? "--password-file FILE and --tls-cert FILE --tls-key FILE"
        : o.password_file.empty() ? "--password-file FILE (make it with `rtukit inverjet "
                                    "panel-password FILE`)"
                                  : "TLS: --tls-cert FILE --tls-key FILE"));
  if (!o.password_file.empty()) {
    Outcome<std::string> r = load_password_record(o.password_file);
    if (!r) return r.error();
    p.record = std::move(*r);
  }
  // A port that does not exist (or is no serial port) is a start failure: a
  // panel that could never show the machine must not look as if it served it.
  if (Error e = p.master.open())
    return rtukit::Status(Errc::io_error,
                          fmt::format("port {}: {}", p.master.describe(),
                                      e.os_error() == ENOTTY ? std::string("not a serial port")
                                      : e.os_error() != 0    ? std::string(std::strerror(e.os_error()))
                                                             : std::string(e.text())));
  p.server.every(30'000, [&p] { p.expire_sessions(); });
  if (rtukit::Status e = p.server.start()) return e;
  impl_->worker.start();
  return {};
}

void Panel::stop() {
  Impl& p = *impl_;
  p.worker.stop();
  p.server.stop();
}

std::string Panel::url() const {
  return web::listener_url(impl_->listener(), impl_->server.ports().at(0));
}

}  // namespace rtukit::programs
