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
    advertisement's properties (GetAll) before it returns, and records them;
    UnregisterAdvertisement ends it (`advertisement` is None again).

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
import queue
import random
import subprocess
import threading
import time

import dbus
import dbus.lowlevel
import dbus.mainloop.glib
import dbus.service
import dbusmock.mockobject as mockobject
from gi.repository import GLib

DEVICE = "org.bluez.Device1"
CHAR = "org.bluez.GattCharacteristic1"
SERVICE = "org.bluez.GattService1"
PROPS = "org.freedesktop.DBus.Properties"
DESCRIPTOR = "org.bluez.GattDescriptor1"
ADAPTER_IFACE = "org.bluez.Adapter1"
OBJECT_MANAGER = "org.freedesktop.DBus.ObjectManager"
CCCD = "00002902-0000-1000-8000-00805f9b34fb"  # Client Characteristic Configuration
BROWSER_ADAPTER = "hci0"  # the adapter Chromium's Web Bluetooth takes: the first by path

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


def device_path(address, adapter="hci0"):
    return f"/org/bluez/{adapter}/dev_{address.replace(':', '_').upper()}"


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
    def __init__(self, work, adapter="hci0"):
        """`adapter`: the chair's adapter (the daemon's --ble=NAME). A phone
        browser's BlueZ (add_browser_phone) takes hci0, the adapter Chromium
        uses: the chair is then hci1."""
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
        self.adapter_name = adapter
        self.template.AddAdapter(self.root, adapter, "rehand-test")
        self.adapter = mockobject.objects[f"/org/bluez/{adapter}"]
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
            ("UnregisterAdvertisement", "o", "", lambda _self, path: self._unregister_advertisement(path)),
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

    def _unregister_advertisement(self, path):
        """BlueZ stops advertising it (a phone's discovery no longer sees the chair)."""
        self.unregistered.append(str(path))
        if self.advertisement and self.advertisement[1] == str(path):
            self.advertisement = None

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
        laptop = dbus.ObjectPath(self.device_path(self.central[1]))
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

    # ------------------------------------------------------------ a phone's browser (Chromium, a central on hci0)

    def add_browser_phone(self, phone, chair="E4:5F:01:66:00:01"):
        """hci0 becomes the phone's adapter, the one Chromium's Web Bluetooth
        takes (the first by path: the chair must be on another adapter,
        MockBluez(work, adapter="hci1")). While the phone's browser discovers,
        the chair appears (address `chair`) if the daemon advertises; once
        connected, its GATT objects forward every call to the daemon's
        application as coming from `phone` (a device of the chair's adapter),
        and mirror its notifications.

        What BlueZ does and Chromium relies on (each was a failure first,
        ../shared design note "web-bluetooth-on-a-mock"): Device1 with BlueZ's
        property types; the device appears during discovery; a CCCD
        descriptor under each notifying characteristic; ReadValue also
        changes Value.

        Security as the two stacks do it: every characteristic of the chair
        needs an encrypted, authenticated link. The first access of a phone
        that has not bonded pairs, as the phone's OS does: if the chair's
        adapter is not pairable the access fails (NotAuthorized); otherwise
        the chair's agent is asked to show a passkey (DisplayPasskey), and
        the access waits (the mock's loop blocked, as the OS dialog blocks)
        until the test types a passkey (type_passkey): the right one bonds
        both sides and the access goes on; a wrong one, or none within 20 s,
        fails it (AuthenticationFailed) after 20 s."""
        assert self.adapter_name != BROWSER_ADAPTER, "the chair must not be on the browser's adapter"
        self.template.AddAdapter(self.root, BROWSER_ADAPTER, "phone")
        adapter = mockobject.objects[f"/org/bluez/{BROWSER_ADAPTER}"]
        adapter.AddMethods(ADAPTER_IFACE, [
            ("StartDiscovery", "", "", lambda a: self._browser_discovering(a, True)),
            ("StopDiscovery", "", "", lambda a: self._browser_discovering(a, False)),
        ])
        self.browser = {"phone": phone, "chair": chair, "path": device_path(chair, BROWSER_ADAPTER),
                        "bonded": False, "connected": False}
        self.browser_forwarded = []          # (method, UUID) that reached the daemon
        # Forget on the display removes the bond (RemoveDevice): the phone's
        # link drops and its side forgets the bond too.
        self.adapter.AddMethods(ADAPTER_IFACE, [
            ("RemoveDevice", "o", "", lambda a, path: self._remove_device(a, path))])
        self.passkey_asked = queue.Queue()   # the passkeys the chair showed, for the test
        self.passkey_typed = queue.Queue()   # what the test typed into the "OS dialog"
        self.browser_calls = []              # (method, characteristic UUID or "") Chromium made, in order
        return self.browser["path"]

    def _browser_discovering(self, adapter, on):
        adapter.UpdateProperties(ADAPTER_IFACE, {"Discovering": dbus.Boolean(on, variant_level=1)})
        if on:
            GLib.timeout_add(300, self._browser_advertisement)

    def _browser_advertisement(self):
        """While the phone discovers: the chair appears, or its RSSI changes
        (Chromium lists only what is added or changes during discovery)."""
        adapter = mockobject.objects[f"/org/bluez/{BROWSER_ADAPTER}"]
        if not adapter.props[ADAPTER_IFACE]["Discovering"]:
            return False
        if not self.advertisement:
            return True  # the chair does not advertise: nothing to see
        path = self.browser["path"]
        if path not in mockobject.objects:
            props = self.advertisement[2]
            uuids = dbus.Array([str(u) for u in props.get("ServiceUUIDs", [])], signature="s", variant_level=1)
            name = str(props.get("LocalName", "Rehand 6600"))
            v = lambda x: x  # noqa: E731 (the values below carry their D-Bus types, as BlueZ's)
            properties = {
                "Address": dbus.String(self.browser["chair"], variant_level=1),
                "AddressType": dbus.String("public", variant_level=1),
                "Name": dbus.String(name, variant_level=1), "Alias": dbus.String(name, variant_level=1),
                "Paired": dbus.Boolean(self.browser["bonded"], variant_level=1),
                "Bonded": dbus.Boolean(self.browser["bonded"], variant_level=1),
                "Trusted": dbus.Boolean(False, variant_level=1), "Blocked": dbus.Boolean(False, variant_level=1),
                "Connected": dbus.Boolean(False, variant_level=1),
                "LegacyPairing": dbus.Boolean(False, variant_level=1),
                "ServicesResolved": dbus.Boolean(False, variant_level=1),
                "UUIDs": v(uuids),
                "Adapter": dbus.ObjectPath(f"/org/bluez/{BROWSER_ADAPTER}", variant_level=1),
                "RSSI": dbus.Int16(-60, variant_level=1),
            }
            self.root.AddObject(path, DEVICE, properties, [
                ("Connect", "", "", lambda _d: self._browser_connect()),
                ("Disconnect", "", "", lambda _d: self._browser_disconnect()),
                ("Pair", "", "", lambda _d: self._browser_secure("Pair", None, "")),
                ("CancelPairing", "", "", ""),
            ])
            self._added(path)
        else:
            mockobject.objects[path].UpdateProperties(DEVICE, {"RSSI": dbus.Int16(random.randint(-70, -50),
                                                                                   variant_level=1)})
        return True

    def _added(self, path):
        obj = mockobject.objects[path]
        self.root.EmitSignal(OBJECT_MANAGER, "InterfacesAdded", "oa{sa{sv}}",
                             [dbus.ObjectPath(path), dbus.Dictionary(obj.props, signature="sa{sv}")])

    def _browser_connect(self):
        self.browser_calls.append(("Connect", ""))
        if not self.app or not self.advertisement:
            raise dbus.exceptions.DBusException("the chair does not answer", name="org.bluez.Error.Failed")
        phone = self.browser["phone"]
        if not self.known(phone):
            self.add_phone(phone, "Pixel 8")  # the chair's BlueZ meets the phone (its name)
        self.connect(phone)
        device = self.browser["path"]
        service = f"{device}/service0010"
        if service not in mockobject.objects:
            svc = [p for p, i in self.app[2].items() if SERVICE in i][0]
            self.root.AddObject(service, SERVICE, {
                "UUID": dbus.String(self.app[2][svc][SERVICE]["UUID"], variant_level=1),
                "Primary": dbus.Boolean(True, variant_level=1),
                "Device": dbus.ObjectPath(device, variant_level=1),
                "Includes": dbus.Array([], signature="o", variant_level=1)}, [])
            self._added(service)
            handle = 0x11
            for app_path, interfaces in sorted((p, i) for p, i in self.app[2].items() if CHAR in i):
                copy = f"{service}/char{handle:04x}"
                target, uuid = str(app_path), str(interfaces[CHAR]["UUID"])
                flags = client_flags(interfaces[CHAR]["Flags"])
                self.root.AddObject(copy, CHAR, {
                    "UUID": dbus.String(uuid, variant_level=1), "Service": dbus.ObjectPath(service, variant_level=1),
                    "Flags": dbus.Array(flags, signature="s", variant_level=1),
                    "Value": dbus.Array([], signature="y", variant_level=1),
                    "Notifying": dbus.Boolean(False, variant_level=1)}, [
                    ("ReadValue", "a{sv}", "ay", lambda _c, o, t=target, c=copy, u=uuid: self._browser_read(t, c, u)),
                    ("WriteValue", "aya{sv}", "", lambda _c, val, o, t=target, u=uuid: self._browser_write(t, u, val, o)),
                    ("StartNotify", "", "", lambda _c, t=target, c=copy, u=uuid: self._browser_notify(t, c, u, True)),
                    ("StopNotify", "", "", lambda _c, t=target, c=copy, u=uuid: self._browser_notify(t, c, u, False)),
                ])
                self._added(copy)
                if "notify" in flags:
                    # Chromium's startNotifications needs the CCCD (NotSupportedError without it).
                    desc = f"{copy}/desc{handle + 2:04x}"
                    self.root.AddObject(desc, DESCRIPTOR, {
                        "UUID": dbus.String(CCCD, variant_level=1),
                        "Characteristic": dbus.ObjectPath(copy, variant_level=1),
                        "Value": dbus.Array([], signature="y", variant_level=1),
                        "Flags": dbus.Array(["read", "write"], signature="s", variant_level=1)}, [
                        ("ReadValue", "a{sv}", "ay", lambda _d, o: dbus.Array([0, 0], signature="y")),
                        ("WriteValue", "aya{sv}", "", lambda _d, val, o: None),
                    ])
                    self._added(desc)
                handle += 3
        self.browser["connected"] = True
        mockobject.objects[device].UpdateProperties(DEVICE, {"Connected": dbus.Boolean(True, variant_level=1)})
        mockobject.objects[device].UpdateProperties(DEVICE, {"ServicesResolved": dbus.Boolean(True,
                                                                                              variant_level=1)})

    def _browser_options(self, options=None):
        o = dict(options or {})
        o.update(device=dbus.ObjectPath(self.device_path(self.browser["phone"])), link="LE", mtu=dbus.UInt16(23))
        return dbus.Dictionary(o, signature="sv")

    def _browser_read(self, target, copy, uuid):
        self.browser_calls.append(("ReadValue", uuid))
        self._browser_secure("ReadValue", target, "read")
        self.browser_forwarded.append(("ReadValue", uuid))
        value = self._call(target, "ReadValue", self._browser_options())
        # As BlueZ: a read also changes Value (Chromium swallows one change per read in flight).
        mockobject.objects[copy].UpdateProperties(CHAR, {"Value": dbus.Array(value, signature="y", variant_level=1)})
        return dbus.Array(value, signature="y")

    def _browser_write(self, target, uuid, value, options):
        self.browser_calls.append(("WriteValue", uuid))
        self._browser_secure("WriteValue", target, "write")
        self.browser_forwarded.append(("WriteValue", uuid))
        self._call(target, "WriteValue", dbus.Array(value, signature="y"), self._browser_options(options))

    def _browser_notify(self, target, copy, uuid, on):
        self.browser_calls.append(("StartNotify" if on else "StopNotify", uuid))
        if on:
            self._browser_secure("StartNotify", target, "notify")
            self.browser_forwarded.append(("StartNotify", uuid))
            self._call(target, "StartNotify")
            self.mirrors[target] = copy
        else:
            self.mirrors.pop(target, None)
            try:
                self._call(target, "StopNotify")
            except dbus.exceptions.DBusException:
                pass  # the daemon had already let go
        mockobject.objects[copy].UpdateProperties(CHAR, {"Notifying": dbus.Boolean(on, variant_level=1)})

    def _browser_secure(self, why, target, access):
        """Enforces the characteristic's flags as the chair's BlueZ does: an
        access its flags say needs an encrypted, authenticated link
        ("encrypt-authenticated-read" for a read...) pairs first, as the
        phone's OS does (see add_browser_phone); one they do not protect goes
        through unpaired (a plain "notify" lets anyone subscribe)."""
        if self.browser["bonded"]:
            return
        if target is not None:
            flags = [str(f) for f in self.app[2][dbus.ObjectPath(target)][CHAR]["Flags"]]
            if not any(f.startswith(("encrypt-", "secure-")) and f.endswith("-" + access) for f in flags):
                return
        phone = self.browser["phone"]
        if not self.adapter.props[ADAPTER_IFACE]["Pairable"]:
            raise dbus.exceptions.DBusException(f"{why}: insufficient authentication, the chair does not pair now",
                                                name="org.bluez.Error.NotAuthorized")
        passkey = random.randint(0, 999999)
        error = self.display_passkey(phone, passkey)
        if error:
            raise dbus.exceptions.DBusException(f"{why}: the chair refused to pair ({error})",
                                                name="org.bluez.Error.AuthenticationRejected")
        self.passkey_asked.put(passkey)
        try:
            typed = self.passkey_typed.get(timeout=20)
        except queue.Empty:
            typed = None
        if typed != passkey:
            raise dbus.exceptions.DBusException(f"{why}: pairing failed (wrong passkey)",
                                                name="org.bluez.Error.AuthenticationFailed")
        self.bond(phone)
        self.browser["bonded"] = True
        mockobject.objects[self.browser["path"]].UpdateProperties(DEVICE, {
            "Paired": dbus.Boolean(True, variant_level=1), "Bonded": dbus.Boolean(True, variant_level=1)})

    def _remove_device(self, adapter, path):
        if str(path) == self.device_path(self.browser["phone"]):
            self.browser_link_lost()  # BlueZ disconnects a device before it removes it
            self.browser["bonded"] = False
            if self.browser["path"] in mockobject.objects:
                mockobject.objects[self.browser["path"]].UpdateProperties(DEVICE, {
                    "Paired": dbus.Boolean(False, variant_level=1), "Bonded": dbus.Boolean(False, variant_level=1)})
        self.template.RemoveDevice(adapter, path)

    def _browser_disconnect(self):
        self.browser_calls.append(("Disconnect", ""))
        self.browser_link_lost()

    def browser_link_lost(self):
        """The link between the phone and the chair ends (Chromium's
        Disconnect, or the radio): both sides see it."""
        if not self.browser["connected"]:
            return
        self.browser["connected"] = False
        for target in [t for t, c in self.mirrors.items() if c.startswith(self.browser["path"])]:
            self.mirrors.pop(target)
        # As BlueZ: a link that ends ends its subscriptions (Chromium does not
        # subscribe again to a characteristic it sees notifying).
        for path, obj in list(mockobject.objects.items()):
            if path.startswith(self.browser["path"] + "/") and CHAR in obj.props and obj.props[CHAR].get("Notifying"):
                obj.UpdateProperties(CHAR, {"Notifying": dbus.Boolean(False, variant_level=1)})
        self.disconnect(self.browser["phone"])
        mockobject.objects[self.browser["path"]].UpdateProperties(DEVICE, {
            "ServicesResolved": dbus.Boolean(False, variant_level=1),
            "Connected": dbus.Boolean(False, variant_level=1)})

    def pairable_timeout(self):
        """BlueZ ends the chair adapter's Pairable by itself (PairableTimeout)."""
        self.adapter.UpdateProperties(ADAPTER_IFACE, {"Pairable": dbus.Boolean(False, variant_level=1)})

    def type_passkey(self, passkey):
        """The person types `passkey` into the phone's pairing dialog (from the test's thread)."""
        self.passkey_typed.put(passkey)

    # ------------------------------------------------------------ a loop of its own

    def run_in_thread(self):
        """Runs the mock's main loop in a thread of its own, for a test whose
        own thread blocks (a browser driven by Selenium). From then on only
        that thread touches the bus: call(fn) runs fn there and returns its
        result."""
        self.loop = GLib.MainLoop()
        self.thread = threading.Thread(target=self.loop.run, daemon=True)
        self.thread.start()

    def call(self, fn, timeout=30):
        done = queue.Queue()

        def run():
            try:
                done.put((True, fn()))
            except Exception as e:  # noqa: BLE001 (handed to the caller's thread)
                done.put((False, e))
            return False
        GLib.idle_add(run)
        ok, value = done.get(timeout=timeout)
        if not ok:
            raise value
        return value

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

    def device_path(self, address):
        """A device's path on the chair's adapter."""
        return device_path(address, self.adapter_name)

    def add_phone(self, address, name):
        self.template.AddDevice(self.root, self.adapter_name, address, name)
        return self.device_path(address)

    def connect(self, address):
        self.template.ConnectDevice(self.root, self.adapter_name, address)

    def disconnect(self, address):
        self.template.DisconnectDevice(self.root, self.adapter_name, address)

    def agent(self):
        manager = mockobject.objects["/org/bluez"]
        return self.last_sender["RegisterAgent"], str(manager.default_agent), manager.capabilities

    def display_passkey(self, address, passkey):
        """BlueZ asks the agent to show the passkey. Returns the D-Bus error name, or ''."""
        sender, path, _ = self.agent()
        agent = self.bus.get_object(sender, path, introspect=False)
        try:
            agent.DisplayPasskey(dbus.ObjectPath(self.device_path(address)), dbus.UInt32(passkey), dbus.UInt16(0),
                                 dbus_interface="org.bluez.Agent1", timeout=5)
            return ""
        except dbus.exceptions.DBusException as e:
            return e.get_dbus_name()

    def bond(self, address):
        self.template.PairDevice(self.root, self.adapter_name, address, 5898764)

    def start_notify(self, uuid):
        self._call(self.characteristic(uuid), "StartNotify")

    def stop_notify(self, uuid):
        self._call(self.characteristic(uuid), "StopNotify")

    def write(self, address, uuid, value):
        """WriteValue as BlueZ passes a phone's write on. Returns the D-Bus error name, or ''."""
        try:
            self._call(self.characteristic(uuid), "WriteValue", dbus.Array(value, signature="y"),
                       dbus.Dictionary({"device": dbus.ObjectPath(self.device_path(address)), "link": "LE",
                                        "mtu": dbus.UInt16(23)}, signature="sv"))
            return ""
        except dbus.exceptions.DBusException as e:
            return e.get_dbus_name()

    def read(self, address, uuid):
        """(bytes, '') or (None, the D-Bus error name)."""
        try:
            v = self._call(self.characteristic(uuid), "ReadValue",
                           dbus.Dictionary({"device": dbus.ObjectPath(self.device_path(address)), "link": "LE"},
                                           signature="sv"))
            return bytes(v), ""
        except dbus.exceptions.DBusException as e:
            return None, e.get_dbus_name()

    def adapter_property(self, name):
        return self.adapter.props["org.bluez.Adapter1"][name]

    def known(self, address):
        return self.device_path(address) in mockobject.objects

    def stop(self):
        if getattr(self, "loop", None):
            self.loop.quit()
            self.thread.join(5)
        try:
            self.bus.close()
        except Exception:  # noqa: BLE001 (closing a bus that went away)
            pass
        self.daemon.terminate()
        try:
            self.daemon.wait(5)
        except subprocess.TimeoutExpired:
            self.daemon.kill()
