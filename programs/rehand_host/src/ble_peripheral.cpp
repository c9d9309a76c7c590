// The BLE link on BlueZ's D-Bus API (ble_peripheral.hpp), with sdbus-c++.
//
// Why its own loop thread instead of sdbus-c++'s: one thread owns the
// connection and makes every call on it (sd-bus is not thread-safe), and
// the registrations are asynchronous: BlueZ calls GetManagedObjects back on
// the application before RegisterApplication returns (and reads the
// advertisement's properties before RegisterAdvertisement returns), so a
// synchronous call there would wait for itself. The daemon's calls are
// posted to the thread through an eventfd.
#include "ble_peripheral.hpp"

#include <fmt/core.h>
#include <poll.h>
#include <sdbus-c++/sdbus-c++.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

#include "rtukit/base/clock.hpp"
#include "rtukit/devices/rehand6600/ble_gatt.hpp"
#include "rtukit/programs/rehand_message.hpp"
#include "rtukit/web/guard.hpp"

namespace rtukit::programs {
namespace {

namespace gatt = rehand6600::ble;
using Options = std::map<std::string, sdbus::Variant>;
using Interfaces = std::map<std::string, std::map<std::string, sdbus::Variant>>;
using ManagedObjects = std::map<sdbus::ObjectPath, Interfaces>;

constexpr const char* kBluez = "org.bluez";
constexpr const char* kAdapterIface = "org.bluez.Adapter1";
constexpr const char* kDeviceIface = "org.bluez.Device1";
constexpr const char* kServiceIface = "org.bluez.GattService1";
constexpr const char* kCharIface = "org.bluez.GattCharacteristic1";
constexpr const char* kAdvertIface = "org.bluez.LEAdvertisement1";
constexpr const char* kAgentIface = "org.bluez.Agent1";
// The application's tree (its ObjectManager root) holds the service and its
// characteristics only; the advertisement and the agent live beside it.
constexpr const char* kApp = "/com/rtukit/rehand6600";
constexpr const char* kService = "/com/rtukit/rehand6600/service0";
constexpr const char* kAdvert = "/com/rtukit/rehand6600_advertisement";
constexpr const char* kAgent = "/com/rtukit/rehand6600_agent";

[[noreturn]] void not_authorized(std::string_view why) {
  throw sdbus::Error("org.bluez.Error.NotAuthorized", std::string(why));
}
[[noreturn]] void rejected(std::string_view why) {
  throw sdbus::Error("org.bluez.Error.Rejected", std::string(why));
}

template <class T>
T value_or(const std::map<std::string, sdbus::Variant>& props, const char* name, T fallback) {
  const auto it = props.find(name);
  if (it == props.end() || !it->second.containsValueOfType<T>()) return fallback;
  return it->second.get<T>();
}

}  // namespace

struct BlePeripheral::Impl {
  BleOptions options;
  BleHandlers handlers;
  std::unique_ptr<sdbus::IConnection> bus;
  std::unique_ptr<sdbus::IObject> root, service, state, command, result, advert, agent;
  std::unique_ptr<sdbus::IProxy> bluez, adapter, agent_manager;
  sdbus::Slot device_changes;
  std::string adapter_path;

  // Loop-thread state.
  std::vector<uint8_t> state_value = std::vector<uint8_t>(gatt::kStateSize, 0);
  std::vector<uint8_t> result_value;
  bool state_notifying = false, result_notifying = false;
  bool app_registered = false, advert_registered = false;
  bool advert_wanted = false;  ///< what set_advertising last asked
  bool advert_busy = false;    ///< a (un)registration is on its way to BlueZ

  std::atomic<bool> pairing_open{false};
  mutable std::mutex mutex;                ///< guards the devices, the jobs, the registration's answer
  std::map<std::string, BleDevice> known;  ///< by object path
  const DriverClock* clock = nullptr;      ///< the daemon's (start()'s argument)
  std::map<std::string, web::TokenBucket> buckets;  ///< commands per device (loop thread)
  std::deque<std::function<void()>> jobs;
  std::condition_variable registered_cv;
  int registrations_left = 2;  ///< the application, and the advertisement when it starts with one
  std::string registration_error;
  int wake_fd = -1;
  std::atomic<bool> stopping{false};
  std::thread thread;

  ~Impl() {
    if (wake_fd >= 0) ::close(wake_fd);
  }

  void post(std::function<void()> job) {
    {
      std::lock_guard lock(mutex);
      jobs.push_back(std::move(job));
    }
    const uint64_t one = 1;
    (void)!::write(wake_fd, &one, sizeof one);
  }

  void run() {
    while (!stopping) {
      std::deque<std::function<void()>> now;
      {
        std::lock_guard lock(mutex);
        now.swap(jobs);
      }
      for (auto& job : now) {
        try {
          job();
        } catch (const sdbus::Error& e) {  // a call BlueZ refused: the link goes on
          fmt::print(stderr, "rehand6600 host: Bluetooth LE: {}\n", e.getMessage());
        }
      }
      try {
        while (bus->processPendingRequest()) {
        }
      } catch (const sdbus::Error& e) {
        fmt::print(stderr, "rehand6600 host: Bluetooth LE: {}\n", e.getMessage());
      }
      const sdbus::IConnection::PollData p = bus->getEventLoopPollData();
      pollfd fds[2] = {{p.fd, p.events, 0}, {wake_fd, POLLIN, 0}};
      if (::poll(fds, 2, p.getPollTimeout()) > 0 && (fds[1].revents & POLLIN)) {
        uint64_t n = 0;
        (void)!::read(wake_fd, &n, sizeof n);
      }
    }
  }

  // ---------------------------------------------------------------- devices

  bool bonded(const Options& call) {
    const auto it = call.find("device");
    if (it == call.end() || !it->second.containsValueOfType<sdbus::ObjectPath>()) return false;
    std::lock_guard lock(mutex);
    const auto d = known.find(it->second.get<sdbus::ObjectPath>());
    return d != known.end() && d->second.bonded;
  }

  // A token bucket per device (the loop thread's only): max_commands_per_s,
  // bursts up to two seconds' worth, as the web server bounds a socket.
  bool within_rate(const std::string& device) {
    const auto it = buckets.try_emplace(device, static_cast<double>(options.max_commands_per_s)).first;
    return it->second.take(clock->now());
  }

  std::string device_of(const Options& call) {
    const auto it = call.find("device");
    return it != call.end() && it->second.containsValueOfType<sdbus::ObjectPath>()
               ? std::string(it->second.get<sdbus::ObjectPath>())
               : std::string();
  }

  // A device's properties as BlueZ reported them (all, or the changed ones).
  // Returns whether it was connected before and is not now.
  bool update(const std::string& path, const std::map<std::string, sdbus::Variant>& props) {
    std::lock_guard lock(mutex);
    BleDevice& d = known[path];
    const bool was_connected = d.connected;
    d.path = path;
    d.address = value_or<std::string>(props, "Address", d.address);
    // A name anyone in radio range chose: cleaned before the display or the log sees it.
    d.name = phone_name(value_or<std::string>(props, "Alias", value_or<std::string>(props, "Name", d.name)),
                        d.address);
    d.bonded = value_or<bool>(props, "Paired", d.bonded) || value_or<bool>(props, "Bonded", false);
    d.connected = value_or<bool>(props, "Connected", d.connected);
    return was_connected && !d.connected;
  }

  bool on_adapter(const std::string& path) const { return path.starts_with(adapter_path + "/"); }

  void watch_devices() {
    bluez->uponSignal("InterfacesAdded")
        .onInterface("org.freedesktop.DBus.ObjectManager")
        .call([this](const sdbus::ObjectPath& path, const Interfaces& interfaces) {
          const auto it = interfaces.find(kDeviceIface);
          if (it == interfaces.end() || !on_adapter(path)) return;
          (void)update(path, it->second);
          if (handlers.devices_changed) handlers.devices_changed();
        });
    bluez->uponSignal("InterfacesRemoved")
        .onInterface("org.freedesktop.DBus.ObjectManager")
        .call([this](const sdbus::ObjectPath& path, const std::vector<std::string>& interfaces) {
          if (std::find(interfaces.begin(), interfaces.end(), kDeviceIface) == interfaces.end()) return;
          bool was_connected = false;
          {
            std::lock_guard lock(mutex);
            const auto it = known.find(path);
            if (it == known.end()) return;
            was_connected = it->second.connected;
            known.erase(it);
          }
          buckets.erase(path);
          if (was_connected && handlers.disconnected) handlers.disconnected(path);
          if (handlers.devices_changed) handlers.devices_changed();
        });
    bluez->finishRegistration();
    // Connected, Paired, Alias of every device of the adapter.
    device_changes =
        bus->addMatch(fmt::format("type='signal',sender='{}',interface='org.freedesktop.DBus.Properties',"
                                  "member='PropertiesChanged',path_namespace='{}'",
                                  kBluez, adapter_path),
                      [this](sdbus::Message& m) {
                        std::string iface;
                        std::map<std::string, sdbus::Variant> changed;
                        m >> iface >> changed;
                        const std::string path = m.getPath();
                        if (iface != kDeviceIface || !on_adapter(path)) return;
                        const bool gone = update(path, changed);
                        if (gone && handlers.disconnected) handlers.disconnected(path);
                        if (handlers.devices_changed) handlers.devices_changed();
                      });
  }

  // ---------------------------------------------------------------- objects

  void add_characteristic(std::unique_ptr<sdbus::IObject>& obj, const std::string& path,
                          std::string_view uuid, std::vector<std::string> flags, std::vector<uint8_t>* value,
                          bool* notifying) {
    obj = sdbus::createObject(*bus, path);
    obj->registerProperty("UUID").onInterface(kCharIface).withGetter([uuid] { return std::string(uuid); });
    obj->registerProperty("Service").onInterface(kCharIface).withGetter([] {
      return sdbus::ObjectPath(kService);
    });
    obj->registerProperty("Flags").onInterface(kCharIface).withGetter([flags] { return flags; });
    if (value) {
      obj->registerProperty("Value").onInterface(kCharIface).withGetter([value] { return *value; });
      obj->registerProperty("Notifying").onInterface(kCharIface).withGetter([notifying] {
        return *notifying;
      });
      obj->registerMethod("ReadValue")
          .onInterface(kCharIface)
          .withInputParamNames("options")
          .withOutputParamNames("value")
          .implementedAs([this, value](const Options& o) {
            if (!bonded(o)) not_authorized("pair with the chair first");
            const uint16_t offset = value_or<uint16_t>(o, "offset", 0);
            if (offset > value->size())
              throw sdbus::Error("org.bluez.Error.InvalidOffset", "offset past the value");
            return std::vector<uint8_t>(value->begin() + offset, value->end());
          });
      obj->registerMethod("StartNotify").onInterface(kCharIface).implementedAs([notifying, &obj] {
        *notifying = true;
        obj->emitPropertiesChangedSignal(kCharIface, {"Notifying"});
      });
      obj->registerMethod("StopNotify").onInterface(kCharIface).implementedAs([this, notifying, &obj] {
        *notifying = false;
        obj->emitPropertiesChangedSignal(kCharIface, {"Notifying"});
        if (!state_notifying && !result_notifying && handlers.unsubscribed) handlers.unsubscribed();
      });
    } else {
      obj->registerMethod("WriteValue")
          .onInterface(kCharIface)
          .withInputParamNames("value", "options")
          .implementedAs([this](const std::vector<uint8_t>& bytes, const Options& o) {
            if (!bonded(o)) not_authorized("pair with the chair first");
            const std::string device = device_of(o);
            if (!within_rate(device))
              throw sdbus::Error("org.bluez.Error.Failed", "too many commands: slow down");
            if (handlers.command) handlers.command(device, bytes);
          });
    }
    obj->finishRegistration();
  }

  void make_objects() {
    root = sdbus::createObject(*bus, kApp);
    root->addObjectManager();
    root->finishRegistration();
    service = sdbus::createObject(*bus, kService);
    service->registerProperty("UUID").onInterface(kServiceIface).withGetter([] {
      return std::string(gatt::kServiceUuid);
    });
    service->registerProperty("Primary").onInterface(kServiceIface).withGetter([] { return true; });
    service->finishRegistration();
    add_characteristic(state, std::string(kService) + "/state", gatt::kStateUuid,
                       {"encrypt-authenticated-read", "encrypt-authenticated-notify"}, &state_value,
                       &state_notifying);
    add_characteristic(command, std::string(kService) + "/command", gatt::kCommandUuid,
                       {"encrypt-authenticated-write"}, nullptr, nullptr);
    add_characteristic(result, std::string(kService) + "/result", gatt::kResultUuid,
                       {"encrypt-authenticated-read", "encrypt-authenticated-notify"}, &result_value,
                       &result_notifying);

    advert = sdbus::createObject(*bus, kAdvert);
    advert->registerProperty("Type").onInterface(kAdvertIface).withGetter([] {
      return std::string("peripheral");
    });
    advert->registerProperty("ServiceUUIDs").onInterface(kAdvertIface).withGetter([] {
      return std::vector<std::string>{std::string(gatt::kServiceUuid)};
    });
    advert->registerProperty("LocalName").onInterface(kAdvertIface).withGetter([this] {
      return options.name;
    });
    advert->registerMethod("Release").onInterface(kAdvertIface).implementedAs([this] {
      advert_registered = false;
    });
    advert->finishRegistration();

    // DisplayOnly: the phone types the passkey the display shows (LE Secure
    // Connections passkey entry, MITM-protected). Anything without a passkey
    // (just works, numeric comparison) and anything outside the pairing
    // window is rejected.
    agent = sdbus::createObject(*bus, kAgent);
    agent->registerMethod("Release").onInterface(kAgentIface).implementedAs([] {});
    agent->registerMethod("RequestPinCode")
        .onInterface(kAgentIface)
        .implementedAs([](const sdbus::ObjectPath&) {
          rejected("this chair pairs with a passkey");
          return std::string();
        });
    agent->registerMethod("DisplayPinCode")
        .onInterface(kAgentIface)
        .implementedAs([](const sdbus::ObjectPath&, const std::string&) {
          rejected("this chair pairs with a passkey");
        });
    agent->registerMethod("RequestPasskey")
        .onInterface(kAgentIface)
        .implementedAs([](const sdbus::ObjectPath&) {
          rejected("the chair shows the passkey, the phone types it");
          return uint32_t{0};
        });
    agent->registerMethod("DisplayPasskey")
        .onInterface(kAgentIface)
        .implementedAs([this](const sdbus::ObjectPath& device, uint32_t passkey, uint16_t) {
          if (!pairing_open) rejected("open \"Pair a phone\" on the display first");
          if (handlers.passkey) handlers.passkey(device, passkey);
        });
    agent->registerMethod("RequestConfirmation")
        .onInterface(kAgentIface)
        .implementedAs(
            [](const sdbus::ObjectPath&, uint32_t) { rejected("the phone types the passkey instead"); });
    agent->registerMethod("RequestAuthorization")
        .onInterface(kAgentIface)
        .implementedAs(
            [](const sdbus::ObjectPath&) { rejected("pairing without a passkey is not allowed"); });
    agent->registerMethod("AuthorizeService")
        .onInterface(kAgentIface)
        .implementedAs([this](const sdbus::ObjectPath& device, const std::string&) {
          std::lock_guard lock(mutex);
          const auto it = known.find(device);
          if (it == known.end() || !it->second.bonded) rejected("not a bonded phone");
        });
    agent->registerMethod("Cancel").onInterface(kAgentIface).implementedAs([this] {
      if (handlers.passkey) handlers.passkey("", 0);
    });
    agent->finishRegistration();
  }

  // On the loop thread: both registrations, each answered asynchronously.
  void register_with_bluez() {
    const auto answered = [this](const char* what, const sdbus::Error* e) {
      std::lock_guard lock(mutex);
      if (e && registration_error.empty()) registration_error = fmt::format("{}: {}", what, e->getMessage());
      --registrations_left;
      registered_cv.notify_all();
    };
    adapter->callMethodAsync("RegisterApplication")
        .onInterface("org.bluez.GattManager1")
        .withArguments(sdbus::ObjectPath(kApp), Options{})
        .uponReplyInvoke([this, answered](const sdbus::Error* e) {
          app_registered = e == nullptr;
          answered("RegisterApplication", e);
        });
    if (!options.advertise) return;
    advert_wanted = advert_busy = true;
    adapter->callMethodAsync("RegisterAdvertisement")
        .onInterface("org.bluez.LEAdvertisingManager1")
        .withArguments(sdbus::ObjectPath(kAdvert), Options{})
        .uponReplyInvoke([this, answered](const sdbus::Error* e) {
          advert_registered = e == nullptr;
          advert_busy = false;
          answered("RegisterAdvertisement", e);
          apply_advertising();
        });
  }

  // Brings BlueZ's advertisement to what was last asked, one call at a time.
  void apply_advertising() {
    if (advert_busy || advert_wanted == advert_registered) return;
    advert_busy = true;
    const char* method = advert_wanted ? "RegisterAdvertisement" : "UnregisterAdvertisement";
    auto call = adapter->callMethodAsync(method).onInterface("org.bluez.LEAdvertisingManager1");
    const auto answered = [this, method](const sdbus::Error* e) {
      advert_busy = false;
      // Unregistered also when BlueZ says it did not know it.
      advert_registered = std::string_view(method) == "RegisterAdvertisement" && e == nullptr;
      if (e) fmt::print(stderr, "rehand6600 host: Bluetooth LE: {}: {}\n", method, e->getMessage());
      if (!e) apply_advertising();  // asked again meanwhile; after a refusal, at the next ask
    };
    if (advert_wanted)
      call.withArguments(sdbus::ObjectPath(kAdvert), Options{}).uponReplyInvoke(answered);
    else
      call.withArguments(sdbus::ObjectPath(kAdvert)).uponReplyInvoke(answered);
  }

  // Asynchronous, as every call the loop makes while it runs: the loop never
  // waits for BlueZ, so a renewal is never held up behind a property change.
  void set_adapter(const char* name, const sdbus::Variant& value) {
    adapter->callMethodAsync("Set")
        .onInterface("org.freedesktop.DBus.Properties")
        .withArguments(std::string(kAdapterIface), std::string(name), value)
        .uponReplyInvoke([name](const sdbus::Error* e) {
          if (e) fmt::print(stderr, "rehand6600 host: Bluetooth LE: setting {}: {}\n", name, e->getMessage());
        });
  }

  void set_discoverable(bool open) {
    const auto seconds = static_cast<uint32_t>(options.pairing_window.count());
    set_adapter("PairableTimeout", sdbus::Variant(seconds));
    set_adapter("DiscoverableTimeout", sdbus::Variant(seconds));
    set_adapter("Pairable", sdbus::Variant(open));
    set_adapter("Discoverable", sdbus::Variant(open));
  }

  void unregister() {
    const auto quietly = [](const std::function<void()>& call) {
      try {
        call();
      } catch (const sdbus::Error&) {  // BlueZ already gone: nothing to undo
      }
    };
    if (advert_registered)
      quietly([this] {
        adapter->callMethod("UnregisterAdvertisement")
            .onInterface("org.bluez.LEAdvertisingManager1")
            .withTimeout(std::chrono::seconds(2))
            .withArguments(sdbus::ObjectPath(kAdvert));
      });
    if (app_registered)
      quietly([this] {
        adapter->callMethod("UnregisterApplication")
            .onInterface("org.bluez.GattManager1")
            .withTimeout(std::chrono::seconds(2))
            .withArguments(sdbus::ObjectPath(kApp));
      });
    quietly([this] {
      for (const char* name : {"Pairable", "Discoverable"})
        adapter->setProperty(name).onInterface(kAdapterIface).toValue(false);
    });
    quietly([this] {
      agent_manager->callMethod("UnregisterAgent")
          .onInterface("org.bluez.AgentManager1")
          .withTimeout(std::chrono::seconds(2))
          .withArguments(sdbus::ObjectPath(kAgent));
    });
  }
};

BlePeripheral::BlePeripheral(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Outcome<std::unique_ptr<BlePeripheral>> BlePeripheral::start(BleOptions options, BleHandlers handlers,
                                                             const DriverClock& clock) {
  auto d = std::make_unique<Impl>();
  d->clock = &clock;
  d->options = std::move(options);
  d->handlers = std::move(handlers);
  d->adapter_path = "/org/bluez/" + d->options.adapter;
  d->registrations_left = d->options.advertise ? 2 : 1;
  const auto failed = [](std::string why) {
    return rtukit::Status(Errc::io_error, fmt::format("Bluetooth LE: {}", why));
  };
  d->wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (d->wake_fd < 0) return failed("eventfd failed");
  try {
    d->bus = sdbus::createSystemBusConnection();
  } catch (const sdbus::Error& e) {
    return failed(fmt::format("no system bus ({})", e.getMessage()));
  }
  try {
    d->bluez = sdbus::createProxy(*d->bus, kBluez, "/");
    ManagedObjects objects;
    d->bluez->callMethod("GetManagedObjects")
        .onInterface("org.freedesktop.DBus.ObjectManager")
        .withTimeout(std::chrono::seconds(5))
        .storeResultsTo(objects);
    const auto it = objects.find(sdbus::ObjectPath(d->adapter_path));
    if (it == objects.end() || !it->second.contains(kAdapterIface))
      return failed(fmt::format("BlueZ has no adapter {}", d->options.adapter));
    for (const auto& [path, interfaces] : objects) {
      const auto dev = interfaces.find(kDeviceIface);
      if (dev != interfaces.end() && d->on_adapter(path)) (void)d->update(path, dev->second);
    }
    d->adapter = sdbus::createProxy(*d->bus, kBluez, d->adapter_path);
    d->adapter->finishRegistration();
    d->agent_manager = sdbus::createProxy(*d->bus, kBluez, "/org/bluez");
    d->agent_manager->finishRegistration();
    d->make_objects();
    d->watch_devices();
    d->agent_manager->callMethod("RegisterAgent")
        .onInterface("org.bluez.AgentManager1")
        .withTimeout(std::chrono::seconds(5))
        .withArguments(sdbus::ObjectPath(kAgent), std::string("DisplayOnly"));
    d->agent_manager->callMethod("RequestDefaultAgent")
        .onInterface("org.bluez.AgentManager1")
        .withTimeout(std::chrono::seconds(5))
        .withArguments(sdbus::ObjectPath(kAgent));
    // Pairing only while the display's window is open (before the loop runs: synchronously).
    for (const char* name : {"Pairable", "Discoverable"})
      d->adapter->setProperty(name).onInterface(kAdapterIface).toValue(false);
  } catch (const sdbus::Error& e) {
    return failed(e.getMessage());
  }
  Impl& impl = *d;
  impl.thread = std::thread([&impl] { impl.run(); });
  impl.post([&impl] { impl.register_with_bluez(); });
  std::string error;
  {
    std::unique_lock lock(impl.mutex);
    // BlueZ answers at once; 10 s is for a loaded board, not a schedule.
    if (!impl.registered_cv.wait_for(lock, std::chrono::seconds(10),
                                     [&] { return impl.registrations_left == 0; }))
      error = "BlueZ did not answer the registration within 10 s";
    else
      error = impl.registration_error;
  }
  auto peripheral = std::unique_ptr<BlePeripheral>(new BlePeripheral(std::move(d)));
  if (!error.empty()) return failed(error);  // ~BlePeripheral undoes what was done
  return peripheral;
}

BlePeripheral::~BlePeripheral() {
  Impl& d = *impl_;
  if (d.thread.joinable()) {
    std::mutex m;
    std::condition_variable cv;
    bool done = false;
    d.post([&] {
      d.unregister();
      std::lock_guard lock(m);
      done = true;
      cv.notify_all();
    });
    {
      std::unique_lock lock(m);
      cv.wait_for(lock, std::chrono::seconds(10), [&] { return done; });
    }
    d.stopping = true;
    d.post([] {});
    d.thread.join();
  }
}

void BlePeripheral::publish_state(std::vector<uint8_t> value) {
  Impl& d = *impl_;
  d.post([&d, value = std::move(value)] {
    if (value == d.state_value) return;
    d.state_value = value;
    if (d.state_notifying) d.state->emitPropertiesChangedSignal(kCharIface, {"Value"});
  });
}

void BlePeripheral::publish_result(std::vector<uint8_t> value) {
  Impl& d = *impl_;
  d.post([&d, value = std::move(value)] {
    d.result_value = value;
    if (d.result_notifying) d.result->emitPropertiesChangedSignal(kCharIface, {"Value"});
  });
}

void BlePeripheral::set_advertising(bool on) {
  Impl& d = *impl_;
  d.post([&d, on] {
    d.advert_wanted = on;
    d.apply_advertising();
  });
}

void BlePeripheral::set_pairing(bool open) {
  Impl& d = *impl_;
  // Always applied, also when it seems unchanged: BlueZ ends Pairable by
  // itself after PairableTimeout, and the next "Pair a phone" must reopen it.
  // The window is the adapter's Pairable: BlueZ ignores an agent that
  // refuses DisplayPasskey, so the agent's refusal is not the gate.
  d.pairing_open = open;
  d.post([&d, open] { d.set_discoverable(open); });
}

std::vector<BleDevice> BlePeripheral::devices() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<BleDevice> out;
  for (const auto& [path, dev] : impl_->known) out.push_back(dev);
  return out;
}

void BlePeripheral::forget(const std::string& path) {
  Impl& d = *impl_;
  d.post([&d, path] {
    d.adapter->callMethodAsync("RemoveDevice")
        .onInterface(kAdapterIface)
        .withArguments(sdbus::ObjectPath(path))
        .uponReplyInvoke([path](const sdbus::Error* e) {
          if (e)
            fmt::print(stderr, "rehand6600 host: Bluetooth LE: forgetting {}: {}\n", path, e->getMessage());
        });
  });
}

}  // namespace rtukit::programs
