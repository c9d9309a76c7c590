// The reference BLE client (rehand_ble_remote.hpp) on one thread: it owns
// the D-Bus connection, polls it together with stdin and the keys' next
// deadline, and makes its calls synchronously (signals that arrive during a
// call wait in the connection's queue until the loop processes it).
#include "rtukit/devices/rehand6600/ble_remote.hpp"

#include <fmt/core.h>
#include <poll.h>
#include <sdbus-c++/sdbus-c++.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <map>
#include <optional>
#include <regex>

#include "rtukit/base/clock.hpp"
#include "rtukit/devices/rehand6600/ble_gatt.hpp"
#include "rtukit/programs/rehand_ble_remote.hpp"
#include "rtukit/term/terminal.hpp"

namespace rtukit::programs {
namespace {

namespace gatt = rehand6600::ble;
namespace rh = rehand6600;
using Props = std::map<std::string, sdbus::Variant>;
using Interfaces = std::map<std::string, Props>;
using ManagedObjects = std::map<sdbus::ObjectPath, Interfaces>;

constexpr const char* kBluez = "org.bluez";
constexpr const char* kDeviceIface = "org.bluez.Device1";
constexpr const char* kCharIface = "org.bluez.GattCharacteristic1";
constexpr const char* kPropsIface = "org.freedesktop.DBus.Properties";

template <class T>
T value_or(const Props& props, const char* name, T fallback) {
  const auto it = props.find(name);
  if (it == props.end() || !it->second.containsValueOfType<T>()) return fallback;
  return it->second.get<T>();
}

rtukit::Status failed(Errc code, std::string why) {
  return rtukit::Status(code, fmt::format("Bluetooth LE: {}", why));
}

const char* function_name(gatt::Function f) {
  static constexpr const char* kNames[] = {"?",    "forward",     "reverse",      "left", "right",
                                           "horn", "left signal", "right signal", "light"};
  const auto i = static_cast<size_t>(f);
  return i < std::size(kNames) ? kNames[i] : "?";
}

class Remote {
 public:
  Remote(const BleRemoteOptions& o) : options_(o), keys_({.key_gap = o.key_gap}) {}

  rtukit::Status run() {
    if (!std::regex_match(options_.address, std::regex("([0-9A-Fa-f]{2}:){5}[0-9A-Fa-f]{2}")))
      return rtukit::Status(
          Errc::invalid_argument,
          fmt::format("'{}' is not a Bluetooth address (AA:BB:CC:DD:EE:FF)", options_.address));
    std::string upper = options_.address;
    std::transform(upper.begin(), upper.end(), upper.begin(),
                   [](unsigned char c) { return std::toupper(c); });
    device_path_ = fmt::format("/org/bluez/{}/dev_{}", options_.adapter,
                               std::regex_replace(upper, std::regex(":"), "_"));
    try {
      bus_ = sdbus::createSystemBusConnection();
    } catch (const sdbus::Error& e) {
      return failed(Errc::io_error, fmt::format("no system bus ({})", e.getMessage()));
    }
    try {
      if (rtukit::Status e = connect()) {
        finish();  // a connection we made for a chair we cannot use is closed again
        return e;
      }
      rtukit::Status e = loop();
      finish();
      return e;
    } catch (const sdbus::Error& e) {
      finish();
      return failed(Errc::io_error, e.getMessage());
    }
  }

 private:
  ManagedObjects objects() {
    auto root = sdbus::createProxy(*bus_, kBluez, "/");
    ManagedObjects out;
    root->callMethod("GetManagedObjects")
        .onInterface("org.freedesktop.DBus.ObjectManager")
        .withTimeout(std::chrono::seconds(5))
        .storeResultsTo(out);
    return out;
  }

  // Runs the bus for at most `d`, or until `done()`.
  bool pump_until(Clock::duration d, const std::function<bool()>& done) {
    const auto until = clock_.now() + d;
    while (!done()) {
      while (bus_->processPendingRequest()) {
      }
      if (done()) return true;
      if (clock_.now() >= until || interrupts_.interrupted()) return false;
      const sdbus::IConnection::PollData p = bus_->getEventLoopPollData();
      pollfd fd{p.fd, p.events, 0};
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - clock_.now());
      (void)::poll(&fd, 1, static_cast<int>(std::clamp<int64_t>(left.count(), 0, 50)));
    }
    return true;
  }

  rtukit::Status connect() {
    const ManagedObjects before = objects();
    if (!before.contains(sdbus::ObjectPath("/org/bluez/" + options_.adapter)))
      return failed(Errc::io_error, fmt::format("BlueZ has no adapter {}", options_.adapter));
    const auto dev = before.find(sdbus::ObjectPath(device_path_));
    if (dev == before.end() || !dev->second.contains(kDeviceIface))
      return failed(
          Errc::io_error,
          fmt::format("BlueZ on {} does not know {}: scan (bluetoothctl scan le), then pair with the "
                      "display's passkey (bluetoothctl pair {})",
                      options_.adapter, options_.address, options_.address));
    const Props& props = dev->second.at(kDeviceIface);
    if (!value_or<bool>(props, "Paired", false) && !value_or<bool>(props, "Bonded", false))
      return failed(Errc::refused,
                    fmt::format("{} is not paired: open \"Pair a phone\" on the chair's display and "
                                "run bluetoothctl pair {} (type the passkey it shows)",
                                options_.address, options_.address));
    device_ = sdbus::createProxy(*bus_, kBluez, device_path_);
    device_->uponSignal("PropertiesChanged")
        .onInterface(kPropsIface)
        .call([this](const std::string& iface, const Props& changed, const std::vector<std::string>&) {
          if (iface != kDeviceIface) return;
          if (changed.contains("Connected")) connected_ = value_or<bool>(changed, "Connected", connected_);
          if (changed.contains("ServicesResolved"))
            resolved_ = value_or<bool>(changed, "ServicesResolved", resolved_);
        });
    device_->finishRegistration();
    connected_ = value_or<bool>(props, "Connected", false);
    resolved_ = value_or<bool>(props, "ServicesResolved", false);
    fmt::print("connecting to {} ({})...\n", value_or<std::string>(props, "Alias", options_.address),
               options_.address);
    std::fflush(stdout);
    if (!connected_) {
      device_->callMethod("Connect").onInterface(kDeviceIface).withTimeout(options_.connect_timeout);
      we_connected_ = true;
      connected_ = true;
    }
    if (!pump_until(options_.connect_timeout, [this] { return resolved_; }))
      return interrupts_.interrupted()
                 ? rtukit::Status()
                 : failed(Errc::timeout, "the chair's services were not resolved in time");
    // The chair's characteristics, by UUID, under this device.
    for (const auto& [path, interfaces] : objects()) {
      const auto c = interfaces.find(kCharIface);
      if (c == interfaces.end() || !std::string(path).starts_with(device_path_ + "/")) continue;
      const std::string uuid = value_or<std::string>(c->second, "UUID", "");
      if (uuid == gatt::kStateUuid) state_path_ = path;
      if (uuid == gatt::kCommandUuid) command_path_ = path;
      if (uuid == gatt::kResultUuid) result_path_ = path;
    }
    if (state_path_.empty() || command_path_.empty() || result_path_.empty())
      return failed(Errc::refused,
                    fmt::format("{} has no Rehand 6600 service ({})", options_.address, gatt::kServiceUuid));
    command_ = sdbus::createProxy(*bus_, kBluez, command_path_);
    command_->finishRegistration();
    state_ = subscribe(state_path_, [this](const std::vector<uint8_t>& v) { on_state(v); });
    result_ = subscribe(result_path_, [this](const std::vector<uint8_t>& v) { on_result(v); });
    std::vector<uint8_t> now;
    state_->callMethod("ReadValue")
        .onInterface(kCharIface)
        .withTimeout(std::chrono::seconds(5))
        .withArguments(Props{})
        .storeResultsTo(now);
    on_state(now);
    return {};
  }

  std::unique_ptr<sdbus::IProxy> subscribe(const std::string& path,
                                           std::function<void(const std::vector<uint8_t>&)> on_value) {
    auto proxy = sdbus::createProxy(*bus_, kBluez, path);
    proxy->uponSignal("PropertiesChanged")
        .onInterface(kPropsIface)
        .call([on_value](const std::string& iface, const Props& changed, const std::vector<std::string>&) {
          const auto v = changed.find("Value");
          if (iface == kCharIface && v != changed.end() &&
              v->second.containsValueOfType<std::vector<uint8_t>>())
            on_value(v->second.get<std::vector<uint8_t>>());
        });
    proxy->finishRegistration();
    proxy->callMethod("StartNotify").onInterface(kCharIface).withTimeout(std::chrono::seconds(5));
    return proxy;
  }

  void on_state(const std::vector<uint8_t>& v) {
    const Outcome<gatt::State> s = gatt::parse_state(v);
    if (!s) return;
    std::string line = gatt::describe(*s);
    if (line == last_state_) return;
    last_state_ = line;
    fmt::print("{}\n", line);
    std::fflush(stdout);
  }

  void on_result(const std::vector<uint8_t>& v) {
    const Outcome<gatt::Result> r = gatt::parse_result(v);
    if (!r) return;
    const auto sent = sent_.find(r->sequence);
    if (sent == sent_.end()) return;  // another phone's (results go to every subscriber)
    keys_.on_result(*r);
    const gatt::Command c = sent->second;
    if (r->code == gatt::ResultCode::accepted) {
      if (c.op == gatt::Op::press || c.op == gatt::Op::pulse)
        fmt::print("{}: accepted\n", function_name(c.function));
    } else {
      static constexpr const char* kCodes[] = {"accepted", "refused", "invalid", "ended"};
      // The reason in full from its code (the text is cut to fit 20 bytes),
      // else what text came.
      const std::string_view why = r->why != rh::Reason::none && r->why != rh::Reason::other
                                       ? rh::reason_text(r->why)
                                       : std::string_view(r->reason);
      fmt::print("{}: {}{}{}\n", function_name(c.function), kCodes[static_cast<size_t>(r->code) & 3],
                 why.empty() ? "" : ": ", why);
    }
    std::fflush(stdout);
  }

  void send(const std::vector<gatt::Command>& commands) {
    for (const gatt::Command& c : commands) {
      const auto bytes = gatt::encode_command(c);
      sent_[c.sequence] = c;
      if (sent_.size() > 256) sent_.erase(sent_.begin());
      try {
        command_->callMethod("WriteValue")
            .onInterface(kCharIface)
            .withTimeout(std::chrono::seconds(2))
            .withArguments(std::vector<uint8_t>(bytes.begin(), bytes.end()),
                           Props{{"type", sdbus::Variant(std::string("request"))}});
      } catch (const sdbus::Error& e) {
        // The chair stops by itself when renewals stop: say so and go on.
        fmt::print("{}: not written ({})\n", function_name(c.function), e.getMessage());
        std::fflush(stdout);
      }
    }
  }

  rtukit::Status loop() {
    fmt::print("{}\n", gatt::RemoteKeys::help());
    std::fflush(stdout);
    term::KeysAtOnce keys_at_once;
    bool input = true;
    while (!keys_.quit() && !interrupts_.interrupted()) {
      while (bus_->processPendingRequest()) {
      }
      if (!connected_) {
        keys_.release_all();
        return failed(Errc::io_error, "the chair disconnected");
      }
      send(keys_.due(clock_.now()));
      const sdbus::IConnection::PollData p = bus_->getEventLoopPollData();
      int timeout = std::min(p.getPollTimeout() < 0 ? 1000 : p.getPollTimeout(), 1000);
      if (const auto wake = keys_.wake_at()) {
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(*wake - clock_.now()).count();
        timeout = std::min<int>(timeout, static_cast<int>(std::max<int64_t>(left, 0)));
      }
      pollfd fds[2] = {{p.fd, p.events, 0}, {input ? STDIN_FILENO : -1, POLLIN, 0}};
      if (::poll(fds, 2, timeout) <= 0) continue;  // a deadline, or a signal (EINTR)
      if (fds[1].revents & (POLLIN | POLLHUP | POLLERR)) {
        uint8_t buf[64];
        const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
        if (n <= 0) {
          input = false;  // the end of input: quit, as x does
          send(keys_.on_byte('x', clock_.now()));
          break;
        }
        for (ssize_t i = 0; i < n; ++i) send(keys_.on_byte(buf[i], clock_.now()));
      }
    }
    send(keys_.release_all());
    return {};
  }

  // Stops the notifications and disconnects what we connected: the chair
  // sees the phone go (nothing is held any more: released above).
  void finish() {
    for (auto* proxy : {state_.get(), result_.get()}) {
      if (!proxy) continue;
      try {
        proxy->callMethod("StopNotify").onInterface(kCharIface).withTimeout(std::chrono::seconds(2));
      } catch (const sdbus::Error&) {  // gone already
      }
    }
    if (we_connected_ && device_ && connected_) {
      try {
        device_->callMethod("Disconnect").onInterface(kDeviceIface).withTimeout(std::chrono::seconds(5));
      } catch (const sdbus::Error&) {  // gone already
      }
    }
  }

  BleRemoteOptions options_;
  DriverClock& clock_ = SteadyClock::instance();  // the keys' time (a terminal's keys are real-time)
  gatt::RemoteKeys keys_;
  term::Interruptible interrupts_;
  std::unique_ptr<sdbus::IConnection> bus_;
  std::string device_path_, state_path_, command_path_, result_path_;
  std::unique_ptr<sdbus::IProxy> device_, command_, state_, result_;
  bool connected_ = false, resolved_ = false, we_connected_ = false;
  std::string last_state_;
  std::map<uint16_t, gatt::Command> sent_;
};

}  // namespace

rtukit::Status run_ble_remote(const BleRemoteOptions& options) {
  return Remote(options).run();
}

}  // namespace rtukit::programs
