// The host daemon: the host controller on its own thread (polls, leases,
// 1010), the web server on another. They meet in two places only: the
// server thread calls the Host's thread-safe commands, and the Host's
// events are posted to the server thread. Neither waits for a client.
#include "rtukit/programs/rehand_host.hpp"

#include <arpa/inet.h>
#include <fmt/core.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <qrencode.h>

#include <atomic>
#include <cstring>
#include <chrono>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <set>

#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/programs/rehand_message.hpp"
#include "rtukit/web/assets.hpp"
#include "rtukit/web/server.hpp"

namespace rtukit::programs {
namespace {

namespace rh = rehand6600;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

constexpr auto kCodeLifetime = std::chrono::minutes(2);
constexpr int kCodeAttempts = 5;

using Role = HostRole;

struct Client {
  web::SocketPtr socket;
  Role role = Role::display;
  bool paired = false;
  std::string token, name;
  std::set<uint16_t> holds;  ///< commands this client holds (released when it goes)
};

// This machine's first non-loopback IPv4 address, for a URL a phone can open.
std::string first_lan_address() {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return "127.0.0.1";
  std::string out = "127.0.0.1";
  for (ifaddrs* i = list; i; i = i->ifa_next) {
    if (!i->ifa_addr || i->ifa_addr->sa_family != AF_INET) continue;
    const auto* a = reinterpret_cast<const sockaddr_in*>(i->ifa_addr);
    if ((ntohl(a->sin_addr.s_addr) >> 24) == 127) continue;
    char text[INET_ADDRSTRLEN] = {};
    ::inet_ntop(AF_INET, &a->sin_addr, text, sizeof text);
    out = text;
    break;
  }
  ::freeifaddrs(list);
  return out;
}

// `text` as a QR code (libqrencode), as SVG with a 4-module quiet zone.
std::string qr_svg(const std::string& text) {
  QRcode* q = QRcode_encodeString(text.c_str(), 0, QR_ECLEVEL_M, QR_MODE_8, 1);
  if (!q) return {};
  const int n = q->width;
  std::string path;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      if (q->data[y * n + x] & 1) path += fmt::format("M{} {}h1v1h-1z", x + 4, y + 4);
  QRcode_free(q);
  return fmt::format(
      R"(<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {0} {0}" shape-rendering="crispEdges">)"
      R"(<rect width="{0}" height="{0}" fill="#fff"/><path d="{1}" fill="#000"/></svg>)",
      n + 8, path);
}

}  // namespace

struct HostDaemon::Impl {
  Impl(std::unique_ptr<io::Link> link, HostDaemonOptions o)
      : options(std::move(o)),
        host(std::move(link), options.host),
        pairing(options.pairing_file),
        server(listen_list(options), handlers()) {}

  static web::ServerOptions listen_list(const HostDaemonOptions& o) {
    web::ServerOptions s;
    s.listen.push_back(o.http);
    for (const std::string& p : o.phone) s.listen.push_back(p);
    return s;
  }

  web::Handlers handlers() {
    web::Handlers h;
    h.http = [this](const web::HttpRequest& r) { return http(r); };
    h.upgrade = [this](const web::HttpRequest& r) { return upgrade(r); };
    h.opened = [this](const web::SocketPtr& s) { opened(s); };
    h.message = [this](const web::SocketPtr& s, std::string_view text) { message(s, text); };
    h.closed = [this](const web::SocketPtr& s) { closed(s); };
    return h;
  }

  // ------------------------------------------------------------ HTTP

  web::HttpResponse http(const web::HttpRequest& r) {
    const bool display_listener = r.listener == 0;
    if (r.method != "GET" && r.method != "HEAD")
      return {.status = 405, .content_type = "text/plain; charset=utf-8", .body = "only GET\n"};
    std::string path = r.path;
    if (path == "/") path = display_listener ? "/rehand/hmi.html" : "/rehand/phone.html";
    if (path == "/phone") path = "/rehand/phone.html";
    if (path == "/api/state") {
      if (!display_listener && !pairing.contains(r.param("token")))
        return {.status = 401, .body = R"({"error":"not paired"})"};
      return {.body = state_json().dump()};
    }
    if (path == "/healthz") return {.body = Json{{"connected", host.connected()}}.dump()};
    if (path == "/api/pair/qr.svg" && display_listener) {
      // The phone's address with the code: scanning it opens the phone page
      // with the code filled in.
      if (code.code.empty()) return {.status = 404, .body = R"({"error":"no pairing code is shown"})"};
      return {.content_type = "image/svg+xml", .body = qr_svg(fmt::format("{}/?code={}", phone_url, code.code))};
    }
    if (auto a = web::asset_response(path)) return *a;
    return {.status = 404, .content_type = "text/plain; charset=utf-8", .body = "not found\n"};
  }

  std::optional<web::HttpResponse> upgrade(const web::HttpRequest& r) {
    if (r.path != "/ws") return web::HttpResponse{.status = 404, .body = R"({"error":"no such endpoint"})"};
    const std::string role = r.param("role");
    if (role == "display" && r.listener != 0)
      return web::HttpResponse{.status = 403,
                               .body = R"({"error":"the display connects on the display's listener"})"};
    if (role != "display" && role != "phone")
      return web::HttpResponse{.status = 400, .body = R"({"error":"role must be display or phone"})"};
    return std::nullopt;
  }

  // ------------------------------------------------------------ WebSocket

  void opened(const web::SocketPtr& s) {
    Client c{.socket = s};
    c.role = s->request().param("role") == "display" ? Role::display : Role::phone;
    if (c.role == Role::phone) {
      c.token = s->request().param("token");
      c.paired = pairing.contains(c.token);
      c.name = c.paired ? pairing.name_of(c.token) : "";
    }
    const Client& added = clients.emplace(s->id(), std::move(c)).first->second;
    Json hello{{"type", "hello"},
               {"role", added.role == Role::display ? "display" : "phone"},
               {"paired", added.role == Role::display || added.paired},
               {"client", s->id()},
               {"lease_ms", options.host.lease.count()},
               {"mph", options.mph}};
    s->send(hello.dump());
    if (added.role == Role::display || added.paired) s->send(state_json().dump());
    if (added.role == Role::phone && added.paired) broadcast_state();  // the display lists it
  }

  void closed(const web::SocketPtr& s) {
    auto it = clients.find(s->id());
    if (it == clients.end()) return;
    // Dead-man: whatever this client held stops now, not at the lease's end.
    for (uint16_t a : it->second.holds) (void)host.release(a);
    if (driver == s->id()) driver.reset();
    if (one_touch.value && one_touch.owner == s->id()) end_one_touch();
    const bool was_phone = it->second.role == Role::phone && it->second.paired;
    clients.erase(it);
    if (was_phone) broadcast_state();
  }

  void message(const web::SocketPtr& s, std::string_view text) {
    auto it = clients.find(s->id());
    if (it == clients.end()) return;
    Client& c = it->second;
    const HostMessage m = parse_host_message(text, c.role, c.paired);
    if (!m.envelope) {
      s->send(Json{{"type", "error"}, {"error", "expected a JSON object with \"op\""}}.dump());
      return;
    }
    Json result{{"type", "result"}, {"op", m.op}};
    if (m.id) result["id"] = *m.id;
    const rtukit::Status e = m.command ? run(c, *m.command, result) : m.command.error();
    result["ok"] = !e;
    if (e) result["error"] = std::string(e.reason());
    s->send(result.dump());
  }

  static rtukit::Status refuse(std::string reason) {
    return rtukit::Status(Errc::refused, std::move(reason));
  }

  rtukit::Status hold_for(Client& c, uint16_t address, uint16_t value) {
    if (rtukit::Status e = host.hold(address, value)) return e;
    c.holds.insert(address);
    return {};
  }

  rtukit::Status release_for(Client& c, uint16_t address) {
    c.holds.erase(address);
    if (Error e = host.release(address)) return rtukit::Status(e, fmt::format("release: {}", e.name()));
    return {};
  }

  // Runs a checked command (parse_host_message decided that `c` may send it).
  rtukit::Status run(Client& c, const HostCommand& k, Json& result) {
    using Kind = HostCommand::Kind;
    switch (k.kind) {
      case Kind::hold:
        return hold_for(c, k.address, k.value);
      case Kind::release:
        return release_for(c, k.address);
      case Kind::pulse:
        return host.pulse(k.address);
      case Kind::set: {
        const bool mode = k.address == rh::reg::kDriveMode;
        if (rtukit::Status e = mode ? host.set_drive_mode(k.value) : host.set_speed_level(k.value)) return e;
        (mode ? drive_mode : speed_level) = k.value;
        broadcast_state();
        return {};
      }
      case Kind::one_touch:
        if (k.value == 0) {
          end_one_touch();
          return {};
        }
        if (one_touch.value) end_one_touch();
        if (rtukit::Status e = host.hold(rh::reg::kStandSit, k.value)) return e;
        one_touch = {k.value, c.socket->id(), Clock::now(), false};
        broadcast_state();
        return {};
      case Kind::pair_start: {
        std::uniform_int_distribution<int> digits(0, 999999);
        code = {fmt::format("{:06d}", digits(random)), Clock::now() + kCodeLifetime, 0};
        broadcast_state();
        return {};
      }
      case Kind::pair_cancel:
        code = {};
        broadcast_state();
        return {};
      case Kind::revoke: {
        auto it = clients.find(k.client);
        if (it == clients.end() || it->second.role != Role::phone)
          return rtukit::Status(Errc::invalid_argument, "no such phone");
        if (rtukit::Status e = pairing.remove(it->second.token)) return e;
        web::SocketPtr s = it->second.socket;
        s->close("revoked by the display");
        closed(s);  // its holds go now, not when the close completes
        return {};
      }
      case Kind::pair: {
        if (c.paired) return {};
        if (code.code.empty() || Clock::now() > code.until)
          return refuse("no pairing code is shown: ask the display for one");
        if (k.code != code.code) {
          if (++code.attempts >= kCodeAttempts) code = {};  // guessing: the code is gone
          broadcast_state();
          return refuse("wrong code");
        }
        code = {};
        Outcome<std::string> token = pairing.add(k.name);
        if (!token) return token.error();
        c.token = *token;
        c.paired = true;
        c.name = pairing.name_of(c.token);
        result["token"] = c.token;
        result["name"] = c.name;
        c.socket->send(state_json().dump());
        broadcast_state();
        return {};
      }
      case Kind::drive: {
        if (k.address == 0) {
          for (uint16_t a = rh::reg::kPhoneForward; a <= rh::reg::kPhoneRight; ++a)
            if (c.holds.count(a)) (void)release_for(c, a);
          if (driver == c.socket->id()) driver.reset();
          broadcast_state();
          return {};
        }
        if (driver && *driver != c.socket->id()) {
          auto other = clients.find(*driver);
          return refuse(
              fmt::format("{} is driving", other != clients.end() ? other->second.name : "another phone"));
        }
        for (uint16_t b = rh::reg::kPhoneForward; b <= rh::reg::kPhoneRight; ++b)
          if (b != k.address && c.holds.count(b)) (void)release_for(c, b);
        if (rtukit::Status e = hold_for(c, k.address, 1)) return e;
        if (driver != c.socket->id()) {
          driver = c.socket->id();
          broadcast_state();
        }
        return {};
      }
      case Kind::horn:
        if (k.value) return hold_for(c, rh::reg::kPhoneHorn, 1);
        return release_for(c, rh::reg::kPhoneHorn);
    }
    return {};
  }

  void end_one_touch() {
    if (!one_touch.value) return;
    one_touch = {};
    (void)host.release(rh::reg::kStandSit);
    broadcast_state();
  }

  // Every 50 ms on the server thread: the one-touch stand/sit runs until the
  // chair reports it done, the pairing code expires.
  void tick() {
    if (one_touch.value) {
      const rh::Snapshot s = host.snapshot();
      const bool moving = s[rh::reg::kStandStatus] != 0;
      if (moving) one_touch.moved = true;
      if ((one_touch.moved && !moving) ||
          (!one_touch.moved && Clock::now() - one_touch.started > std::chrono::seconds(1)))
        end_one_touch();
      else if (host.hold(rh::reg::kStandSit, one_touch.value))
        end_one_touch();  // refused (an error, D-8): it ends here
    }
    if (!code.code.empty() && Clock::now() > code.until) {
      code = {};
      broadcast_state();
    }
  }

  // ------------------------------------------------------------ state

  Json state_json() {
    const rh::Snapshot s = host.snapshot();
    const uint16_t error = host.active_error();
    Json values = Json::object(), text = Json::object();
    for (const rh::Register& r : rh::registers()) {
      if (rh::table_of(r) != rh::Table::status || r.key.starts_with("reserved")) continue;
      values[std::string(r.key)] = s[r.address];
      text[std::string(r.key)] = rh::format_value(r, s[r.address]);
    }
    Json st{{"type", "state"},
            {"connected", host.connected() && s.valid},
            {"error", error},
            {"error_text", error ? rh::error_text(error) : ""},
            {"values", values},
            {"text", text},
            {"drive_mode", profile::name_of(*rh::find_register(rh::reg::kDriveMode), drive_mode)},
            {"speed_level", speed_level},
            {"one_touch", one_touch.value == 1   ? "stand"
                          : one_touch.value == 2 ? "sit"
                                                 : ""}};
    // Why a control is disabled, as the UI rules say (empty: allowed).
    const std::string overlay = error ? fmt::format("{} is active", rh::error_text(error)) : "";
    const bool seated = s[rh::reg::kActuatorPosition] == 0 && s[rh::reg::kActuatorPosition + 2] == 0;
    std::string drive = overlay;
    if (drive.empty() && s.charging()) drive = "no driving while charging";
    if (drive.empty() && !s.clutch_drive()) drive = "no driving with the clutch in push";
    if (drive.empty() && !seated) drive = "no phone driving while the chair is not fully seated";
    if (drive.empty() && !s.is_static() && !driver) drive = "phone drive only while the chair is static";
    std::string raise = overlay;
    if (raise.empty() && s.charging()) raise = "no standing up or raising the seat while charging";
    st["disabled"] = {{"all", overlay}, {"drive", drive}, {"raise", raise}};
    Json phones = Json::array();
    for (const auto& [id, c] : clients)
      if (c.role == Role::phone && c.paired)
        phones.push_back({{"client", id}, {"name", c.name}, {"driving", driver == id}});
    st["phones"] = phones;
    st["paired_phones"] = pairing.size();
    return st;
  }

  // The state goes to every display and paired phone; the pairing code to
  // displays only.
  void broadcast_state() {
    Json st = state_json();
    const std::string for_phones = st.dump();
    st["pairing_code"] = code.code;
    st["pairing_seconds"] =
        code.code.empty()
            ? 0
            : std::chrono::duration_cast<std::chrono::seconds>(code.until - Clock::now()).count();
    const std::string for_displays = st.dump();
    for (auto& [id, c] : clients) {
      if (c.role == Role::display)
        c.socket->send(for_displays);
      else if (c.paired)
        c.socket->send(for_phones);
    }
  }

  void broadcast(const Json& j) {
    const std::string text = j.dump();
    for (auto& [id, c] : clients)
      if (c.role == Role::display || c.paired) c.socket->send(text);
  }

  // On the server thread: what the host controller reported.
  void host_event(const rh::Event& e) {
    using T = rh::Event::Type;
    switch (e.type) {
      case T::connected:
        // The controller may have rebooted to its defaults: give it ours.
        (void)host.set_drive_mode(drive_mode);
        (void)host.set_speed_level(speed_level);
        broadcast_state();
        break;
      case T::horn:
        broadcast({{"type", "event"}, {"event", "horn"}});
        break;
      case T::view:
        broadcast({{"type", "event"}, {"event", "view"}});
        break;
      case T::error_raised:
      case T::error_cleared:
        if (e.type == T::error_raised) one_touch = {};  // the host dropped it (D-8)
        for (auto& [id, c] : clients) c.holds.clear();
        if (e.type == T::error_raised) driver.reset();
        broadcast({{"type", "event"},
                   {"event", e.type == T::error_raised ? "error_raised" : "error_cleared"},
                   {"code", e.code},
                   {"text", rh::error_text(e.code)},
                   {"reason", e.reason}});
        broadcast_state();
        break;
      case T::released: {
        const rh::Register* r = rh::find_register(e.address);
        for (auto& [id, c] : clients) c.holds.erase(e.address);
        broadcast({{"type", "event"}, {"event", "released"}, {"command", r ? std::string(r->key) : ""}});
        break;
      }
      case T::changed:
        break;
    }
  }

  HostDaemonOptions options;
  rh::Host host;
  PairingStore pairing;
  web::Server server;
  std::atomic<bool> flush_pending{false};
  // Server-thread state.
  std::map<uint64_t, Client> clients;
  std::optional<uint64_t> driver;
  uint16_t drive_mode = 1, speed_level = 1;  // D-7: the controller's power-on values
  struct OneTouch {
    uint16_t value = 0;
    uint64_t owner = 0;
    Clock::time_point started{};
    bool moved = false;
  } one_touch;
  struct Code {
    std::string code;
    Clock::time_point until{};
    int attempts = 0;
  } code;
  std::mt19937 random{std::random_device{}()};
  std::string phone_url;  ///< set by start(), read on the server thread after
  bool started = false;
};

HostDaemon::HostDaemon(std::unique_ptr<io::Link> link, HostDaemonOptions options)
    : impl_(std::make_unique<Impl>(std::move(link), std::move(options))) {}

HostDaemon::~HostDaemon() {
  stop();
}

rtukit::Status HostDaemon::start() {
  Impl& d = *impl_;
  if (d.options.pairing_file.empty()) return rtukit::Status(Errc::invalid_argument, "no pairing file given");
  if (rtukit::Status e = d.pairing.load()) return e;
  d.host.on_event([&d](const rh::Event& e) {
    if (e.type == rh::Event::Type::changed) {
      // One state message per poll, however many registers changed.
      if (!d.flush_pending.exchange(true))
        d.server.post([&d] {
          d.flush_pending = false;
          d.broadcast_state();
        });
      return;
    }
    d.server.post([&d, e] { d.host_event(e); });
  });
  d.server.every(50, [&d] { d.tick(); });
  if (rtukit::Status e = d.server.start()) return e;
  d.phone_url = d.options.phone_url;
  if (d.phone_url.empty() && !d.options.phone.empty()) {
    std::string url = web::url_of(d.options.phone[0], d.server.ports()[1]);
    for (const char* any : {"0.0.0.0", "[::]"}) {
      if (const size_t at = url.find(any); at != std::string::npos) url.replace(at, std::strlen(any), first_lan_address());
    }
    d.phone_url = url;
  }
  if (d.phone_url.empty()) d.phone_url = web::url_of(d.options.http, d.server.ports()[0]);
  d.host.start();
  d.started = true;
  return {};
}

void HostDaemon::stop() {
  Impl& d = *impl_;
  if (!d.started) return;
  d.started = false;
  d.host.stop();  // releases every hold first
  d.server.stop();
}

std::vector<uint16_t> HostDaemon::ports() const {
  return impl_->server.ports();
}

std::vector<std::string> HostDaemon::urls() const {
  std::vector<std::string> out;
  const auto ports = impl_->server.ports();
  for (size_t i = 0; i < ports.size(); ++i)
    out.push_back(web::url_of(i == 0 ? impl_->options.http : impl_->options.phone[i - 1], ports[i]));
  return out;
}

}  // namespace rtukit::programs
