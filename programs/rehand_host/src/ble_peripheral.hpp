// The Rehand 6600 host daemon's Bluetooth LE link (D-13): a GATT server, an
// advertisement and a pairing agent registered with BlueZ over its D-Bus API
// on the system bus ($DBUS_SYSTEM_BUS_ADDRESS, so tests point it at a
// private bus with a mock BlueZ). Internal to programs/rehand_host.
//
// It carries bytes only (the layouts are devices/rehand6600/ble_gatt.hpp)
// and knows no rule: what a command may do is the session's, run by the
// daemon. Everything it does with D-Bus happens on its own thread, which
// owns the connection (sd-bus connections are not thread-safe); the
// daemon's calls post to that thread, and the handlers below are called on
// it and must not block (the daemon posts them on to its server thread).
//
// What it enforces itself, as BlueZ would with the characteristic flags:
// a read or a write from a device that is not bonded is refused
// (org.bluez.Error.NotAuthorized), and no pairing is accepted while the
// pairing window is closed. It also bounds each device's commands
// (BleOptions::max_commands_per_s).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"

namespace rtukit::programs {

/// A device the adapter knows (a phone that connected or paired).
struct BleDevice {
  std::string path;     ///< its BlueZ object, /org/bluez/hci0/dev_AA_BB_...
  std::string address;  ///< "AA:BB:CC:DD:EE:FF"
  std::string name;     ///< its alias (the phone's name), else the address
  bool bonded = false;  ///< paired (and bonded): may read and write
  bool connected = false;
};

/// What the link reports, on its thread (never blocking).
struct BleHandlers {
  /// A bonded device wrote the command characteristic.
  std::function<void(const std::string& device, std::vector<uint8_t> value)> command;
  /// A device disconnected (Device1.Connected false, or it went away).
  std::function<void(const std::string& device)> disconnected;
  /// Nobody listens to the state or the results any more (StopNotify).
  std::function<void()> unsubscribed;
  /// Pairing: show `passkey` (6 digits) for `device`; 0 with `device` empty: stop showing it.
  std::function<void(const std::string& device, uint32_t passkey)> passkey;
  /// The known devices changed (paired, forgotten, connected, disconnected).
  std::function<void()> devices_changed;
};

struct BleOptions {
  std::string adapter = "hci0";
  std::string name = "Rehand 6600";  ///< advertised
  std::chrono::seconds pairing_window{120};
  /// Commands a device may write per second, averaged over 2 s (a phone
  /// renews 10 times a second). More are refused (org.bluez.Error.Failed
  /// "too many commands") before they reach the daemon: a flooding phone's
  /// renewals lapse and the chair stops, and nobody else is slowed.
  unsigned max_commands_per_s = 50;
  /// Advertise from the start (start() then fails when BlueZ refuses the
  /// advertisement); else only once set_advertising(true) is called.
  bool advertise = true;
};

class BlePeripheral {
 public:
  /// Connects to the system bus, registers the agent (DisplayOnly), the GATT
  /// application and the advertisement with BlueZ on `options.adapter`, and
  /// runs the link until destroyed. Errors: io_error with the reason ("no
  /// system bus", "BlueZ has no adapter hci0", BlueZ's refusal). `clock`
  /// (the daemon's; it must outlive the link) times the command rate.
  static Outcome<std::unique_ptr<BlePeripheral>> start(BleOptions options, BleHandlers handlers,
                                                       const DriverClock& clock);
  ~BlePeripheral();  ///< unregisters what it registered, ends the thread
  BlePeripheral(const BlePeripheral&) = delete;
  BlePeripheral& operator=(const BlePeripheral&) = delete;

  /// The state characteristic's value; notified when it differs from the last.
  void publish_state(std::vector<uint8_t> value);
  /// A result, notified on the result characteristic.
  void publish_result(std::vector<uint8_t> value);
  /// Advertises the chair ("Rehand 6600" with the service UUID) or stops:
  /// the daemon advertises only while a bonded phone may connect or the
  /// pairing window is open. Applied asynchronously; BlueZ's refusal is
  /// logged on stderr.
  void set_advertising(bool on);
  /// Opens the pairing window (the adapter pairable and discoverable for at
  /// most BleOptions::pairing_window) or closes it.
  void set_pairing(bool open);
  /// The devices the adapter knows, as last reported by BlueZ.
  std::vector<BleDevice> devices() const;
  /// Forgets a device: BlueZ removes it and its bond (Adapter1.RemoveDevice).
  void forget(const std::string& path);

  struct Impl;

 private:
  explicit BlePeripheral(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit::programs
