// The reference Bluetooth LE client of the Rehand 6600 (D-13): what an
// engineer runs on a laptop against the real board, and the tests run
// against the mock BlueZ. It is a central on BlueZ's D-Bus API (system bus,
// $DBUS_SYSTEM_BUS_ADDRESS): Device1.Connect, the chair's characteristics
// found by UUID, StartNotify on state and result, WriteValue (with
// response) for the commands. The keys and their rules are
// rehand6600::ble::RemoteKeys; the bytes are ble_gatt.hpp.
#pragma once

#include <chrono>
#include <string>

#include "rtukit/base/status.hpp"

namespace rtukit::programs {

struct BleRemoteOptions {
  std::string address;                     ///< the chair, "AA:BB:CC:DD:EE:FF" (as bluetoothctl shows it)
  std::string adapter = "hci0";            ///< this computer's adapter
  std::chrono::milliseconds key_gap{700};  ///< a held key that stops repeating this long is let go
  std::chrono::seconds connect_timeout{20};
};

/// Connects to the chair (already paired: BlueZ knows and bonded it), then
/// reads keys from stdin (a terminal: one at a time, no echo) until x,
/// Ctrl-C, SIGTERM or the end of input, printing the state on stdout when
/// it changes and each refusal; releases what is held before it returns,
/// and disconnects if it connected. Errors: invalid_argument (not an
/// address), io_error (no system bus, no such adapter, BlueZ does not know
/// the chair, the link went away), refused (not paired; not a Rehand 6600:
/// its service is missing), timeout (the connection or its services did not
/// come within connect_timeout).
rtukit::Status run_ble_remote(const BleRemoteOptions& options);

}  // namespace rtukit::programs
