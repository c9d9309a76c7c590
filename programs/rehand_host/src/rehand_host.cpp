// The host daemon: the host controller on its own thread (polls, the
// session's rules, writes), the web server on another. They meet in two
// places only: the server thread calls the Host's thread-safe functions,
// none of which waits for the bus, and the Host's events are posted to the
// server thread.
#include "rtukit/programs/rehand_host.hpp"

#include <arpa/inet.h>
#include <fmt/chrono.h>
#include <fmt/core.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <qrencode.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "ble_peripheral.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/rehand6600/ble_gatt.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/views.hpp"
#include "rtukit/programs/phone_access.hpp"
#include "rtukit/programs/rehand_message.hpp"
#include "rtukit/web/assets.hpp"
#include "rtukit/web/guard.hpp"
#include "rtukit/web/server.hpp"
#include "rtukit/web/tls.hpp"
#include "rtukit/web/webcrypto.hpp"

namespace rtukit::programs {
namespace {

namespace rh = rehand6600;
using Json = nlohmann::json;
using Role = HostRole;

constexpr auto kCodeLifetime = std::chrono::minutes(2);  ///< "Pair a phone": one window, never extended
constexpr auto kHeartbeat =
    std::chrono::seconds(1);     ///< the state at least this often (pages: 3 s of silence is a loss)
constexpr int kCodeGuesses = 3;  ///< wrong codes before the code is replaced
/// Wrong codes in one window, from all addresses together, before the window
/// closes: a guesser with many addresses gets 10 tries at 1 in a million each,
/// then the display must open it again (the person at the chair sees it close).
constexpr int kWindowGuesses = 10;

/// A WebSocket: a display's (always in) or a phone's (in once PhoneAccess let it in).
struct Client {
  web::SocketPtr socket;
  Role role = Role::display;
};

std::string local_time(int64_t unix_seconds, const char* format) {
  const std::time_t t = unix_seconds;
  std::tm tm{};
  ::localtime_r(&t, &tm);
  char out[64] = {};
  std::strftime(out, sizeof out, format, &tm);
  return out;
}

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

// A six-digit code from the OS random source, uniform (rejection sampling).
std::string random_code() {
  for (;;) {
    uint32_t r = 0;
    if (!web::random_bytes(reinterpret_cast<unsigned char*>(&r), sizeof r)) return {};
    if (r >= 4294000000U) continue;  // 4294000000 is a multiple of 10^6
    return fmt::format("{:06d}", r % 1000000U);
  }
}

std::string key_of(uint16_t address) {
  const rh::Register* r = rh::find_register(address);
  return r ? std::string(r->key) : std::string();
}

}  // namespace

struct HostDaemon::Impl {
  Impl(std::unique_ptr<io::Link> link, HostDaemonOptions o)
      : options(with_clock(std::move(o))),
        clock(clock_or_steady(options.clock)),
        host(std::move(link), options.host),
        pairing(options.pairing_file),
        access(pairing, clock, random_code,
               {.window = {.lifetime = kCodeLifetime,
                           .code_guesses = kCodeGuesses,
                           .window_guesses = kWindowGuesses},
                .auth_timeout = options.auth_timeout,
                .max_age = options.pairing_max_age}) {
    if (!options.log)
      options.log = [this](const std::string& line) {
        fmt::print(stderr, "{} rehand6600 host: {}\n", local_time(unix_now(), "%Y-%m-%d %H:%M:%S"), line);
        std::fflush(stderr);
      };
  }

  // The controller runs on the daemon's clock unless it was given its own.
  static HostDaemonOptions with_clock(HostDaemonOptions o) {
    if (!o.host.clock) o.host.clock = o.clock;
    return o;
  }
  int64_t unix_now() const { return clock.unix_seconds(); }
  // The pairing store's time: the calendar, never before what its file
  // recorded (a board without a real-time clock boots in 1970).
  int64_t pairing_now() { return access.store_now(); }
  // A display is always in; a phone once it authenticated or paired.
  bool is_in(const Client& c) const { return c.role == Role::display || access.is_in(c.socket->id()); }

  void log(const std::string& line) const { options.log(line); }

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
    if (path == "/healthz") return {.body = Json{{"connected", host.connected()}}.dump()};
    // The display's own endpoints: the state and the pairing QR code exist
    // on the loopback listener only. A phone sees the state on its
    // authenticated WebSocket, and nothing tells a stranger whether a code
    // is showing.
    if (display_listener && path == "/api/state") return {.body = state_json(true).dump()};
    if (display_listener && path == "/api/pair/qr.svg") {
      if (!access.window_open()) return {.status = 404, .body = R"({"error":"no pairing code is shown"})"};
      // The code and the certificate's fingerprint in the fragment: never
      // sent to a server, never in a log; the page reads and removes it.
      return {.content_type = "image/svg+xml",
              .body = qr_svg(fmt::format("{}/#code={}&fp={}", phone_url, access.code(), fingerprint))};
    }
    if (auto a = web::asset_response(path)) return *a;
    return {.status = 404, .content_type = "text/plain; charset=utf-8", .body = "not found\n"};
  }

  std::optional<web::HttpResponse> upgrade(const web::HttpRequest& r) {
    if (r.path != "/ws") return web::HttpResponse{.status = 404, .body = R"({"error":"no such endpoint"})"};
    if (r.query.find("token") != std::string::npos || r.query.find("signature") != std::string::npos)
      return web::HttpResponse{
          .status = 400, .body = R"({"error":"no credential in a URL: authenticate in the first message"})"};
    return std::nullopt;
  }

  // ------------------------------------------------------------ WebSocket

  void opened(const web::SocketPtr& s) {
    Client c{.socket = s, .role = s->request().listener == 0 ? Role::display : Role::phone};
    // A phone's challenge: base64url of 32 random bytes, sent in the hello,
    // this connection's only (PhoneAccess::signed_text).
    std::string challenge;
    if (c.role == Role::phone) {
      std::array<unsigned char, 32> random{};
      if (!web::random_bytes(random.data(), random.size())) {
        s->close("no random numbers on the display computer");
        return;
      }
      challenge = web::base64url({reinterpret_cast<const char*>(random.data()), random.size()});
      access.connected(s->id(), challenge);
    }
    clients.emplace(s->id(), c);
    if (c.role == Role::display) host.join(s->id(), rh::ClientKind::display);
    Json hello{{"type", "hello"},
               {"role", c.role == Role::display ? "display" : "phone"},
               {"authenticated", c.role == Role::display},
               {"client", s->id()},
               {"lease_ms", options.host.lease.count()},
               {"auth_timeout_ms", std::chrono::milliseconds(options.auth_timeout).count()},
               {"mph", options.mph}};
    if (c.role == Role::phone) hello["challenge"] = challenge;
    s->send(hello.dump());
    if (c.role == Role::display) s->send(state_json(true).dump());
  }

  void closed(const web::SocketPtr& s) {
    auto it = clients.find(s->id());
    if (it == clients.end()) return;
    // The session decides what losing this client means: a phone that was
    // driving is a loss of control (the stop command), anything else ends.
    host.leave(s->id());
    clients.erase(it);
    const std::string phone = access.left(s->id());
    if (!phone.empty()) {
      remember_gone(s->id(), name_of(phone));
      (void)access.touch(phone);
      log(fmt::format("phone '{}' ({}) disconnected from {}", name_of(phone), phone, s->peer_address()));
      broadcast_state();
    }
  }

  void message(const web::SocketPtr& s, std::string_view text) {
    auto it = clients.find(s->id());
    if (it == clients.end()) return;
    Client& c = it->second;
    const HostMessage m = parse_host_message(text, c.role, is_in(c));
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

  std::string name_of(const std::string& phone) const {
    const PairedPhone* p = pairing.phone(phone);
    return p ? p->name : "a forgotten phone";
  }

  // PhoneAccess let `c` in as a.phone: its older connections close (one
  // per phone, the newest wins), it joins the session, the phone hears who it is.
  void admitted(Client& c, const PhoneAccess::Admission& a, Json& result) {
    for (const uint64_t id : a.replaced) {
      if (auto it = clients.find(id); it != clients.end())
        it->second.socket->close("replaced by a new connection");
      host.leave(id);  // at once, not when the close completes
      tell_displays(
          {{"type", "event"}, {"event", "replaced"}, {"phone", a.phone}, {"name", name_of(a.phone)}});
      log(fmt::format("phone '{}' ({}) connected again: the older connection is closed", name_of(a.phone),
                      a.phone));
    }
    host.join(c.socket->id(), rh::ClientKind::phone);
    result["phone"] = a.phone;
    result["name"] = name_of(a.phone);
    result["client"] = c.socket->id();
  }

  // Closes every connection of `phone` (forgotten): its presses end now.
  void drop_phone(const std::string& phone, const std::string& why) {
    for (const uint64_t id : access.drop(phone)) {
      if (auto it = clients.find(id); it != clients.end()) it->second.socket->close(why);
      host.leave(id);
    }
  }

  // Runs a checked command (parse_host_message decided that `c` may send it;
  // the session decides whether the chair may do it now).
  rtukit::Status run(Client& c, const HostCommand& k, Json& result) {
    using Kind = HostCommand::Kind;
    const uint64_t me = c.socket->id();
    switch (k.kind) {
      case Kind::press:
        if (rtukit::Status e = may_drive(access.phone_of(me), k.address)) return e;
        return host.press(me, k.address, k.value, k.press);
      case Kind::renew:
        return host.renew(me, k.press);
      case Kind::release:
        host.release_press(me, k.press);
        return {};
      case Kind::stop:
        host.stop_all();
        log("the display's STOP: every command released, the stop command (0x006A) held until lifted");
        broadcast_state();
        return {};
      case Kind::lift_stop:
        host.lift_stop();
        log("the display lifted STOP: 0x006A is released once the chair is still");
        broadcast_state();
        return {};
      case Kind::pulse:
        return host.send(me, k.address, 1);
      case Kind::set: {
        if (rtukit::Status e = host.send(me, k.address, k.value)) return e;
        broadcast_state();
        return {};
      }
      case Kind::pair_start: {
        if (!access.open_window()) return rtukit::Status(Errc::io_error, "no random numbers (getrandom)");
        if (ble) ble->set_pairing(true);
        update_advertising();
        log("pairing code shown on the display");
        broadcast_state();
        return {};
      }
      case Kind::pair_cancel:
        close_pairing();
        broadcast_state();
        return {};
      case Kind::forget: {
        if (k.phone.starts_with("ble:")) return ble_forget(k.phone);
        const std::string name = name_of(k.phone);
        if (rtukit::Status e = pairing.remove(k.phone)) return e;
        drop_phone(k.phone, "this phone was forgotten by the display");
        log(fmt::format("phone '{}' ({}) forgotten by the display", name, k.phone));
        broadcast_state();
        return {};
      }
      case Kind::confirm: {
        if (k.phone.starts_with("ble:") && !ble_bonded(k.phone))
          return rtukit::Status(Errc::invalid_argument, fmt::format("no such phone '{}'", k.phone));
        if (rtukit::Status e = pairing.confirm(k.phone)) return e;
        log(fmt::format("phone '{}' ({}) allowed to drive by the display", display_name_of(k.phone),
                        k.phone));
        broadcast_state();
        return {};
      }
      case Kind::forget_all: {
        std::vector<std::string> ids;
        for (const PairedPhone& p : pairing.phones()) ids.push_back(p.id);
        if (rtukit::Status e = pairing.remove_all()) return e;
        for (const std::string& id : ids) drop_phone(id, "every phone was forgotten by the display");
        if (ble)
          for (const BleDevice& b : ble->devices())
            if (b.bonded) (void)ble_forget(ble_id(b.path));
        log(fmt::format("every phone forgotten by the display ({})", ids.size()));
        broadcast_state();
        return {};
      }
      case Kind::auth: {
        const std::string& from = c.socket->peer_address();
        const PhoneAccess::Admission a = access.authenticate(me, from, k.phone, k.signature);
        if (a.error) return a.error;
        admitted(c, a, result);
        log(fmt::format("phone '{}' ({}) connected from {}", name_of(a.phone), a.phone, from));
        c.socket->send(state_json(false).dump());
        broadcast_state();
        return {};
      }
      case Kind::pair: {
        const std::string& from = c.socket->peer_address();
        const PhoneAccess::Admission a = access.pair(me, from, k.code, k.name, k.public_key, k.signature);
        if (a.guess == PairingWindow::Guess::window_closed) {
          log(
              fmt::format("pairing closed: {} wrong codes while it was open (last from {}); open \"Pair a "
                          "phone\" again on the display",
                          kWindowGuesses, from));
          close_pairing();
          broadcast_state();
        } else if (a.guess == PairingWindow::Guess::code_replaced) {
          log(fmt::format("pairing code guessed at {} times (last from {}): replaced", kCodeGuesses, from));
          broadcast_state();
        }
        if (a.error) return a.error;
        // One "Pair a phone", one phone: the window closes for both links
        // (before, a web pairing left the Bluetooth window open).
        close_pairing();
        admitted(c, a, result);
        log(fmt::format("phone '{}' ({}) paired from {} with the display's code", name_of(a.phone), a.phone,
                        from));
        c.socket->send(state_json(false).dump());
        broadcast_state();
        return {};
      }
    }
    return {};
  }

  // Every 50 ms on the server thread: unauthenticated phones time out, the
  // pairing code expires, the state follows the clock (last contact).
  void tick() {
    const auto now = clock.now();
    // A heartbeat: the state at least once a second, changed or not, so a
    // page that hears nothing for 3 s knows the daemon is gone or frozen
    // (common.js SILENT_MS) instead of showing its last state as live.
    if (now - last_state_sent >= kHeartbeat) broadcast_state();
    for (const uint64_t id : access.timed_out())
      if (auto it = clients.find(id); it != clients.end()) it->second.socket->close("authentication timeout");
    if (access.expire_window()) {
      close_pairing();
      broadcast_state();
    }
    // With --ble, once the link is up: an expired bond is removed from BlueZ, not only from the file.
    const bool ble_ready = options.ble_adapter.empty() || ble;
    if (ble_ready) {
      const auto days = options.pairing_max_age.count() / 86400;
      const std::vector<PairingStore::Forgotten> forgotten = access.expire_unused();
      for (const PairingStore::Forgotten& p : forgotten) {
        if (p.id.starts_with("ble:")) {
          if (!remove_bond(p.id, fmt::format("forgotten: unused for more than {} days", days)))
            log(fmt::format("Bluetooth phone {} forgotten: unused for more than {} days", p.id, days));
          continue;
        }
        drop_phone(p.id, "this pairing expired");
        log(fmt::format("phone '{}' ({}) forgotten: unused for more than {} days", p.name, p.id, days));
      }
      if (ble && !forgotten.empty()) broadcast_state();
    }
    const rh::HostState hs = host.state();
    if (hs.connected && hs.snapshot.valid && hs.snapshot.sequence != last_sequence) {
      last_sequence = hs.snapshot.sequence;
      last_contact = clock.wall();
      publish_ble_state();  // a new reading: the counter moved (published only when the bytes differ)
    }
    const bool near = hs.near_obstacle;
    if (near && !near_obstacle) broadcast({{"type", "event"}, {"event", "near_obstacle"}});
    near_obstacle = near;
  }

  // ------------------------------------------------------------ Bluetooth LE

  // A BLE phone is named in the display's list by its address.
  std::string ble_id(const std::string& path) const {
    if (ble)
      for (const BleDevice& b : ble->devices())
        if (b.path == path) return "ble:" + b.address;
    return "ble:" + path;
  }
  // A phone's name for the session's events about it, also once it has gone:
  // a lost phone's stop is announced after its connection closed. The last
  // few are kept (one per phone that left since).
  void remember_gone(uint64_t client, std::string name) {
    gone_names.emplace_back(client, std::move(name));
    if (gone_names.size() > 16) gone_names.erase(gone_names.begin());
  }
  std::string client_name(uint64_t client) const {
    if (const std::string phone = access.phone_of(client); !phone.empty()) return name_of(phone);
    if (std::string ble_phone = ble_name(client); !ble_phone.empty()) return ble_phone;
    for (const auto& [id, name] : gone_names)
      if (id == client) return name;
    return {};
  }

  // The name of the BLE phone behind session client `client`, "" when it is none.
  std::string ble_name(uint64_t client) const {
    for (const auto& [path, id] : ble_clients) {
      if (id != client) continue;
      if (ble)
        for (const BleDevice& b : ble->devices())
          if (b.path == path) return b.name;
      return path;
    }
    return {};
  }

  void close_pairing() {
    access.close_window();
    ble_passkey.clear();
    ble_passkey_for.clear();
    if (ble) ble->set_pairing(false);
    update_advertising();
  }

  // A bonded phone wrote a command: the session decides, the result goes back
  // on the result characteristic. The phone joins the session at its first command.
  void ble_command(const std::string& device, const std::vector<uint8_t>& bytes) {
    namespace ble_gatt = rh::ble;
    const Outcome<ble_gatt::Command> c = ble_gatt::parse_command(bytes);
    if (!c) {
      const uint16_t sequence =
          bytes.size() == ble_gatt::kCommandSize ? static_cast<uint16_t>(bytes[8] | bytes[9] << 8) : 0;
      ble->publish_result(ble_gatt::encode_result({.sequence = sequence,
                                                   .code = ble_gatt::ResultCode::invalid,
                                                   .reason = std::string(c.error().reason())}));
      return;
    }
    (void)pairing.touch(ble_id(device), pairing_now());  // recorded once a minute at most
    uint64_t& id = ble_clients[device];
    if (id == 0) {
      id = next_ble_client++;
      host.join(id, rh::ClientKind::phone);
      log(fmt::format("Bluetooth phone '{}' ({}) connected", ble_name(id), ble_id(device)));
    }
    const uint16_t address = ble_gatt::register_of(c->function);
    rtukit::Status e;
    switch (c->op) {
      case ble_gatt::Op::press:
        e = may_drive(ble_id(device), address);
        if (!e) e = host.press(id, address, 1, c->press);
        break;
      case ble_gatt::Op::renew:
        e = host.renew(id, c->press);
        break;
      case ble_gatt::Op::release:
        host.release_press(id, c->press);
        break;
      case ble_gatt::Op::pulse:
        e = host.send(id, address, 1);
        break;
    }
    ble->publish_result(ble_gatt::encode_result(ble_gatt::result_of(*c, e)));
  }

  // The phone's link is gone: the session treats it as a loss of control
  // when it was driving (the stop command), like a web phone's socket.
  void ble_gone(const std::string& device, std::string_view why) {
    const auto it = ble_clients.find(device);
    if (it == ble_clients.end()) return;
    log(fmt::format("Bluetooth phone '{}' ({}) {}", ble_name(it->second), ble_id(device), why));
    remember_gone(it->second, ble_name(it->second));
    host.leave(it->second);
    ble_clients.erase(it);
    broadcast_state();
  }

  void ble_show_passkey(const std::string& device, uint32_t passkey) {
    ble_passkey = device.empty() ? std::string() : fmt::format("{:06d}", passkey);
    // Whose passkey it is: the person at the display checks it is their phone.
    ble_passkey_for = device.empty() ? std::string() : ble_device_name(device);
    if (!device.empty()) {
      log(fmt::format("Bluetooth pairing: passkey shown on the display for '{}' ({})", ble_passkey_for,
                      ble_id(device)));
      // A new bond is a new phone to the person at the display (R-18), even
      // at an address allowed before (a bond removed elsewhere, then made again).
      (void)pairing.remove(ble_id(device));
    }
    broadcast_state();
  }

  // A Bluetooth device's name as BlueZ knows it (cleaned: phone_name), else its address.
  std::string ble_device_name(const std::string& path) const {
    if (ble)
      for (const BleDevice& b : ble->devices())
        if (b.path == path) return b.name;
    return ble_id(path);
  }

  // R-18: a phone drives once the display's user allowed it, seeing its
  // name; until then its drive presses are refused, saying where to allow
  // it (its horn, light and signals need no leave: they move nothing).
  rtukit::Status may_drive(const std::string& phone, uint16_t command) const {
    if (phone.empty() || !rh::reg::is_phone_drive(command) || pairing.confirmed(phone)) return {};
    return rtukit::Status(Errc::refused, std::string(rh::reason_text(rh::Reason::not_allowed)));
  }

  bool ble_bonded(const std::string& phone) const {
    if (ble)
      for (const BleDevice& b : ble->devices())
        if (b.bonded && ble_id(b.path) == phone) return true;
    return false;
  }

  std::string display_name_of(const std::string& phone) const {
    if (!phone.starts_with("ble:")) return name_of(phone);
    if (ble)
      for (const BleDevice& b : ble->devices())
        if (ble_id(b.path) == phone) return b.name;
    return phone;
  }

  rtukit::Status ble_forget(const std::string& phone) {
    if (!ble) return rtukit::Status(Errc::invalid_argument, "no Bluetooth LE link");
    if (!remove_bond(phone, "forgotten by the display"))
      return rtukit::Status(Errc::invalid_argument, fmt::format("no such phone '{}'", phone));
    return {};
  }

  // Ends Bluetooth phone `phone`'s link, its record (its leave to drive
  // goes with it) and its bond in BlueZ. False when BlueZ lists no such device.
  bool remove_bond(const std::string& phone, const std::string& why) {
    (void)pairing.remove(phone);
    if (!ble) return false;
    for (const BleDevice& b : ble->devices()) {
      if (ble_id(b.path) != phone) continue;
      ble_gone(b.path, why);
      // Until BlueZ reports the bond gone, its listing is no new bond.
      ble_forgetting.insert(b.path);
      ble->forget(b.path);
      log(fmt::format("Bluetooth phone '{}' ({}) {}: its bond removed", b.name, phone, why));
      update_advertising();
      return true;
    }
    return false;
  }

  // BlueZ's bonds and the store's records, after BlueZ reported a change: a
  // bond gets its record (a new phone, not allowed to drive; its 30 days
  // start), and the chair advertises only while it should.
  void ble_sync() {
    if (!ble) return;
    const std::vector<BleDevice> devices = ble->devices();
    std::erase_if(ble_forgetting, [&](const std::string& path) {
      return std::none_of(devices.begin(), devices.end(),
                          [&](const BleDevice& b) { return b.path == path && b.bonded; });
    });
    for (const BleDevice& b : devices)
      if (b.bonded && !ble_forgetting.contains(b.path)) (void)pairing.bonded(ble_id(b.path), pairing_now());
    update_advertising();
    broadcast_state();
  }

  // Privacy: the chair advertises only while a bonded phone may connect or
  // the pairing window is open; at any other time nothing in radio range
  // tells that a chair is there (docs/rehand6600-ble.md, "Advertising").
  void update_advertising() {
    if (!ble) return;
    bool bonded = false;
    for (const BleDevice& b : ble->devices())
      bonded = bonded || (b.bonded && !ble_forgetting.contains(b.path));
    ble->set_advertising(bonded || access.window_open());
  }

  // ------------------------------------------------------------ state

  // The phone id of a client: a Wi-Fi phone's, or "ble:ADDRESS"; "" for the display.
  std::string phone_id_of(rh::Host::ClientId id) {
    for (const auto& [path, client] : ble_clients)
      if (client == id) return ble_id(path);
    return access.phone_of(id);
  }

  Json state_json(bool for_display) {
    // The chair's part from the device layer (views.hpp), from one reading
    // of the host taken under its lock; the daemon adds its connections.
    const rh::HostState hs = host.state();
    std::string driver;
    if (hs.driver) driver = phone_id_of(*hs.driver);
    const int64_t contact_ms =
        last_contact
            ? std::chrono::duration_cast<std::chrono::milliseconds>(last_contact->time_since_epoch()).count()
            : 0;
    Json st{{"type", "state"},
            {"last_contact", contact_ms ? local_time(contact_ms / 1000, "%H:%M:%S") : ""},
            {"last_contact_ms", contact_ms}};
    st.update(rh::state_view(hs, {.owner =
                                      [this](rh::Host::ClientId c) {
                                        const std::string ble_phone = ble_name(c);
                                        if (!ble_phone.empty()) return ble_phone;
                                        const std::string phone = access.phone_of(c);
                                        return phone.empty() ? std::string("display") : name_of(phone);
                                      },
                                  .phone = [this](rh::Host::ClientId c) { return phone_id_of(c); }}));
    if (!for_display) return st;
    st["pairing_code"] = access.code();
    st["pairing_seconds"] = std::chrono::duration_cast<std::chrono::seconds>(access.window_left()).count();
    st["fingerprint"] = fingerprint;
    Json phones = Json::array();
    for (const PairedPhone& p : pairing.phones()) {
      const bool connected = access.is_connected(p.id);
      phones.push_back({{"phone", p.id},
                        {"name", p.name},
                        {"paired_code", p.code},
                        {"connected", connected},
                        {"driving", !driver.empty() && driver == p.id},
                        {"confirmed", p.confirmed},
                        {"last_contact", local_time(p.last_contact, "%Y-%m-%d %H:%M:%S")}});
    }
    // Bonded Bluetooth phones in the same list, "ble:ADDRESS" (forget removes the bond).
    if (ble) {
      for (const BleDevice& b : ble->devices()) {
        if (!b.bonded) continue;
        const BluetoothPhone* record = pairing.bluetooth_phone(ble_id(b.path));
        phones.push_back(
            {{"phone", ble_id(b.path)},
             {"name", b.name},
             {"paired_code", ""},
             {"link", "ble"},
             {"connected", b.connected},
             {"driving", !driver.empty() && driver == ble_id(b.path)},
             {"confirmed", pairing.confirmed(ble_id(b.path))},
             {"last_contact", record ? local_time(record->last_contact, "%Y-%m-%d %H:%M:%S") : ""}});
      }
      st["ble_passkey"] = ble_passkey.empty() ? "" : ble_passkey;
      st["ble_passkey_for"] = ble_passkey.empty() ? "" : ble_passkey_for;
    }
    st["phones"] = phones;
    return st;
  }

  // The Bluetooth state: its counter (byte 17) moves with every reading, so
  // it is notified at every poll even when nothing else changed, and a phone
  // whose notifications stop knows its link is stale (docs/rehand6600-ble.md).
  void publish_ble_state() {
    if (!ble) return;
    const rh::HostState hs = host.state();
    const auto b = rh::ble::encode_state({.snapshot = hs.snapshot,
                                          .active_error = hs.active_error,
                                          .disabled = hs.disabled,
                                          .phone_driving = hs.driver.has_value(),
                                          .emergency = hs.emergency});
    ble->publish_state(std::vector<uint8_t>(b.begin(), b.end()));
  }

  // The state goes to every display and authenticated phone; the pairing
  // code, the fingerprint and the phone list to displays only.
  void broadcast_state() {
    publish_ble_state();
    send_to_all(state_json(true).dump(), state_json(false).dump());
    last_state_sent = clock.now();
  }

  // One text to the displays, another to the authenticated phones.
  void send_to_all(const std::string& for_displays, const std::string& for_phones) {
    for (auto& [id, c] : clients) {
      if (c.role == Role::display)
        c.socket->send(for_displays);
      else if (access.is_in(id))
        c.socket->send(for_phones);
    }
  }

  void broadcast(const Json& j) {
    const std::string text = j.dump();
    send_to_all(text, text);
  }

  // An event that names a phone: the displays only. A phone hears no other
  // phone's name or id (and a phone page took any "replaced" for its own
  // and left its link, as every other phone did when one connected again).
  void tell_displays(const Json& j) {
    const std::string text = j.dump();
    for (auto& [id, c] : clients)
      if (c.role == Role::display) c.socket->send(text);
  }

  // On the server thread: what the host controller reported.
  void host_event(const rh::Event& e) {
    using T = rh::Event::Type;
    switch (e.type) {
      case T::connected:
        // The controller may have rebooted to its defaults: give it ours.
        {
          const rh::HostState hs = host.state();
          (void)host.send(rh::Host::kLocalClient, rh::reg::kDriveMode, hs.drive_mode);
          (void)host.send(rh::Host::kLocalClient, rh::reg::kSpeedLevel, hs.chosen_speed);
        }
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
        if (e.code == rh::kMasterCommunicationError)
          log(e.type == T::error_raised ? fmt::format("link to the controller lost: {}", e.reason)
                                        : "link to the controller recovered");
        broadcast({{"type", "event"},
                   {"event", e.type == T::error_raised ? "error_raised" : "error_cleared"},
                   {"code", e.code},
                   {"text", rh::error_text(e.code)},
                   {"reason", e.reason}});
        broadcast_state();
        break;
      case T::released: {
        // The owner hears why its press ended (a lapse, an error, Stop).
        if (auto it = clients.find(e.client); it != clients.end())
          it->second.socket->send(Json{
              {"type", "event"},
              {"event", "released"},
              {"command", key_of(e.address)},
              {"press", e.press},
              {"reason", e.reason},
              {"emergency",
               e.emergency}}.dump());
        broadcast_state();
        break;
      }
      case T::emergency_started:
      case T::emergency_ended:
        log(e.type == T::emergency_started ? fmt::format("emergency stop (0x006A): {}", e.reason)
                                           : "the chair is still: emergency stop released");
        // Which phone and why, for the display to say (a stop nobody
        // explains looks like a fault of the chair).
        {
          Json event{{"type", "event"},
                     {"event", e.type == T::emergency_started ? "emergency" : "emergency_ended"},
                     {"reason", e.reason}};
          const std::string for_phones = event.dump();  // that it stopped and why, never whose phone
          event["phone"] = e.type == T::emergency_started && e.client ? client_name(e.client) : "";
          send_to_all(event.dump(), for_phones);
        }
        broadcast_state();
        break;
      case T::driver_changed:
        broadcast_state();
        break;
      case T::chair_stopped:
        break;  // the session ended the press: its owner hears why in a `released` event
      case T::write_failed:
        broadcast({{"type", "event"},
                   {"event", "write_failed"},
                   {"command", key_of(e.address)},
                   {"reason", e.reason}});
        break;
      case T::changed:
        break;
    }
  }

  HostDaemonOptions options;
  DriverClock& clock;
  rh::Host host;
  PairingStore pairing;
  PhoneAccess access;  ///< who is in: pairing, guesses, authentication, expiry (phone_access.hpp)
  std::unique_ptr<web::Server> server;
  std::unique_ptr<BlePeripheral> ble;  ///< --ble: set by start() before the server runs its handlers
  std::atomic<bool> flush_pending{false};
  // Server-thread state.
  std::map<uint64_t, Client> clients;
  std::optional<std::chrono::system_clock::time_point> last_contact;
  Clock::time_point last_state_sent{};  ///< broadcast_state(): the heartbeat's start
  uint64_t last_sequence = 0;
  bool near_obstacle = false;
  std::vector<std::pair<uint64_t, std::string>> gone_names;  ///< remember_gone()
  std::map<std::string, uint64_t> ble_clients;    ///< a BLE phone's device path -> its session client
  std::set<std::string> ble_forgetting;           ///< device paths whose bond is being removed
  uint64_t next_ble_client = uint64_t{1} << 62;   ///< apart from the web sockets' ids
  std::string ble_passkey;                        ///< shown on the display while a phone pairs
  std::string ble_passkey_for;                    ///< the name of the phone that passkey is for
  std::string phone_url, fingerprint, cert_path;  ///< set by start(), read on the server thread after
  bool started = false;
};

HostDaemon::HostDaemon(std::unique_ptr<io::Link> link, HostDaemonOptions options)
    : impl_(std::make_unique<Impl>(std::move(link), std::move(options))) {}

HostDaemon::~HostDaemon() {
  stop();
}

rtukit::Status HostDaemon::start() {
  Impl& d = *impl_;
  const HostDaemonOptions& o = d.options;
  const auto bad = [](std::string why) { return rtukit::Status(Errc::invalid_argument, std::move(why)); };
  if (o.pairing_file.empty()) return bad("no pairing file given");
  if (!web::is_loopback(o.http))
    return bad(
        fmt::format("the display listener {} must be a loopback address (127.0.0.1:PORT): it has no "
                    "authentication, only the kiosk browser on this board may reach it",
                    o.http));
  if (o.tls_cert.empty() != o.tls_key.empty()) return bad("--tls-cert and --tls-key go together");
  if (rtukit::Status e = d.pairing.load(d.unix_now())) return e;
  web::ServerOptions so;
  so.clock = &d.clock;
  so.listen.push_back(web::Listener::from(o.http));
  if (!o.phone.empty()) {
    const std::filesystem::path beside = std::filesystem::path(o.pairing_file).parent_path();
    d.cert_path = o.tls_cert.empty() ? (beside / "rehand6600-phone.crt").string() : o.tls_cert;
    const std::string key = o.tls_key.empty() ? (beside / "rehand6600-phone.key").string() : o.tls_key;
    if (rtukit::Status e = web::ensure_self_signed(d.cert_path, key, first_lan_address())) return e;
    Outcome<std::string> fp = web::certificate_fingerprint(d.cert_path);
    if (!fp) return fp.error();
    d.fingerprint = *fp;
    for (const std::string& p : o.phone) {
      web::Listener l = web::Listener::from(p);
      l.tls = web::TlsFiles{d.cert_path, key};
      l.max_connections = 16;
      // A phone's browser loads the page's modules over up to 6 parallel
      // HTTP/1.1 connections and keeps them open beside its WebSocket: with 4
      // a page of 7 files had its WebSocket refused (the browser test). 8 of
      // 16 leaves a stranger's one address half the slots, the owner the rest.
      l.max_per_source = 8;
      l.host_names = o.host_names;
      so.listen.push_back(std::move(l));
    }
  }
  d.server = std::make_unique<web::Server>(std::move(so), d.handlers());
  d.host.on_event([&d](const rh::Event& e) {
    if (e.type == rh::Event::Type::changed) {
      // One state message per poll, however many registers changed.
      if (!d.flush_pending.exchange(true))
        d.server->post([&d] {
          d.flush_pending = false;
          d.broadcast_state();
        });
      return;
    }
    d.server->post([&d, e] { d.host_event(e); });
  });
  d.server->every(50, [&d] { d.tick(); });
  // Read before the server's thread runs: from then on the pairing store and
  // the phone URL are that thread's (its tick expires pairings).
  const size_t paired = d.pairing.size();
  const bool ble_phones_known = !d.pairing.bluetooth().empty();
  for (const std::string& name : d.pairing.legacy_dropped())
    d.log(fmt::format("phone '{}' paired with a token before phones signed with a key: pair it again", name));
  if (rtukit::Status e = d.server->start()) return e;
  std::string phone_url = o.phone_url;
  if (phone_url.empty() && !o.phone.empty()) {
    phone_url = urls()[1];  // the bound port is known only now
    for (const char* any : {"0.0.0.0", "[::]"}) {
      if (const size_t at = phone_url.find(any); at != std::string::npos)
        phone_url.replace(at, std::strlen(any), first_lan_address());
    }
  }
  d.server->post([&d, phone_url] { d.phone_url = phone_url; });
  if (!o.ble_adapter.empty()) {
    BleHandlers h;
    h.command = [&d](const std::string& device, std::vector<uint8_t> value) {
      d.server->post([&d, device, value = std::move(value)] { d.ble_command(device, value); });
    };
    h.disconnected = [&d](const std::string& device) {
      d.server->post([&d, device] { d.ble_gone(device, "disconnected"); });
    };
    h.unsubscribed = [&d] {
      d.server->post([&d] {
        const auto gone = d.ble_clients;
        for (const auto& [device, id] : gone) d.ble_gone(device, "stopped listening");
      });
    };
    h.passkey = [&d](const std::string& device, uint32_t passkey) {
      d.server->post([&d, device, passkey] { d.ble_show_passkey(device, passkey); });
    };
    h.devices_changed = [&d] { d.server->post([&d] { d.ble_sync(); }); };
    // Advertising from the start only when a bonded phone may connect
    // (ble_sync then follows BlueZ's list of bonds).
    Outcome<std::unique_ptr<BlePeripheral>> ble = BlePeripheral::start(
        {.adapter = o.ble_adapter, .advertise = ble_phones_known}, std::move(h), d.clock);
    if (!ble) {
      d.server->stop();
      return ble.error();
    }
    // Handed to the server thread, which reads it from then on.
    std::promise<void> handed;
    d.server->post([&d, &ble, &handed] {
      d.ble = std::move(*ble);
      d.ble_sync();
      handed.set_value();
    });
    handed.get_future().wait();
  }
  d.host.start();
  d.started = true;
  d.log(fmt::format("started: display {}, {} phone listener(s), {} paired phone(s)", o.http, o.phone.size(),
                    paired));
  for (const std::string& p : o.phone) {
    // Every address: the phones' hotspot, and every other network the board
    // joins (Ethernet, LTE), where strangers can reach the pairing page.
    if (p.starts_with("0.0.0.0:") || p.starts_with("[::]:"))
      d.log(
          fmt::format("warning: --phone {} listens on every network this board joins (Ethernet, LTE, the "
                      "hotspot); give the hotspot's own address instead, e.g. 192.168.4.1{}",
                      p, p.substr(p.rfind(':'))));
  }
  return {};
}

void HostDaemon::stop() {
  Impl& d = *impl_;
  if (!d.started) return;
  d.started = false;
  d.host.stop();                                       // releases every hold first
  if (d.ble) d.server->post([&d] { d.ble.reset(); });  // unregistered from BlueZ on the server thread
  d.server->stop();
  d.log("stopped: every command released");
}

std::vector<uint16_t> HostDaemon::ports() const {
  return impl_->server ? impl_->server->ports() : std::vector<uint16_t>{};
}

std::vector<std::string> HostDaemon::urls() const {
  std::vector<std::string> out;
  const auto p = ports();
  for (size_t i = 0; i < p.size(); ++i) {
    std::string url = web::url_of(i == 0 ? impl_->options.http : impl_->options.phone[i - 1], p[i]);
    if (i > 0 && url.starts_with("http://")) url.replace(0, 4, "https");
    out.push_back(std::move(url));
  }
  return out;
}

std::string HostDaemon::fingerprint() const {
  return impl_->fingerprint;
}

std::string HostDaemon::certificate() const {
  return impl_->cert_path;
}

}  // namespace rtukit::programs
