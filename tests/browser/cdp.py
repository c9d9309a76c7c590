"""A small client of Chromium's DevTools protocol, for what Selenium cannot
do: answer the Web Bluetooth device chooser (the DeviceAccess domain, whose
prompts are events). A plain WebSocket (RFC 6455) over a socket: Debian has
no python3-websocket package, and this is all we need of one (text frames,
masked from the client, no extensions).

Use: chooser = DeviceChooser(driver, name="Rehand 6600"); ...; chooser.close().
The chooser answers every prompt of the page that lists a device named so.
"""
import base64
import json
import os
import socket
import struct
import threading
import urllib.request


class DevTools:
    """One DevTools session on a target's WebSocket URL."""

    def __init__(self, ws_url, timeout=30):
        assert ws_url.startswith("ws://")
        hostport, _, path = ws_url[len("ws://"):].partition("/")
        host, _, port = hostport.partition(":")
        self.sock = socket.create_connection((host, int(port)), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET /{path} HTTP/1.1\r\nHost: {hostport}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(1)
            if not chunk:
                raise ConnectionError("DevTools closed during the handshake")
            head += chunk
        if b" 101 " not in head.split(b"\r\n")[0]:
            raise ConnectionError(f"DevTools refused the WebSocket: {head[:80]!r}")
        self.sock.settimeout(None)
        self.next_id = 1
        self.lock = threading.Lock()
        self.replies = {}
        self.cond = threading.Condition()
        self.handlers = []      # fn(method, params) for every event
        self.closed = False
        self.reader = threading.Thread(target=self._read_loop, daemon=True)
        self.reader.start()

    def _send_frame(self, text):
        data = text.encode()
        header = bytes([0x81])
        if len(data) < 126:
            header += bytes([0x80 | len(data)])
        elif len(data) < 65536:
            header += bytes([0x80 | 126]) + struct.pack(">H", len(data))
        else:
            header += bytes([0x80 | 127]) + struct.pack(">Q", len(data))
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(data))
        with self.lock:
            self.sock.sendall(header + mask + masked)

    def _recv_exact(self, n):
        out = b""
        while len(out) < n:
            chunk = self.sock.recv(n - len(out))
            if not chunk:
                raise ConnectionError("DevTools closed")
            out += chunk
        return out

    def _read_loop(self):
        message = b""
        try:
            while True:
                b0, b1 = self._recv_exact(2)
                n = b1 & 0x7F
                if n == 126:
                    n = struct.unpack(">H", self._recv_exact(2))[0]
                elif n == 127:
                    n = struct.unpack(">Q", self._recv_exact(8))[0]
                payload = self._recv_exact(n)  # a server's frames are not masked
                opcode = b0 & 0x0F
                if opcode == 8:
                    break
                if opcode in (0, 1):
                    message += payload
                    if b0 & 0x80:
                        self._dispatch(json.loads(message))
                        message = b""
        except (ConnectionError, OSError):
            pass
        with self.cond:
            self.closed = True
            self.cond.notify_all()

    def _dispatch(self, m):
        if "id" in m:
            with self.cond:
                self.replies[m["id"]] = m
                self.cond.notify_all()
        elif "method" in m:
            for handler in list(self.handlers):
                handler(m["method"], m.get("params", {}))

    def send(self, method, params=None, timeout=30):
        """Sends a command and waits for its reply; raises on an error reply."""
        with self.cond:
            mid = self.next_id
            self.next_id += 1
        self._send_frame(json.dumps({"id": mid, "method": method, "params": params or {}}))
        with self.cond:
            if not self.cond.wait_for(lambda: mid in self.replies or self.closed, timeout):
                raise TimeoutError(f"DevTools: no reply to {method}")
            if mid not in self.replies:
                raise ConnectionError(f"DevTools closed before the reply to {method}")
            reply = self.replies.pop(mid)
        if "error" in reply:
            raise RuntimeError(f"DevTools: {method}: {reply['error']}")
        return reply.get("result", {})

    def close(self):
        try:
            self.sock.close()
        except OSError:
            pass


def page_session(driver):
    """A DevTools session on the page Selenium drives (its current tab)."""
    address = driver.capabilities["goog:chromeOptions"]["debuggerAddress"]
    handle = driver.current_window_handle
    with urllib.request.urlopen(f"http://{address}/json/list", timeout=10) as r:
        targets = json.load(r)
    pages = [t for t in targets if t.get("type") == "page"]
    # Selenium's window handle is the target's id.
    page = next((t for t in pages if t.get("id") == handle), pages[0] if len(pages) == 1 else None)
    if page is None:
        raise RuntimeError(f"no page target for window {handle}")
    return DevTools(page["webSocketDebuggerUrl"])


class DeviceChooser:
    """Answers the page's Web Bluetooth chooser: picks the first device
    whose name is `name` (the first prompt comes with an empty list when
    discovery starts; the device follows). `prompts` counts the prompts
    answered; `cancel=True` cancels instead (a person who closes the chooser)."""

    def __init__(self, driver, name, cancel=False):
        self.name = name
        self.cancel = cancel
        self.prompts = 0
        self.seen = []
        self.session = page_session(driver)
        self.session.handlers.append(self._on_event)
        self.session.send("DeviceAccess.enable")

    def _on_event(self, method, params):
        if method != "DeviceAccess.deviceRequestPrompted":
            return
        devices = params.get("devices", [])
        self.seen.append([d.get("name") for d in devices])
        chosen = next((d for d in devices if d.get("name") == self.name), None)
        if self.cancel and devices:
            threading.Thread(target=self._answer, args=("DeviceAccess.cancelPrompt", {"id": params["id"]}),
                             daemon=True).start()
        elif chosen:
            threading.Thread(target=self._answer, args=("DeviceAccess.selectPrompt",
                                                        {"id": params["id"], "deviceId": chosen["id"]}),
                             daemon=True).start()

    def _answer(self, method, params):
        try:
            self.session.send(method, params)
            self.prompts += 1
        except (RuntimeError, TimeoutError, ConnectionError):
            pass  # a prompt answered already (the device list came again): the first answer counts

    def close(self):
        self.session.close()
