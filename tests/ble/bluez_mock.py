#!/usr/bin/python3
"""A BlueZ for tests: a private system bus with python3-dbusmock's bluez5
template (adapter, devices, pairing, the agent manager), extended with what
a BLE peripheral needs of BlueZ, as its documentation describes them
(doc/org.bluez.GattManager.rst, org.bluez.LEAdvertisingManager.rst):

  - GattManager1.RegisterApplication(o, a{sv}) on the adapter calls
    GetManagedObjects back on the caller's application *before* it returns,
    checks the tree (one primary GattService1 with a UUID; each
    GattCharacteristic1 with UUID, Service and Flags) and records it;
  - LEAdvertisingManager1.RegisterAdvertisement(o, a{sv}) reads the
    advertisement's properties (GetAll) before it returns, and records them.

Then it acts as BlueZ and as the phone on the radio: connects and pairs a
device, calls the agent's DisplayPasskey, subscribes (StartNotify), writes a
characteristic with the `device` option BlueZ adds, reads the notified values
(PropertiesChanged on Value), disconnects a device.

What it cannot prove: real pairing and encryption (LE Secure Connections),
the radio, the ATT MTU. The characteristic flags are checked, and the
peripheral's own refusal of unbonded devices is exercised, but the link's
encryption is the phone's and the board's Bluetooth stacks' (see
docs/rehand6600-ble.md for the check-list to run once on the RK3588).

For the reference client (`rtukit rehand6600 remote --ble`), add_central()
adds a second adapter, hci1 (the engineer's laptop), that knows the chair
as a bonded device; once connected, its GATT objects under that device
forward every read, write and subscription to the daemon's application, as
coming from the laptop (a bonded device of hci0), and mirror the
application's notifications: the radio between the two adapters.

Use: bus = MockBluez(work_dir); env = bus.env (DBUS_SYSTEM_BUS_ADDRESS for
the program under test); ...; bus.stop(). Everything it starts it stops by PID.
"""
import os
import subprocess
import time

import dbus
import dbus.lowlevel
import dbus.mainloop.glib
import dbus.service
import dbusmock.mockobject as mockobject
from gi.repository import GLib

ADAPTER = "/org/bluez/hci0"
DEVICE = "org.bluez.Device1"
CHAR = "org.bluez.GattCharacteristic1"
SERVICE = "org.bluez.GattService1"
PROPS = "org.freedesktop.DBus.Properties"

BUS_CONFIG = """<!DOCTYPE busconfig PUBLIC "-//freedesktop//DTD D-BUS Bus Configuration 1.0//EN"
 "http://www.freedesktop.org/standards/dbus/1.0/busconfig.dtd">
<busconfig>
  <type>system</type>
  <listen>unix:dir={dir}</listen>
  <auth>EXTERNAL</auth>
  <policy context="default">
    <allow user="*"/>
    <allow own="*"/>
    <allow send_type="method_call"/>
    <allow send_type="signal"/>
    <allow send_type="method_return"/>
    <allow send_type="error"/>
    <allow receive_type="method_call"/>
    <allow receive_type="signal"/>
    <allow receive_type="method_return"/>
    <allow receive_type="error"/>
  </policy>
</busconfig>
"""


def device_path(address):
    return f"{ADAPTER}/dev_{address.replace(':', '_').upper()}"


def client_flags(server_flags):
    """The Flags a central's BlueZ shows for a characteristic a peripheral
    declared with `server_flags`: the ATT properties only ("read", "write",
    "notify"...); the security part of "encrypt-authenticated-read" or
    "encrypt-authenticated-notify" is the peripheral's, enforced there."""
    shown = []
    for f in map(str, server_flags):
        base = f.split("-")[-1] if f.startswith(("encrypt-", "secure-")) else f
        if base not in shown:
            shown.append(base)
    return dbus.Array(shown, signature="s")


class MockBluez:
    def __init__(self, work):
        config = os.path.join(work, "system-bus.conf")
        with open(config, "w") as f:
            f.write(BUS_CONFIG.format(dir=work))
        self.daemon = subprocess.Popen(["dbus-daemon", "--config-file", config, "--nofork", "--print-address"],
                                       stdout=subprocess.PIPE, stderr=open(os.path.join(work, "bus.log"), "w"),
                                       text=True)
        self.address = self.daemon.stdout.readline().strip()
        self.env = dict(os.environ, DBUS_SYSTEM_BUS_ADDRESS=self.address)
        dbus.mainloop.glib.DBusGMainLoop(set_as_default=True)
        self.bus = dbus.bus.BusConnection(self.address)
        self.name = dbus.service.BusName("org.bluez", self.bus, do_not_queue=True)
        self.root = mockobject.DBusMockObject(self.name, "/", "org.freedesktop.DBus.ObjectManager", {}, os.devnull,
                                              True)
        mockobject.objects["/"] = self.root
        self.root.AddTemplate("bluez5", {})
        self.template = mockobject.load_module("bluez5")
        self.template.AddAdapter(self.root, "hci0", "rehand-test")
        self.adapter = mockobject.objects[ADAPTER]
        # Who called: dbusmock's methods do not see the sender, a message filter does.
        self.last_sender = {}
        self.bus.add_message_filter(self._note_sender)
        self.app = None          # (sender, path, tree) once registered
        self.advertisement = None  # (sender, path, properties)
        self.unregistered = []
        self.notified = []       # (characteristic path, bytes) from PropertiesChanged on Value
        self.mirrors = {}        # the application's characteristic -> the laptop's copy (notifying)
        self.central = None      # (chair's address, laptop's address) once add_central was called
        self.adapter.AddMethods("org.bluez.GattManager1", [
            # dbusmock calls plain functions only (not bound methods): hence the lambdas
            ("RegisterApplication", "oa{sv}", "", lambda a, path, o: self._register_application(a, path, o)),
            ("UnregisterApplication", "o", "", lambda _self, path: self.unregistered.append(str(path))),
        ])
        self.adapter.AddMethods("org.bluez.LEAdvertisingManager1", [
            ("RegisterAdvertisement", "oa{sv}", "", lambda a, path, o: self._register_advertisement(a, path, o)),
            ("UnregisterAdvertisement", "o", "", lambda _self, path: self.unregistered.append(str(path))),
        ])
        self.bus.add_signal_receiver(self._properties_changed, signal_name="PropertiesChanged",
                                     dbus_interface=PROPS, path_keyword="path", sender_keyword="sender")

    # ------------------------------------------------------------ BlueZ's side

    def _note_sender(self, _bus, message):
        if message.get_type() == 1:  # a method call
            self.last_sender[message.get_member()] = message.get_sender()
        return dbus.lowlevel.HANDLER_RESULT_NOT_YET_HANDLED  # dispatched as usual

    def _register_application(self, _adapter, path, _options):
        sender = self.last_sender["RegisterApplication"]
        app = self.bus.get_object(sender, path, introspect=False)
        tree = app.GetManagedObjects(dbus_interface="org.freedesktop.DBus.ObjectManager", timeout=5)
        services = [p for p, i in tree.items() if SERVICE in i]
        chars = [p for p, i in tree.items() if CHAR in i]
        if len(services) != 1 or not tree[services[0]][SERVICE].get("Primary") or not chars:
            raise dbus.exceptions.DBusException("no primary service with characteristics",
                                                name="org.bluez.Error.InvalidArguments")
        for c in chars:
            props = tree[c][CHAR]
            if not all(k in props for k in ("UUID", "Service", "Flags")) or props["Service"] not in services:
                raise dbus.exceptions.DBusException(f"characteristic {c} incomplete",
                                                    name="org.bluez.Error.InvalidArguments")
        self.app = (sender, str(path), tree)

    def _register_advertisement(self, _adapter, path, _options):
        sender = self.last_sender["RegisterAdvertisement"]
        adv = self.bus.get_object(sender, path, introspect=False)
        props = adv.GetAll("org.bluez.LEAdvertisement1", dbus_interface=PROPS, timeout=5)
        if props.get("Type") not in ("peripheral", "broadcast"):
            raise dbus.exceptions.DBusException("bad Type", name="org.bluez.Error.InvalidArguments")
        self.advertisement = (sender, str(path), props)

    def _properties_changed(self, interface, changed, _invalidated, path=None, sender=None):
        if interface == CHAR and "Value" in changed and self.app and sender == self.app[0]:
            self.notified.append((str(path), bytes(changed["Value"])))
            copy = self.mirrors.get(str(path))
            if copy in mockobject.objects:
                mockobject.objects[copy].UpdateProperties(CHAR, {"Value": dbus.Array(changed["Value"], signature="y")})

    # ------------------------------------------------------------ the laptop (a central on hci1)

    def add_central(self, chair, laptop, bonded=True):
        """hci1 knows the chair (address `chair`), bonded unless told; the
        chair's hci0 knows the laptop (address `laptop`), bonded alike.
        Returns the chair's device path on hci1."""
        self.template.AddAdapter(self.root, "hci1", "laptop")
        path = self.template.AddDevice(self.root, "hci1", chair, "Rehand 6600")
        self.add_phone(laptop, "laptop")
        if bonded:
            self.template.PairDevice(self.root, "hci1", chair, 5898764)
            self.bond(laptop)
        self.central = (chair, laptop)
        device = mockobject.objects[path]
        device.AddMethods(DEVICE, [
            ("Connect", "", "", lambda _d: self._central_connect(str(path))),
            ("Disconnect", "", "", lambda _d: self._central_disconnect(str(path))),
        ])
        return str(path)

    def _central_connect(self, path):
        if not self.app:
            raise dbus.exceptions.DBusException("the chair does not answer", name="org.bluez.Error.Failed")
        self.connect(self.central[1])  # the chair sees the laptop connect
        laptop = dbus.ObjectPath(device_path(self.central[1]))
        service = f"{path}/service0010"
        if service not in mockobject.objects:
            svc = [p for p, i in self.app[2].items() if SERVICE in i][0]
            self.root.AddObject(service, SERVICE, {"UUID": self.app[2][svc][SERVICE]["UUID"],
                                                   "Primary": dbus.Boolean(True), "Device": dbus.ObjectPath(path)}, [])
            for n, (app_path, interfaces) in enumerate(sorted((p, i) for p, i in self.app[2].items() if CHAR in i)):
                copy = f"{service}/char{0x11 + n:04x}"
                target = str(app_path)

                def forward(method, *args, target=target):
                    return self._call(target, method, *args)
                options = lambda o: dbus.Dictionary(dict(o, device=laptop, link="LE"), signature="sv")  # noqa: E731
                self.root.AddObject(copy, CHAR, {
                    "UUID": interfaces[CHAR]["UUID"], "Service": dbus.ObjectPath(service),
                    "Flags": client_flags(interfaces[CHAR]["Flags"]), "Value": dbus.Array([], signature="y"),
                    "Notifying": dbus.Boolean(False)}, [
                    ("ReadValue", "a{sv}", "ay", lambda _c, o, f=forward: f("ReadValue", options(o))),
                    ("WriteValue", "aya{sv}", "", lambda _c, v, o, f=forward: f("WriteValue", v, options(o))),
                    ("StartNotify", "", "", lambda _c, f=forward, t=target, c=copy: self._mirror(f, t, c)),
                    ("StopNotify", "", "", lambda _c, f=forward, t=target: (self.mirrors.pop(t, None),
                                                                           f("StopNotify"))[1]),
                ])
        mockobject.objects[path].UpdateProperties(DEVICE, {"Connected": dbus.Boolean(True),
                                                           "ServicesResolved": dbus.Boolean(True)})

    def _mirror(self, forward, target, copy):
        forward("StartNotify")
        self.mirrors[target] = copy

    def _central_disconnect(self, path):
        self.mirrors.clear()
        self.disconnect(self.central[1])
        mockobject.objects[path].UpdateProperties(DEVICE, {"Connected": dbus.Boolean(False),
                                                           "ServicesResolved": dbus.Boolean(False)})

    # ------------------------------------------------------------ the test's side

    def pump(self, seconds=0.0, until=None):
        """Runs the main loop for `seconds`, or until `until()` is true (then
        at most `seconds`). Returns until()'s last value (or True)."""
        end = time.monotonic() + seconds
        ctx = GLib.MainContext.default()
        while True:
            while ctx.pending():
                ctx.iteration(False)
            if until and until():
                return True
            if time.monotonic() >= end:
                return until() if until else True
            ctx.iteration(False)
            time.sleep(0.005)

    def characteristic(self, uuid):
        """The path of the application's characteristic with this UUID."""
        for path, interfaces in self.app[2].items():
            if CHAR in interfaces and str(interfaces[CHAR]["UUID"]) == uuid:
                return str(path)
        raise KeyError(uuid)

    def flags(self, uuid):
        return [str(f) for f in self.app[2][dbus.ObjectPath(self.characteristic(uuid))][CHAR]["Flags"]]

    def _call(self, path, method, *args, interface=CHAR):
        obj = self.bus.get_object(self.app[0], path, introspect=False)
        return getattr(obj, method)(*args, dbus_interface=interface, timeout=5)

    def add_phone(self, address, name):
        self.template.AddDevice(self.root, "hci0", address, name)
        return device_path(address)

    def connect(self, address):
        self.template.ConnectDevice(self.root, "hci0", address)

    def disconnect(self, address):
        self.template.DisconnectDevice(self.root, "hci0", address)

    def agent(self):
        manager = mockobject.objects["/org/bluez"]
        return self.last_sender["RegisterAgent"], str(manager.default_agent), manager.capabilities

    def display_passkey(self, address, passkey):
        """BlueZ asks the agent to show the passkey. Returns the D-Bus error name, or ''."""
        sender, path, _ = self.agent()
        agent = self.bus.get_object(sender, path, introspect=False)
        try:
            agent.DisplayPasskey(dbus.ObjectPath(device_path(address)), dbus.UInt32(passkey), dbus.UInt16(0),
                                 dbus_interface="org.bluez.Agent1", timeout=5)
            return ""
        except dbus.exceptions.DBusException as e:
            return e.get_dbus_name()

    def bond(self, address):
        self.template.PairDevice(self.root, "hci0", address, 5898764)

    def start_notify(self, uuid):
        self._call(self.characteristic(uuid), "StartNotify")

    def stop_notify(self, uuid):
        self._call(self.characteristic(uuid), "StopNotify")

    def write(self, address, uuid, value):
        """WriteValue as BlueZ passes a phone's write on. Returns the D-Bus error name, or ''."""
        try:
            self._call(self.characteristic(uuid), "WriteValue", dbus.Array(value, signature="y"),
                       dbus.Dictionary({"device": dbus.ObjectPath(device_path(address)), "link": "LE",
                                        "mtu": dbus.UInt16(23)}, signature="sv"))
            return ""
        except dbus.exceptions.DBusException as e:
            return e.get_dbus_name()

    def read(self, address, uuid):
        """(bytes, '') or (None, the D-Bus error name)."""
        try:
            v = self._call(self.characteristic(uuid), "ReadValue",
                           dbus.Dictionary({"device": dbus.ObjectPath(device_path(address)), "link": "LE"},
                                           signature="sv"))
            return bytes(v), ""
        except dbus.exceptions.DBusException as e:
            return None, e.get_dbus_name()

    def adapter_property(self, name):
        return self.adapter.props["org.bluez.Adapter1"][name]

    def known(self, address):
        return device_path(address) in mockobject.objects

    def stop(self):
        try:
            self.bus.close()
        except Exception:  # noqa: BLE001 (closing a bus that went away)
            pass
        self.daemon.terminate()
        try:
            self.daemon.wait(5)
        except subprocess.TimeoutExpired:
            self.daemon.kill()
