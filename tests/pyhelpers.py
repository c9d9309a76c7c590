"""What the Python tests and benchmarks share: a free loopback port, polling
with a deadline, whether a TCP port accepts, a percentile, a simulator's
console and a small WebSocket client. Import with the tests/ folder on
sys.path."""
import os
import socket
import time


def free_port():
    """A TCP port on 127.0.0.1 nobody listens on (now)."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def wait_for(fn, timeout=5.0, step=0.02):
    """fn() until it returns something true, at most `timeout` s; its last value."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        v = fn()
        if v:
            return v
        time.sleep(step)
    return fn()


def connects(port, host="127.0.0.1"):
    """Whether a TCP connection to host:port is accepted."""
    try:
        socket.create_connection((host, port), 0.2).close()
        return True
    except OSError:
        return False


def pct(xs, p):
    """The p-th percentile of xs (nearest rank); nan when empty."""
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100.0 * (len(xs) - 1))))] if xs else float("nan")


class Console:
    """A simulator's console on its unix socket (`--console unix:PATH`): one
    line in, one line of answer out."""

    def __init__(self, path):
        self.s = socket.socket(socket.AF_UNIX)
        self.s.connect(path)
        self.s.settimeout(2)

    def ask(self, line):
        self.s.sendall(line.encode() + b"\n")
        data = b""
        while not data.endswith(b"\n"):
            data += self.s.recv(4096)
        return data.decode().strip()


class WebSocket:
    """A small WebSocket client (RFC 6455) for the daemons' APIs: text frames
    only, masked as a client must, pings answered. Not a library: enough to
    drive a page's API from a test or a bench without a browser."""

    def __init__(self, port, path, host="127.0.0.1", timeout=5.0):
        import base64
        self.s = socket.create_connection((host, port), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        self.s.sendall((f"GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.s.recv(4096)
            if not chunk:
                raise OSError("closed during the handshake")
            head += chunk
        status = head.split(b"\r\n", 1)[0]
        if b" 101 " not in status:
            raise OSError(f"handshake refused: {status.decode(errors='replace')}")
        self.buf = head.split(b"\r\n\r\n", 1)[1]

    def _frame(self, opcode, payload):
        mask = os.urandom(4)
        n = len(payload)
        head = bytes([0x80 | opcode])
        if n < 126:
            head += bytes([0x80 | n])
        elif n < 65536:
            head += bytes([0x80 | 126]) + n.to_bytes(2, "big")
        else:
            head += bytes([0x80 | 127]) + n.to_bytes(8, "big")
        self.s.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))

    def send(self, text):
        self._frame(0x1, text.encode())

    def _need(self, n):
        while len(self.buf) < n:
            chunk = self.s.recv(65536)
            if not chunk:
                raise OSError("closed")
            self.buf += chunk

    def recv(self, timeout=None):
        """The next text message, or None when `timeout` passes first."""
        self.s.settimeout(timeout)
        try:
            while True:
                self._need(2)
                opcode, n = self.buf[0] & 0x0F, self.buf[1] & 0x7F
                at = 2
                if n == 126:
                    self._need(4)
                    n, at = int.from_bytes(self.buf[2:4], "big"), 4
                elif n == 127:
                    self._need(10)
                    n, at = int.from_bytes(self.buf[2:10], "big"), 10
                self._need(at + n)
                payload, self.buf = self.buf[at:at + n], self.buf[at + n:]
                if opcode == 0x9:
                    self._frame(0xA, payload)
                elif opcode == 0x8:
                    raise OSError("closed by the server")
                elif opcode == 0x1:
                    return payload.decode()
        except socket.timeout:
            return None

    def close(self):
        try:
            self._frame(0x8, b"")
        except OSError:
            pass
        self.s.close()


def stop_processes(procs, timeout=5.0):
    """Stops what a test or bench started, last started first: SIGTERM (a
    server ends cleanly: pty link removed, state saved), then SIGKILL for one
    that has not ended within `timeout`."""
    import signal
    import subprocess
    for p in reversed(procs):
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(timeout)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
