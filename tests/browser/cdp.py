"""A small client of Chromium's DevTools protocol, for what Selenium cannot
do: answer the Web Bluetooth device chooser (the DeviceAccess domain, whose
prompts are events), pause a page's script, crash a tab. Over the tests' own
WebSocket client (tests/pyhelpers.py): Debian has no python3-websocket.

Use: chooser = DeviceChooser(driver, name="Rehand 6600"); ...; chooser.close().
The chooser answers every prompt of the page that lists a device named so.
"""
import json
import os
import sys
import threading
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from pyhelpers import WebSocket  # noqa: E402


class DevTools:
    """One DevTools session on a target's WebSocket URL (ws://HOST:PORT/PATH),
    over tests/pyhelpers.py's WebSocket client; events go to `handlers`."""

    def __init__(self, ws_url, timeout=30):
        assert ws_url.startswith("ws://")
        hostport, _, path = ws_url[len("ws://"):].partition("/")
        host, _, port = hostport.partition(":")
        self.ws = WebSocket(int(port), "/" + path, host=host, timeout=timeout)
        self.next_id = 1
        self.send_lock = threading.Lock()   # frames from several threads must not interleave
        self.replies = {}
        self.cond = threading.Condition()
        self.handlers = []      # fn(method, params) for every event
        self.closed = False
        self.reader = threading.Thread(target=self._read_loop, daemon=True)
        self.reader.start()

    def _read_loop(self):
        try:
            while True:
                text = self.ws.recv(None)
                if text is not None:
                    self._dispatch(json.loads(text))
        except (OSError, ValueError):
            pass  # closed (by us, or the browser went away)
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
        with self.send_lock:
            self.ws.send(json.dumps({"id": mid, "method": method, "params": params or {}}))
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
            self.ws.s.close()
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
