"""What the Python tests and benchmarks share: a free loopback port, polling
with a deadline, whether a TCP port accepts, and a percentile. Import with
the tests/ folder on sys.path."""
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
