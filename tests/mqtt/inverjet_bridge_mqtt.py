#!/usr/bin/python3
"""The Inverjet MQTT bridge against a real Mosquitto broker, with Debian's
mosquitto_sub / mosquitto_pub as the independent peers, and the simulated
machine on a pty. Starts what it needs (a broker on a free loopback port with
a config file written here), stops it by PID.

Timing: every wait is for an event (a socket that accepts, a subscription the
broker confirmed, a message seen) under a generous deadline, never a fixed
sleep that assumes how fast this machine is; only the checks that something
does NOT happen watch for a bounded time. The temporary folder is removed at
the end.

Usage: inverjet_bridge_mqtt.py RTUKIT
Prints "ok NAME" / "FAIL NAME detail" per check; exits 1 when one failed.
"""
import ctypes
import getpass
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import pyhelpers  # noqa: E402
from pyhelpers import START_DEADLINE, Console, connects, free_port, temp_dir, wait_for  # noqa: E402

RTUKIT = sys.argv[1]
failures = []
procs = []


def check(name, cond, detail=""):
    print(f"{'ok' if cond else 'FAIL'} {name} {detail if not cond else ''}".rstrip(), flush=True)
    if not cond:
        failures.append(name)


def _end_with_us():
    # In the child: SIGTERM when this script ends, however it ends (even
    # SIGKILL from the test runner's deadline): no broker, simulator or
    # bridge is left running. (prctl(PR_SET_PDEATHSIG) = 1)
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM, 0, 0, 0)


def start(argv, **kw):
    """A child with its stderr kept (in ERR_DIR, or the file given) for
    stop()'s check (pyhelpers.check_child)."""
    p = pyhelpers.start(argv, ERR_DIR or tempfile.gettempdir(), preexec_fn=_end_with_us, **kw)
    procs.append(p)
    return p


def stop(p, sig=signal.SIGTERM):
    """Ends `p` with `sig` (SIGKILL: a power cut, on purpose), then checks its
    end once: no sanitizer report, and our binary ended clean on SIGTERM."""
    if p.poll() is None:
        # Told once only: the finally block below tells every program at
        # once, then waits here. A second SIGTERM to a program already ending
        # (its loop over, cleaning up: slow under qemu) is a second Ctrl-C,
        # which may end it by the signal's default action, as it should.
        if getattr(p, "sent", None) != sig:
            p.send_signal(sig)
            p.sent = sig
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.killed_here = True
            p.wait()
    if sig == signal.SIGKILL:
        p.killed_on_purpose = True
    if not getattr(p, "checked", False):
        p.checked = True
        pyhelpers.check_child(p, getattr(p, "sent", None) == signal.SIGTERM)


class Broker:
    def __init__(self, work, port, extra=""):
        self.conf = os.path.join(work, f"mosquitto-{port}.conf")
        with open(self.conf, "w") as f:
            # As root, mosquitto drops to the user named here before it reads
            # the password file (which lives in our private temporary folder).
            f.write(f"listener {port} 127.0.0.1\npersistence false\nuser {getpass.getuser()}\n"
                    f"{extra or 'allow_anonymous true'}\n")
        self.port = port
        self.start()

    def start(self):
        self.p = start(["mosquitto", "-c", self.conf])
        if not wait_for(lambda: connects(self.port) or self.p.poll() is not None, START_DEADLINE) \
                or self.p.poll() is not None:
            raise RuntimeError(f"mosquitto on port {self.port} did not come up (exit {self.p.poll()})")

    def restart(self):
        stop(self.p)
        self.start()


def pub(port, topic, payload, retain=False, auth=()):
    """mosquitto_pub at QoS 1; an empty payload is sent as the empty message (-n)."""
    argv = ["mosquitto_pub", "-h", "127.0.0.1", "-p", str(port), "-t", topic, "-q", "1", *auth]
    argv += ["-m", payload] if payload != "" else ["-n"]
    if retain:
        argv.append("-r")
    try:
        return subprocess.run(argv, capture_output=True, text=True, timeout=START_DEADLINE).returncode
    except subprocess.TimeoutExpired:  # (a client fighting another one for its client id)
        return None


class Subscriber:
    """mosquitto_sub on `topics`, returned once the broker has confirmed the
    subscription (its SUBACK, seen with -d): whatever is published after that
    reaches it. messages() gives the payload lines (with -v: "topic payload")
    until `count` came or `timeout` s passed."""

    def __init__(self, port, topics, count=None, timeout=30, auth=(), verbose=False, qos=0):
        # Line-buffered (stdbuf): into a pipe, mosquitto_sub would hold its -d lines until it exits.
        argv = ["stdbuf", "-oL", "mosquitto_sub", "-d", "-h", "127.0.0.1", "-p", str(port), "-W", str(timeout),
                "-q", str(qos), *auth]
        for t in topics:
            argv += ["-t", t]
        if count:
            argv += ["-C", str(count)]
        if verbose:
            argv.append("-v")
        self.p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                                  preexec_fn=_end_with_us)
        self.ready = False
        try:
            for line in self.p.stdout:
                if "received SUBACK" in line:
                    self.ready = True
                    break
        finally:
            if not self.ready:
                self.close()
        if not self.ready:
            raise RuntimeError(f"mosquitto_sub {' '.join(topics)} on port {port}: no SUBACK")

    def messages(self):
        for line in self.p.stdout:
            # -d's own lines: "Client ... sending/received ...", "Subscribed (mid: 1): 0".
            if line.startswith("Client ") or line.startswith("Subscribed (mid"):
                continue
            yield line.rstrip("\n")

    def close(self):
        stop(self.p)
        self.p.stdout.close()


def sub(port, topics, auth=(), timeout=START_DEADLINE):
    """The retained messages on `topics` as [(topic, payload)], all of them and
    no more, without watching for a while: subscribed (SUBACK), the broker
    has queued every retained message for us; a probe we publish after that
    comes behind them. None when the broker does not serve us (refused, no
    TLS) or `timeout` passed."""
    user = auth[auth.index("-u") + 1] if "-u" in auth else "anonymous"
    probe = f"rtukit/inverjet/{user}/test-probe"  # inside what the ACL grants each user
    token = os.urandom(8).hex()
    try:
        s = Subscriber(port, [*topics, probe], timeout=timeout, auth=auth, verbose=True)
    except RuntimeError:
        return None
    try:
        if pub(port, probe, token, auth=auth) != 0:
            return None
        msgs = []
        for line in s.messages():
            topic, _, payload = line.partition(" ")
            if topic != probe:
                msgs.append((topic, payload))
            elif payload == token:
                return msgs
        return None
    finally:
        s.close()


def retained(port, topic, auth=(), timeout=START_DEADLINE):
    """The retained message on `topic`, or None."""
    msgs = sub(port, [topic], auth, timeout) or []
    return next((v for t, v in msgs if t == topic), None)


def machine(work, name):
    """A simulated machine: its pty, and its console once it accepts (the
    console socket's file exists from bind(), before the simulator listens)."""
    pty, con = os.path.join(work, name), os.path.join(work, name + ".sock")
    sim = start([RTUKIT, "sim", "inverjet", "--listen", f"pty:{pty}", "--no-state", "--no-console", "--console",
                 f"unix:{con}"])
    if not wait_for(lambda: os.path.exists(pty) or sim.poll() is not None, START_DEADLINE) or sim.poll() is not None:
        raise RuntimeError(f"simulator {name} did not come up (exit {sim.poll()})")
    return pty, Console(con)


ERR_DIR = None  # the bridges' stderr files: main() makes it inside its temporary folder


def bridge(pty, port, mid, *extra, scheme="mqtt"):
    # stderr kept: a sanitizer build (ASan, TSan) reports there.
    # stdout kept: it names the bridge's client ids; stderr its warnings.
    name = os.path.join(ERR_DIR, f"{mid}-{len(procs)}")
    p = start([RTUKIT, "inverjet", "bridge", "--port", pty, "--mqtt", f"{scheme}://127.0.0.1:{port}", "--id", mid,
               "--poll-hz", "4", "--max-rate", "4", *extra], stdout=open(name + ".out", "w"),
              stderr=open(name + ".err", "w"))
    p.files = name
    return p


def client_id(b):
    """The client id the bridge `b` printed at start (None before it did)."""
    m = re.search(r"\(client id ([^)]+)\)", open(b.files + ".out").read())
    return m.group(1) if m else None


def documented_acl():
    """The fleet ACL exactly as docs/security.md gives it (the block after the
    pool-fleet-acl marker): the test runs the documentation."""
    doc = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "security.md")).read()
    block = doc[doc.index("<!-- pool-fleet-acl -->"):]
    return block.split("```")[1].split("\n", 1)[1]


def body(**fields):
    """A command's JSON payload, stamped now ("ts", required) unless given."""
    fields.setdefault("ts", int(time.time()))
    return json.dumps(fields)


def command(port, mid, cmd, payload, auth=(), timeout=30):
    """Publishes a command and returns the bridge's answer to it on .../result
    (the first answer naming this command, and its id when the payload has one;
    a late answer to an earlier command is skipped); None when none came
    within `timeout` s."""
    out = Subscriber(port, [f"rtukit/inverjet/{mid}/result"], timeout=timeout, auth=auth)
    try:
        pub(port, f"rtukit/inverjet/{mid}/set/{cmd}", payload, auth=auth)
        try:
            want_id = json.loads(payload).get("id")
        except (ValueError, AttributeError):
            want_id = None
        for line in out.messages():
            r = json.loads(line)
            if r.get("command") == cmd and r.get("id") == want_id:
                return r
        return None
    finally:
        out.close()


# Home Assistant's MQTT discovery schema (the keys each component takes, as
# documented on home-assistant.io/integrations/<component>.mqtt), for the
# keys the bridge uses.
COMMON = {"name", "unique_id", "object_id", "device", "availability_topic", "payload_available",
          "payload_not_available", "availability", "availability_mode", "icon", "entity_category",
          "enabled_by_default", "qos", "json_attributes_topic", "json_attributes_template", "encoding"}
SCHEMA = {
    "sensor": COMMON | {"state_topic", "value_template", "unit_of_measurement", "device_class", "state_class",
                        "force_update", "expire_after", "suggested_display_precision"},
    "binary_sensor": COMMON | {"state_topic", "value_template", "payload_on", "payload_off", "device_class",
                               "force_update", "expire_after", "off_delay"},
    "number": COMMON | {"state_topic", "value_template", "command_topic", "command_template", "min", "max", "step",
                        "mode", "unit_of_measurement", "device_class", "optimistic", "retain"},
    "button": COMMON | {"command_topic", "command_template", "payload_press", "device_class", "retain"},
    "select": COMMON | {"state_topic", "value_template", "command_topic", "command_template", "options",
                        "optimistic", "retain"},
}
DEVICE_KEYS = {"identifiers", "connections", "name", "manufacturer", "model", "sw_version", "hw_version",
               "suggested_area", "via_device", "configuration_url"}
REQUIRED = {"sensor": {"state_topic"}, "binary_sensor": {"state_topic"}, "number": {"command_topic"},
            "button": {"command_topic"}, "select": {"command_topic", "options"}}


def main():
    global ERR_DIR
    work = temp_dir("rtukit-mqtt-")  # removed at exit, on every path (SIGHUP too)
    ERR_DIR = os.path.join(work, "bridge-stderr")
    os.mkdir(ERR_DIR)
    try:
        port = free_port()
        broker = Broker(work, port)
        pty, con = machine(work, "jet1")

        # a retained command left on the broker before the bridge comes up
        pub(port, "rtukit/inverjet/pool1/set/start", '{"mode":"free","speed":60}', retain=True)
        refusal = Subscriber(port, ["rtukit/inverjet/pool1/result"], count=1, timeout=START_DEADLINE)
        b = bridge(pty, port, "pool1")
        check("availability online", wait_for(lambda: retained(port, "rtukit/inverjet/pool1/availability") == "online",
                                               START_DEADLINE))
        doc = wait_for(lambda: retained(port, "rtukit/inverjet/pool1/state"), START_DEADLINE)
        state = json.loads(doc) if doc else {}
        check("retained state document", state.get("state") == "off" and state.get("speed") == 0
              and state.get("bus_v") == 311.0 and "versions" in state, doc)
        answer = json.loads(next(refusal.messages(), None) or "{}")
        refusal.close()
        check("a retained command is refused", answer.get("ok") is False and "retained" in answer.get("error", ""), answer)
        check("a retained command is never run", con.ask("get state").startswith("state = off"), con.ask("get state"))
        pub(port, "rtukit/inverjet/pool1/set/start", "", retain=True)  # clear it
        check("per-value topics", wait_for(lambda: retained(port, "rtukit/inverjet/pool1/value/bus_v") == "311.0"),
              sub(port, ["rtukit/inverjet/pool1/value/#"]))

        # every command and every refusal
        r = command(port, "pool1", "start", body(mode="timer", speed=80, duration="30:00", id=7))
        check("start timer", r and r["ok"] and r.get("id") == 7, r)
        check("the machine runs it", wait_for(lambda: con.ask("get speed").startswith("speed = 80")), con.ask("get speed"))
        check("state published on change", wait_for(
            lambda: json.loads(retained(port, "rtukit/inverjet/pool1/state") or "{}").get("speed") == 80))
        r = command(port, "pool1", "speed", body(speed=120))
        check("speed 120 refused with the client's reason", r and not r["ok"] and "outside 0..100" in r["error"], r)
        r = command(port, "pool1", "speed", body(speed=55))
        check("speed 55", r and r["ok"] and wait_for(lambda: "55" in con.ask("get speed")), r)
        r = command(port, "pool1", "speed", body(speed="60"))
        check("speed as text (a wrong type) refused", r and not r["ok"] and "whole number" in r["error"], r)
        r = command(port, "pool1", "pause", body())
        check("pause", r and r["ok"], r)
        r = command(port, "pool1", "resume", body())
        check("resume", r and r["ok"], r)
        r = command(port, "pool1", "start", body(mode="timer", speed=50))
        check("timer without duration refused", r and not r["ok"] and "duration" in r["error"], r)
        r = command(port, "pool1", "start", body(mode="warp"))
        check("unknown mode refused", r and not r["ok"] and "warp" in r["error"], r)
        r = command(port, "pool1", "fly", body())
        check("unknown command refused", r and not r["ok"] and "unknown command" in r["error"], r)
        r = command(port, "pool1", "plan", body(plan=2, segments=[{"speed": 40, "end": "05:00"},
                                                                   {"speed": 60, "end": "04:00"}]))
        check("a plan with decreasing end times refused, nothing written",
              r and not r["ok"] and "segment 2" in r["error"], r)
        r = command(port, "pool1", "plan", body(plan=2, segments=[{"speed": 40, "end": 300}]))
        check("a plan end as a bare number refused", r and not r["ok"] and "end" in r["error"], r)
        r = command(port, "pool1", "plan", body(plan=2, segments=[{"speed": 40, "end": "05:00"},
                                                                   {"speed": 70, "end": "10m"}]))
        check("plan upload", r and r["ok"] and r.get("segments") == 2, r)
        r = command(port, "pool1", "stop", body())
        check("stop", r and r["ok"] and wait_for(lambda: con.ask("get state").startswith("state = off")), r)
        r = command(port, "pool1", "pause", body())
        check("pause with nothing running: the Modbus exception by name",
              r and not r["ok"] and "exception 04" in r["error"], r)

        # ---- commands are explicit or refused: none of these may start the machine
        now = int(time.time())
        bad = [
            ("an empty message (mosquitto_pub -n)", "", "empty"),
            ("a button's PRESS", "PRESS", "JSON object"),
            ("false", "false", "JSON object"),
            ("true", "true", "JSON object"),
            ("a number", "60", "JSON object"),
            ("null", "null", "JSON object"),
            ("an array", "[]", "JSON object"),
            ("not JSON", "{mode: free", "JSON object"),
            ("no ts", json.dumps({"mode": "free", "speed": 30}), '"ts" is required'),
            ("ts as text", json.dumps({"mode": "free", "speed": 30, "ts": str(now)}), '"ts" is required'),
            ("a command sent 60 s ago", body(mode="free", speed=30, ts=now - 60), "stale"),
            ("a command from the year 2100", body(mode="free", speed=30, ts=4102444800), "future"),
            ("ts 30 s ahead, in milliseconds", body(mode="free", speed=30, ts=(now + 30) * 1000), "future"),
            ("no mode", body(speed=30), '"mode" is required'),
            ("mode false", body(mode=False), '"mode" is required'),
            ("speed as text", body(mode="free", speed="30"), "whole number"),
            ("a timer of a bare 30", body(mode="timer", speed=30, duration="30"), "30:00"),
            ("a timer duration as a JSON number", body(mode="timer", speed=30, duration=1800), "duration"),
            ("a plan number as text", body(mode="plan", plan="2"), "plan"),
        ]
        for what, payload, why in bad:
            r = command(port, "pool1", "start", payload)
            check(f"refused, with a reason: {what}", r and r["ok"] is False and why in r.get("error", ""), r)
        check("...and none of them started the machine", con.ask("get state").startswith("state = off"),
              con.ask("get state"))
        # Retained while the bridge is online (MQTT 5, retain as published).
        r = command(port, "pool1", "start", body(mode="free", speed=40))  # warm: a normal command is run
        check("a fresh command runs", r and r["ok"], r)
        command(port, "pool1", "stop", body())
        wait_for(lambda: con.ask("get state").startswith("state = off"))
        out = Subscriber(port, ["rtukit/inverjet/pool1/result"], timeout=30)
        pub(port, "rtukit/inverjet/pool1/set/start", body(mode="free", speed=40), retain=True)
        answer = json.loads(next(out.messages(), None) or "{}")
        out.close()
        check("a command published retained while the bridge is online is refused",
              answer.get("ok") is False and "retained" in answer.get("error", ""), answer)
        out = Subscriber(port, ["rtukit/inverjet/pool1/result"], timeout=30)
        pub(port, "rtukit/inverjet/pool1/set/start", "", retain=True)  # cleared the standard way: -r -n
        answer = json.loads(next(out.messages(), None) or "{}")
        out.close()
        check("clearing it with mosquitto_pub -r -n is refused too", answer.get("ok") is False, answer)
        check("...and the machine stays off", con.ask("get state").startswith("state = off"), con.ask("get state"))

        # ---- 1000 commands in a burst: every one answered (run, or refused as busy)
        n = 1000
        out = Subscriber(port, ["rtukit/inverjet/pool1/result"], count=n, timeout=120, qos=1)
        lines = "".join(json.dumps({"speed": 40, "ts": int(time.time()), "id": i}) + "\n" for i in range(n))
        subprocess.run(["mosquitto_pub", "-h", "127.0.0.1", "-p", str(port), "-t", "rtukit/inverjet/pool1/set/speed",
                        "-q", "1", "-l"], input=lines, text=True, capture_output=True)
        answers = {}
        for line in out.messages():
            a = json.loads(line)
            answers[a.get("id")] = a
        out.close()
        busy = sum(1 for a in answers.values() if "busy" in a.get("error", ""))
        check(f"{n} commands in a burst: each answered ({len(answers)}, {busy} busy)",
              set(answers) == set(range(n)), sorted(set(range(n)) - set(answers))[:10])
        print(f"# burst: {n} commands, {len(answers)} answers, {busy} refused as busy, "
              f"{sum(1 for a in answers.values() if a.get('ok'))} ran", flush=True)

        r = command(port, "pool1", "start", body(mode="plan", plan=2))
        check("a plan starts (plan 2)", r and r["ok"] and wait_for(
            lambda: json.loads(retained(port, "rtukit/inverjet/pool1/state") or "{}").get("plan_select") == "Plan 2"), r)
        command(port, "pool1", "stop", body())

        # a fault shows
        con.ask("fault motor-drive")
        check("fault published", wait_for(lambda: json.loads(retained(port, "rtukit/inverjet/pool1/state") or "{}")
                                          .get("fault") is True), retained(port, "rtukit/inverjet/pool1/state"))
        con.ask("fault clear")

        # Home Assistant discovery
        disc = sub(port, ["homeassistant/#"]) or []
        comps = {}
        bad = []
        own = {"rtukit/inverjet/pool1/" + t for t in ("state", "availability", "set/speed", "set/start", "set/pause",
                                                      "set/resume", "set/stop")}
        for topic, payload in disc:
            parts = topic.split("/")
            if len(parts) != 5 or parts[0] != "homeassistant" or parts[4] != "config":
                bad.append(f"topic {topic}")
                continue
            comp = parts[1]
            cfg = json.loads(payload)
            comps[comp] = comps.get(comp, 0) + 1
            if comp not in SCHEMA:
                bad.append(f"component {comp}")
                continue
            extra = set(cfg) - SCHEMA[comp]
            missing = REQUIRED[comp] - set(cfg)
            if extra or missing:
                bad.append(f"{topic}: unknown {sorted(extra)} missing {sorted(missing)}")
            if set(cfg.get("device", {})) - DEVICE_KEYS:
                bad.append(f"{topic}: device keys {sorted(set(cfg['device']) - DEVICE_KEYS)}")
            for k, v in cfg.items():
                if k.endswith("_topic") and v not in own:
                    bad.append(f"{topic}: {k} {v} is not a bridge topic")
            if cfg.get("unique_id", "").count("pool1") != 1 or parts[3] not in cfg.get("unique_id", ""):
                bad.append(f"{topic}: unique_id {cfg.get('unique_id')}")
            # Every command Home Assistant sends is stamped with the time it was sent.
            if "command_topic" in cfg and "now().timestamp()" not in cfg.get("command_template", ""):
                bad.append(f"{topic}: no command_template with ts")
        check("discovery payloads follow the schema", not bad, "; ".join(bad[:6]))
        check("discovery announces every entity", comps == {"sensor": 9, "number": 1, "binary_sensor": 1,
                                                            "button": 4, "select": 1}, comps)

        # broker restart: the bridge comes back by itself and publishes again
        broker.restart()
        # (the bridge retries at 1, 2, 4... up to 30 s: a restart that took long is seen up to 30 s late)
        check("after a broker restart: online again", wait_for(
            lambda: retained(port, "rtukit/inverjet/pool1/availability") == "online", 60))
        check("after a broker restart: state again", wait_for(
            lambda: retained(port, "rtukit/inverjet/pool1/state") is not None, START_DEADLINE))

        # the machine unplugged, then back
        stop(procs[1], signal.SIGKILL)  # the simulator
        check("machine gone: offline", wait_for(
            lambda: retained(port, "rtukit/inverjet/pool1/availability") == "offline", START_DEADLINE))
        pty2, con = machine(work, "jet1")
        check("machine back: online", wait_for(
            lambda: retained(port, "rtukit/inverjet/pool1/availability") == "online", START_DEADLINE))

        # last will: the bridge killed
        stop(b, signal.SIGKILL)
        check("bridge killed: the broker publishes offline (last will)", wait_for(
            lambda: retained(port, "rtukit/inverjet/pool1/availability") == "offline", START_DEADLINE))
        b = bridge(pty, port, "pool1")
        check("bridge back", wait_for(lambda: retained(port, "rtukit/inverjet/pool1/availability") == "online",
                                      START_DEADLINE))
        stop(b)
        # Exit 0: it ended on SIGTERM (not killed, which would publish the last will instead).
        check("bridge stopped cleanly: offline", b.returncode == 0 and wait_for(
            lambda: retained(port, "rtukit/inverjet/pool1/availability") == "offline"), b.returncode)
        plan = subprocess.run([RTUKIT, "inverjet", "plan", "show", "2", "--port", pty, "--json"], capture_output=True,
                              text=True)
        # The simulator was restarted without state: plan 2 is the factory plan again; shown to prove the port is free.
        check("the port is free after the bridge stops", plan.returncode == 0, plan.stdout + plan.stderr)

        # ---- identity and least privilege, with the fleet ACL of docs/security.md
        aport = free_port()
        pw = os.path.join(work, "passwd")
        subprocess.run(["mosquitto_passwd", "-b", "-c", pw, "jetA", "secretA"], check=True)
        subprocess.run(["mosquitto_passwd", "-b", pw, "jetB", "secretB"], check=True)
        subprocess.run(["mosquitto_passwd", "-b", pw, "homeassistant", "secretH"], check=True)
        acl = os.path.join(work, "acl")
        with open(acl, "w") as f:
            f.write(documented_acl())
        os.chmod(pw, 0o600)
        Broker(work, aport, f"allow_anonymous false\npassword_file {pw}\nacl_file {acl}")
        ptyA, conA = machine(work, "jetA")
        ptyB, conB = machine(work, "jetB")
        bridges = {}
        for name, p_ in (("jetA", ptyA), ("jetB", ptyB)):
            with open(os.path.join(work, name + ".pw"), "w") as f:
                f.write("secret" + name[-1] + "\n")
            bridges[name] = bridge(p_, aport, name, "--user", name, "--password-file", os.path.join(work, name + ".pw"))
        authA = ("-u", "jetA", "-P", "secretA")
        authB = ("-u", "jetB", "-P", "secretB")
        authH = ("-u", "homeassistant", "-P", "secretH")
        check("A and B online", wait_for(lambda: retained(aport, "rtukit/inverjet/jetA/availability", authA) == "online"
                                         and retained(aport, "rtukit/inverjet/jetB/availability", authB) == "online",
                                         START_DEADLINE))
        # At QoS 1 mosquitto_pub returns once the broker has taken the message;
        # B's answer to a command published after it shows B's bridge has seen
        # everything the broker let through before (one subscription, in order).
        pub(aport, "rtukit/inverjet/jetB/set/start", body(mode="free", speed=70), auth=authA)
        r = command(aport, "jetB", "fly", body(), auth=authB)
        check("B answers its own credentials' command after A's attempt", r and not r["ok"], r)
        check("A's credentials cannot command B", conB.ask("get state").startswith("state = off"), conB.ask("get state"))
        r = command(aport, "jetA", "start", body(mode="free", speed=70), auth=authA)
        check("A's credentials command A", r and r["ok"] and wait_for(lambda: not conA.ask("get state").startswith("state = off")), r)
        check("A cannot read B's state", retained(aport, "rtukit/inverjet/jetB/state", authA) is None)
        # Home Assistant: reads every machine, commands only the one it is given.
        check("homeassistant reads both machines", retained(aport, "rtukit/inverjet/jetA/state", authH) is not None
              and retained(aport, "rtukit/inverjet/jetB/state", authH) is not None)
        check("homeassistant reads machine A's discovery (the %u pattern inside a topic level)",
              len(sub(aport, ["homeassistant/+/rtukit_inverjet_jetA/#"], authH) or []) == 16)
        pub(aport, "homeassistant/button/rtukit_inverjet_jetA/forged/config", '{"name":"forged"}', retain=True,
            auth=authB)
        check("B cannot announce entities for machine A",
              retained(aport, "homeassistant/button/rtukit_inverjet_jetA/forged/config", authH) is None)
        r = command(aport, "jetA", "stop", body(id=1), auth=authH)
        check("homeassistant commands machine A", r and r["ok"] and wait_for(
            lambda: conA.ask("get state").startswith("state = off")), r)
        pub(aport, "rtukit/inverjet/jetB/set/start", body(mode="free", speed=70), auth=authH)
        r = command(aport, "jetB", "fly", body(), auth=authB)
        check("homeassistant cannot command machine B", r and conB.ask("get state").startswith("state = off"),
              conB.ask("get state"))
        pub(aport, "rtukit/inverjet/jetA/availability", "offline", retain=True, auth=authH)
        pub(aport, "rtukit/inverjet/jetA/state", '{"state":"off"}', retain=True, auth=authB)
        check("nobody else writes a machine's availability or state",
              retained(aport, "rtukit/inverjet/jetA/availability", authA) == "online"
              and json.loads(retained(aport, "rtukit/inverjet/jetA/state", authA) or "{}").get("versions"))
        # The client id: unique per machine and per bridge instance.
        ida = wait_for(lambda: client_id(bridges["jetA"]), START_DEADLINE)
        idb = client_id(bridges["jetB"])
        check("each bridge has its own client id, with a random part",
              ida and idb and re.fullmatch(r"rtukit-inverjet-jetA-[0-9a-f]{8}", ida) and idb.startswith("rtukit-inverjet-jetB-"),
              (ida, idb))
        # Another user connecting as the old well-known id (or any guess) knocks nobody off.
        guesser = start(["mosquitto_sub", "-h", "127.0.0.1", "-p", str(aport), "-i", "rtukit-inverjet-jetA",
                         "-t", "rtukit/inverjet/jetB/#", *authB])
        r = command(aport, "jetA", "start", body(mode="free", speed=30, id=2), auth=authA)
        check("a client using the old well-known id does not displace the bridge", r and r["ok"]
              and guesser.poll() is None and retained(aport, "rtukit/inverjet/jetA/availability", authA) == "online", r)
        command(aport, "jetA", "stop", body(), auth=authA)
        wait_for(lambda: conA.ask("get state").startswith("state = off"))
        stop(guesser)
        # The bridge's real id, leaked. MQTT has the broker close a connection
        # when another one presents its client id, whoever that one logs in as,
        # and no ACL refuses a client id: the squatter does knock the bridge
        # off (each connection with the id replaces the other). What the ACL
        # holds is that the id brings none of jetA's rights: logged in as jetB,
        # the squatter can neither command machine A nor write its state,
        # availability or discovery; and the bridge comes back by itself.
        watch = Subscriber(aport, ["rtukit/inverjet/jetA/state", "rtukit/inverjet/jetA/availability",
                                   "homeassistant/+/rtukit_inverjet_jetA/#"], timeout=120, auth=authH, verbose=True)
        squat = (*authB, "-i", ida)
        pub(aport, "rtukit/inverjet/jetA/set/start", body(mode="free", speed=70), auth=squat)
        pub(aport, "rtukit/inverjet/jetA/state", '{"state":"off","by":"squatter"}', retain=True, auth=squat)
        pub(aport, "rtukit/inverjet/jetA/availability", "squatter", retain=True, auth=squat)
        pub(aport, "homeassistant/button/rtukit_inverjet_jetA/squatter/config", '{"name":"squatter"}', retain=True,
            auth=squat)
        # Back: online (retained, as the bridge republishes it on reconnecting) and answering its commands.
        r = wait_for(lambda: retained(aport, "rtukit/inverjet/jetA/availability", authA) == "online"
                     and command(aport, "jetA", "stop", body(id=3), auth=authA, timeout=3), START_DEADLINE, 0.2)
        check("after a squatter with the bridge's client id: the bridge is back online and answers", bool(r), r)
        # While a connection holds the bridge's id the bridge is off the broker
        # and hears no command; once it is back, the same login on a
        # connection of its own is held by the ACL. (The answer to A's own
        # command after it shows the bridge saw whatever came through before.)
        pub(aport, "rtukit/inverjet/jetA/set/start", body(mode="free", speed=70), auth=authB)
        r = command(aport, "jetA", "fly", body(), auth=authA)
        check("the squatter cannot command machine A, with the bridge's id or without",
              r and conA.ask("get state").startswith("state = off"), conA.ask("get state"))
        stop(watch.p)
        seen = watch.p.stdout.read().splitlines()
        watch.p.stdout.close()
        check("...nor write its state, availability or discovery", seen and not [m for m in seen if "squatter" in m],
              [m for m in seen if "squatter" in m][:3] or "nothing seen")
        check("...and what Home Assistant has retained is the bridge's",
              retained(aport, "rtukit/inverjet/jetA/availability", authH) == "online"
              and json.loads(retained(aport, "rtukit/inverjet/jetA/state", authH) or "{}").get("versions")
              and retained(aport, "homeassistant/button/rtukit_inverjet_jetA/squatter/config", authH) is None)
        availability = [m.split(" ", 1)[1] for m in seen if m.startswith("rtukit/inverjet/jetA/availability ")]
        # Each of the squatter's connections may knock it off again, or find it
        # reconnecting: how many offline/online pairs is the machine's timing
        # (a busy CI run saw online, offline, online, online). What must hold:
        # knocked off at least once, and online last.
        check("what no ACL stops: the squatter knocks the bridge off (its last will, offline), and it comes back",
              "offline" in availability[1:] and availability[-1] == "online", availability)
        # Warnings: no credentials (the pool1 bridge above ran anonymous).
        err = open(b.files + ".err").read()
        check("the bridge warns when it has no broker credentials", "no broker credentials" in err, err[:300])
        check("...and not when it has some", "no broker credentials" not in open(bridges["jetA"].files + ".err").read())

        # ---- TLS to the broker (a CA of our own, the server certificate for 127.0.0.1)
        ca_key, ca, key, csr, crt = (os.path.join(work, n) for n in ("ca.key", "ca.crt", "srv.key", "srv.csr", "srv.crt"))
        ssl = lambda *a: subprocess.run(["openssl", *a], check=True, capture_output=True)  # noqa: E731
        ssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", ca_key, "-out", ca, "-days", "2",
            "-subj", "/CN=rtukit test CA")
        ssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", key, "-out", csr, "-subj", "/CN=127.0.0.1")
        ext = os.path.join(work, "san.ext")
        with open(ext, "w") as f:
            f.write("subjectAltName=IP:127.0.0.1\n")
        ssl("x509", "-req", "-in", csr, "-CA", ca, "-CAkey", ca_key, "-CAcreateserial", "-out", crt, "-days", "2",
            "-extfile", ext)
        for f_ in (key, crt, ca):
            os.chmod(f_, 0o644)
        tport = free_port()
        Broker(work, tport, f"allow_anonymous true\ncafile {ca}\ncertfile {crt}\nkeyfile {key}")
        ptyT, conT = machine(work, "jetT")
        bridge(ptyT, tport, "tls1", "--tls-ca", ca, scheme="mqtts")
        tls_sub = ("--cafile", ca)
        check("TLS: the bridge is online through the encrypted link",
              wait_for(lambda: retained(tport, "rtukit/inverjet/tls1/availability", tls_sub) == "online",
                       START_DEADLINE))
        # (a plain mosquitto_sub retries until its -W: 5 s of being refused)
        check("TLS: a plain client is not served", retained(tport, "rtukit/inverjet/tls1/availability", timeout=5) is None)
        ptyU, _ = machine(work, "jetU")
        # A bridge that trusts another CA (a stranger's), not the broker's:
        # it must refuse the broker's certificate. (Without --tls-ca the
        # bridge refuses to start at all, which proved nothing of TLS.)
        other_key, other_ca = os.path.join(work, "other-ca.key"), os.path.join(work, "other-ca.crt")
        ssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", other_key, "-out", other_ca, "-days", "2",
            "-subj", "/CN=a stranger's CA")
        untrusting = bridge(ptyU, tport, "tls2", "--tls-ca", other_ca, scheme="mqtts")
        # The event, not a sleep: the bridge says it could not connect (after
        # its 3 s of tries), and nothing of it is on the broker then.
        said = wait_for(lambda: "does not answer" in open(untrusting.files + ".err").read(), START_DEADLINE)
        check("TLS: a bridge that does not trust the broker's certificate does not connect",
              bool(said) and retained(tport, "rtukit/inverjet/tls2/availability", tls_sub) is None,
              open(untrusting.files + ".err").read()[-300:])

        # ---- 20 machines on one broker
        fport = free_port()
        Broker(work, fport)
        for i in range(20):
            p_, _ = machine(work, f"fleet{i}")
            bridge(p_, fport, f"swim{i:02d}", "--no-discovery")
        online = wait_for(lambda: sum(1 for t, v in sub(fport, ["rtukit/inverjet/+/availability"]) or []
                                      if v == "online") == 20, 2 * START_DEADLINE, 0.2)
        check("20 machines online, each under its own id", online)
        states = set()

        def twenty_states():
            states.clear()
            states.update(t for t, _ in sub(fport, ["rtukit/inverjet/+/state"]) or [])
            return len(states) == 20
        check("20 state documents", wait_for(twenty_states, START_DEADLINE, 0.5), len(states))
    finally:
        # All told at once, then waited for: some forty programs end together
        # (one by one they took longer than a runner's grace before SIGKILL).
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                p.sent = signal.SIGTERM
        for p in reversed(procs):
            stop(p)
        reports = [n for n in os.listdir(ERR_DIR) if n.endswith(".err") and "Sanitizer" in open(os.path.join(ERR_DIR, n)).read()]
        check("no sanitizer report from any bridge", not reports,
              "".join(open(os.path.join(ERR_DIR, n)).read()[:3000] for n in reports[:1]))
        shutil.rmtree(work, ignore_errors=True)
    bad = failures + [f"child process: {c}" for c in pyhelpers.child_problems]
    print("PASS" if not bad else f"FAILED: {', '.join(bad)}")
    return 0 if not bad else 1


if __name__ == "__main__":
    # Stopped by the test runner (its deadline): end through the finally
    # blocks, which stop what was started and remove the temporary folder.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    sys.exit(main())
