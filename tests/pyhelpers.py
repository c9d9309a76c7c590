"""What the Python tests and benchmarks share: a free loopback port, polling
with a deadline, whether a TCP port accepts, connecting to a server that may
still be starting, a percentile, a simulator's console, a small WebSocket
client, temporary folders that go when the program ends, and children
started with their stderr kept and checked when they are stopped. Import with the tests/ folder on sys.path.

Timing: a test waits for events (a socket that accepts, an answer, a state
seen) with generous deadlines, never for a fixed time: a deadline only costs
time when the test fails anyway, while a short one fails on a busy machine
(scripts/busy.sh). START_DEADLINE is the one for a program coming up."""
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


# How long a started program may take to open its socket and accept: a
# sanitizer build on a machine whose other core is busy starts in seconds.
START_DEADLINE = 30.0

# The bound of every stop path of the Rehand 6600 host (docs/rehand6600.md,
# "How the host writes"): the 300-ms lease + one poll (at most 100 ms) +
# 500 ms for the machine; 950 ms with RTUKIT_BUSY (scripts/test.sh --busy).
# Never seconds.
STOP_BOUND_S = 0.3 + 0.1 + (0.95 if os.environ.get("RTUKIT_BUSY") else 0.5)


def host_polls_later(state, n=2, wait=None):
    """Returns once the Rehand host daemon has polled its controller `n` more
    times (its state()'s last_contact_ms moves at each poll): long enough for
    anything it would write to have reached the controller, and for motion to
    show. An event, not a sleep. `state`: a function returning the daemon's
    /api/state document; `wait(seconds, until)`: how to wait (the mock
    BlueZ's pump), wait_for by default. False when a poll did not come."""
    for _ in range(n):
        seen = state()["last_contact_ms"]
        until = lambda: state()["last_contact_ms"] > seen  # noqa: E731
        if not (wait(START_DEADLINE, until) if wait else wait_for(until, START_DEADLINE, 0.01)):
            return False
    return True


def wait_for(fn, timeout=START_DEADLINE, step=0.02):
    """fn() until it returns something true, at most `timeout` s; its last value.

    The default deadline is START_DEADLINE: an event on a loaded machine
    (the full suite beside two compilers under ASan) comes late, and a wait
    that succeeds returns as soon as it does, so only a failure waits it out."""
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


def connect_retrying(make, address, timeout=START_DEADLINE):
    """A socket from make() connected to `address`, for a server that may
    still be starting: its socket not there yet (FileNotFoundError), or there
    but not accepting yet (ConnectionRefusedError: bound, not listening) is
    tried again until `timeout` s have passed; then the last error is raised."""
    end = time.monotonic() + timeout
    while True:
        s = make()
        try:
            s.connect(address)
            return s
        except (FileNotFoundError, ConnectionRefusedError):
            s.close()
            if time.monotonic() >= end:
                raise
            time.sleep(0.02)
        except BaseException:
            s.close()
            raise


def connect_unix(path, timeout=START_DEADLINE):
    """A connected unix-domain stream socket (a simulator's console)."""
    return connect_retrying(lambda: socket.socket(socket.AF_UNIX), path, timeout)


def connect_tcp(port, host="127.0.0.1", timeout=START_DEADLINE, io_timeout=None, source=None):
    """A TCP connection to host:port, retried while it is refused; `source`:
    the local address to connect from (another loopback address, 127.0.0.N:
    a client from another machine, as the server counts them)."""
    def make():
        s = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
        s.settimeout(io_timeout if io_timeout is not None else timeout)
        if source:
            s.bind((source, 0))
        return s
    return connect_retrying(make, (host, port), timeout)


def pct(xs, p):
    """The p-th percentile of xs (nearest rank); nan when empty."""
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100.0 * (len(xs) - 1))))] if xs else float("nan")


class Console:
    """A simulator's console on its unix socket (`--console unix:PATH`): one
    line in, one line of answer out. Connects as soon as the simulator
    accepts (it may still be starting), within `timeout` s."""

    def __init__(self, path, timeout=START_DEADLINE):
        self.s = connect_unix(path, timeout)
        self.s.settimeout(10)

    def ask(self, line):
        self.s.sendall(line.encode() + b"\n")
        data = b""
        while not data.endswith(b"\n"):
            chunk = self.s.recv(4096)
            if not chunk:
                raise OSError(f"console closed after {data!r}")
            data += chunk
        return data.decode().strip()


class WebSocket:
    """A small WebSocket client (RFC 6455) for the daemons' APIs: text frames
    only, masked as a client must, pings answered. Not a library: enough to
    drive a page's API from a test or a bench without a browser."""

    def __init__(self, port, path, host="127.0.0.1", timeout=5.0, tls=False, headers=None, host_header=None,
                 source=None):
        """`tls`: wss (the certificate is not checked: the tests pin it
        elsewhere); `headers`: more header fields ({"Origin": ...});
        `host_header`: the Host field to send (default host:port);
        `source`: the local address to connect from (connect_tcp).
        Raises OSError("handshake refused: HTTP/1.1 403 ...") on a refusal."""
        import base64
        self.s = connect_tcp(port, host, io_timeout=timeout, source=source)
        if tls:
            import ssl
            ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
            ctx.check_hostname = False
            ctx.verify_mode = ssl.CERT_NONE
            self.s = ctx.wrap_socket(self.s, server_hostname=host)
        key = base64.b64encode(os.urandom(16)).decode()
        more = "".join(f"{k}: {v}\r\n" for k, v in (headers or {}).items())
        self.s.sendall((f"GET {path} HTTP/1.1\r\nHost: {host_header or f'{host}:{port}'}\r\nUpgrade: websocket\r\n"
                        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n{more}\r\n").encode())
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
        self.close_reason = None
        self.hello = None  # the daemon's first message, once read (its "challenge" for a phone)

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

    def request(self, message, timeout=5.0):
        """Sends a JSON message with a fresh "id" and returns the result that
        echoes it (other messages on the way are skipped), or None."""
        import json
        self.next_id = getattr(self, "next_id", 0) + 1
        self.send(json.dumps({**message, "id": self.next_id}))
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            text = self.recv(max(0.01, end - time.monotonic()))
            if text is None:
                return None
            m = json.loads(text)
            if m.get("type") == "result" and m.get("id") == self.next_id:
                return m
        return None

    def _need(self, n):
        while len(self.buf) < n:
            chunk = self.s.recv(65536)
            if not chunk:
                raise OSError("closed")
            self.buf += chunk

    def recv(self, timeout=None):
        """The next text message, or None when `timeout` passes first."""
        self.s.settimeout(timeout)
        # A message may come in fragments (RFC 6455, 5.4): a text frame
        # without FIN, then continuation frames (opcode 0) up to one with
        # FIN. The daemon's server fragments a message over 4 KB (a state
        # with an error's advice is one): read as one frame, it was cut.
        message = None
        try:
            while True:
                self._need(2)
                fin, opcode, n = self.buf[0] & 0x80, self.buf[0] & 0x0F, self.buf[1] & 0x7F
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
                    self.close_reason = payload[2:].decode(errors="replace")
                    raise OSError(f"closed by the server: {self.close_reason}")
                elif opcode == 0x1 or (opcode == 0x0 and message is not None):
                    message = payload if opcode == 0x1 else message + payload
                    if not fin:
                        continue
                    if self.hello is None and b'"hello"' in message:
                        import json
                        self.hello = json.loads(message)
                    return message.decode()
        except socket.timeout:
            return None

    def challenge(self, timeout=5.0):
        """The challenge of the daemon's hello (read now if it was not yet),
        or None."""
        end = time.monotonic() + timeout
        while self.hello is None and time.monotonic() < end:
            if self.recv(max(0.01, end - time.monotonic())) is None:
                break
        return (self.hello or {}).get("challenge")

    def close(self):
        try:
            self._frame(0x8, b"")
        except OSError:
            pass
        self.s.close()


class PhoneKey:
    """A phone's key as the Rehand phone page makes it with WebCrypto
    (web/assets/rehand/phone-key.js): ECDSA P-256, the public key as its raw
    point and signatures as r||s, both base64url. Made with Python's
    cryptography package (Debian's python3-cryptography), for tests that
    speak the phone's protocol without a browser."""

    PREFIX = "rtukit-rehand6600-phone:"  # the daemon's challenge_message

    def __init__(self):
        from cryptography.hazmat.primitives.asymmetric import ec
        self._key = ec.generate_private_key(ec.SECP256R1())

    @staticmethod
    def _b64(raw):
        import base64
        return base64.urlsafe_b64encode(raw).rstrip(b"=").decode()

    def public(self):
        from cryptography.hazmat.primitives import serialization
        return self._b64(self._key.public_key().public_bytes(serialization.Encoding.X962,
                                                             serialization.PublicFormat.UncompressedPoint))

    def sign(self, challenge):
        from cryptography.hazmat.primitives import hashes
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.hazmat.primitives.asymmetric.utils import decode_dss_signature
        r, s = decode_dss_signature(self._key.sign((self.PREFIX + challenge).encode(), ec.ECDSA(hashes.SHA256())))
        return self._b64(r.to_bytes(32, "big") + s.to_bytes(32, "big"))

    def auth(self, ws, phone):
        """Authenticates phone `phone` on the open phone socket `ws`: the result, or None."""
        challenge = ws.challenge()
        if challenge is None:
            return None
        return ws.request({"op": "auth", "phone": phone, "signature": self.sign(challenge)})

    def pair(self, ws, code, name):
        """Pairs with the display's `code` on `ws`, with this key: the result, or None."""
        challenge = ws.challenge()
        if challenge is None:
            return None
        return ws.request({"op": "pair", "code": code, "name": name, "key": self.public(),
                           "signature": self.sign(challenge)})

    def pairing_file(self, path, phone, name, confirmed=True):
        """Writes a pairing file (format 3) in which this key is phone `phone`."""
        import json
        with open(path, "w") as f:
            json.dump({"format": "rtukit rehand6600 pairing 3",
                       "phones": [{"id": phone, "public_key": self.public(), "name": name, "code": "",
                                   "paired_at": "", "confirmed": confirmed}]}, f)


def display_request(port, message):
    """One request on a new display connection of the Rehand host daemon
    (its loopback listener at `port`): the result, or None."""
    ws = WebSocket(port, "/ws?role=display")
    try:
        return ws.request(message)
    finally:
        ws.close()


# What stop_processes found wrong with a child (a sanitizer report, a crash,
# our binary ending unclean after SIGTERM): each a line; the tests' verdict
# (browser_common.summary) fails on any.
child_problems = []
_started = [0]


def start(argv, log_dir, stdout=None, stderr=None, **kw):
    """subprocess.Popen(argv) whose stderr is kept for stop_processes' check:
    in `stderr` when it is a file the caller opened (its name is read back),
    else in a file of its own under `log_dir` (PROGRAM-N.stderr). stdout goes
    to /dev/null unless given."""
    import subprocess
    path = getattr(stderr, "name", None) if stderr not in (None, subprocess.STDOUT) else None
    if stderr is None:
        _started[0] += 1
        path = os.path.join(log_dir, f"{os.path.basename(argv[0])}-{_started[0]}.stderr")
        stderr = open(path, "w")
    if stderr is subprocess.STDOUT and hasattr(stdout, "name"):
        path = stdout.name
    p = subprocess.Popen(argv, stdout=subprocess.DEVNULL if stdout is None else stdout, stderr=stderr, **kw)
    p.stderr_path = path
    return p


def sanitizer_lines(text):
    """The lines a sanitizer or UBSan wrote ("ERROR: AddressSanitizer",
    "runtime error:", "SUMMARY: ...Sanitizer"), as one string ("" if none)."""
    return "\n".join(line for line in text.splitlines() if "Sanitizer" in line or "runtime error:" in line)


def check_child(p, terminated, output=None):
    """The end of a child (issue 36): no sanitizer line in the stderr that
    start() kept; our own `rtukit` binary, when `terminated` (SIGTERM sent
    here), ended by itself with 0 or 128 + SIGTERM (a command cut short says
    so); a child that ended by a signal of its own (a crash) fails too.
    Foreign peers (socat, Python, Mosquitto) may die by SIGTERM. `output`:
    what the child wrote when the caller collected it itself. Returns the
    problems (also added to child_problems and printed as FAIL lines)."""
    import signal
    problems = []
    name = os.path.basename(str(p.args[0] if isinstance(p.args, (list, tuple)) else p.args))
    path = getattr(p, "stderr_path", None)
    if path or output is not None:
        lines = sanitizer_lines(output or "")
        try:
            if path:
                with open(path, errors="replace") as f:
                    lines = sanitizer_lines(f.read())
        except OSError:
            pass
        if lines:
            problems.append(f"{name} (pid {p.pid}) reported: {lines}")
    code = p.returncode
    ours = name == "rtukit" and not getattr(p, "killed_on_purpose", False)  # a power cut a test makes
    if ours and code is not None and code < 0:
        if code == -signal.SIGKILL and getattr(p, "killed_here", False):
            problems.append(f"{name} (pid {p.pid}) did not end within its deadline after SIGTERM (killed)")
        else:
            problems.append(f"{name} (pid {p.pid}) ended by signal {-code}")
    elif ours and terminated and code not in (0, 128 + signal.SIGTERM):
        problems.append(f"{name} (pid {p.pid}) ended unclean after SIGTERM: exit {code}")
    for problem in problems:
        print(f"FAIL child process: {problem}", flush=True)
    child_problems.extend(problems)
    return problems


def stop_processes(procs, timeout=10.0, wait=None):
    """Stops what a test or bench started, last started first: SIGTERM (a
    server ends cleanly: pty link removed, state saved), then SIGKILL for one
    that has not ended within `timeout`; then checks each one's end
    (check_child). `wait(seconds, until)`: how to wait when something in this
    process must go on meanwhile (the mock BlueZ's loop, which answers the
    daemon's goodbye to BlueZ: MockBluez.pump)."""
    import signal
    for p in reversed(procs):
        terminated = False
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
            terminated = True
            if wait:
                wait(timeout, lambda: p.poll() is not None)
            else:
                wait_for(lambda: p.poll() is not None, timeout, 0.01)
            if p.poll() is None:
                p.kill()
                p.killed_here = True
            p.wait()
        check_child(p, terminated)


_temp_dirs = []


def temp_dir(prefix):
    """A new folder under the temporary directory (tempfile.mkdtemp), removed
    with everything in it when the program ends: normally, by an exception or
    SystemExit, or by SIGTERM, SIGHUP or SIGINT (ctest's stop, a closed
    terminal, Ctrl-C; SIGTERM and SIGHUP become SystemExit here, so `finally`
    blocks stop the program's children first). Only SIGKILL leaves it."""
    import atexit
    import signal
    import tempfile
    import threading
    if not _temp_dirs:
        atexit.register(_remove_temp_dirs)
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGTERM, signal.SIGHUP):
                if signal.getsignal(sig) == signal.SIG_DFL:
                    signal.signal(sig, _exit_on_signal)
    d = tempfile.mkdtemp(prefix=prefix)
    _temp_dirs.append(d)
    return d


def _exit_on_signal(signum, frame):
    raise SystemExit(128 + signum)


def _remove_temp_dirs():
    import shutil
    while _temp_dirs:
        shutil.rmtree(_temp_dirs.pop(), ignore_errors=True)
