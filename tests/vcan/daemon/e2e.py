"""Fixtures of cobridged's end-to-end tests: the daemon, the simulator, a raw
CAN listener and a held sd_notify socket, run inside User-Mode Linux by
tests/vcan/run-in-vcan (vcan0, vcan1 up; /run is a tmpfs there).

Every test script takes --daemon, --cli and --sim (the built executables)
and reports each check as PASS/FAIL with its measured times; the exit status
is 1 when any check failed.
"""
import argparse
import contextlib
import errno
import faulthandler
import json
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

SOURCE_DIR = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
DEVICES_DIR = os.path.join(SOURCE_DIR, "config", "devices")


def arm_stack_dump(margin=20.0):
    """A test that hangs says where: `margin` seconds before the guest is killed
    (COBRIDGE_GUEST_DEADLINE, tests/vcan/run-in-vcan) every thread's stack goes to stderr."""
    deadline = os.environ.get("COBRIDGE_GUEST_DEADLINE", "")
    if deadline.isdigit():
        faulthandler.dump_traceback_later(max(1.0, int(deadline) - time.time() - margin), exit=False)


def parse_args(extra=None):
    """The common arguments; extra(parser) adds a test's own."""
    arm_stack_dump()
    p = argparse.ArgumentParser()
    p.add_argument("--daemon", required=True)
    p.add_argument("--cli", required=True)
    p.add_argument("--sim", required=True)
    p.add_argument("--keep", action="store_true", help="keep the work directory")
    p.add_argument("--plugins", help="the output plugin directory (--plugin-dir of cobridged)")
    if extra:
        extra(p)
    return p.parse_args()


# A sanitizer build's end-to-end run (tests/vcan/sanitizer-reports: COBRIDGE_SANITIZER names the
# sanitizer): an -O0 instrumented daemon on the QEMU bed's emulated CPU is many times slower than the
# build users run, so its time bounds are printed, not judged; the default build judges them on both
# beds. Every other check is judged, and any sanitizer report fails the test.
SANITIZER = os.environ.get("COBRIDGE_SANITIZER", "")


class Report:
    """Collects check results; a failed check does not stop the script."""

    def __init__(self, name):
        self.name = name
        self.failed = []
        self.passed = 0
        self.unjudged = []

    def check_bound(self, ok, what, detail=""):
        """A time bound: judged as check() except in a sanitizer build, where a missed one is printed."""
        if ok or not SANITIZER:
            return self.check(ok, what, detail)
        print("BOUND " + what + ((" -- " + detail) if detail else "") + " (not judged: %s build)" % SANITIZER,
              flush=True)
        self.unjudged.append(what)
        return True

    def check(self, ok, what, detail=""):
        line = ("PASS " if ok else "FAIL ") + what + ((" -- " + detail) if detail else "")
        print(line, flush=True)
        if ok:
            self.passed += 1
        else:
            self.failed.append(what)
        return ok

    def finish(self):
        if self.unjudged:
            print("%s: %d time bounds missed in the %s build, not judged: %s" % (
                self.name, len(self.unjudged), SANITIZER, "; ".join(self.unjudged)), flush=True)
        print("%s: %d passed, %d failed%s" % (self.name, self.passed, len(self.failed),
                                             (": " + "; ".join(self.failed)) if self.failed else ""), flush=True)
        return 1 if self.failed else 0


class Workspace:
    """A state directory on the shared file system and a socket directory on /run."""

    def __init__(self, name, keep=False, base="/tmp"):
        """base: where the state directory goes; "/run" puts it on UML's own tmpfs (see
        test_commissioning_scale.py), gone with the machine."""
        self.keep = keep
        self.dir = tempfile.mkdtemp(prefix="cobridge-e2e-%s-" % name, dir=base)
        self.run = tempfile.mkdtemp(prefix="cobridge-e2e-%s-" % name, dir="/run")
        self.state = os.path.join(self.dir, "state")
        self.sim_state = os.path.join(self.dir, "sim-state")
        os.makedirs(self.sim_state)
        self.control = os.path.join(self.run, "ctl", "control.sock")
        self.sim_control = os.path.join(self.run, "sim.sock")

    def path(self, name):
        return os.path.join(self.dir, name)

    def cleanup(self):
        if self.keep:
            print("work directory kept: %s" % self.dir)
            return
        shutil.rmtree(self.dir, ignore_errors=True)
        shutil.rmtree(self.run, ignore_errors=True)


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return str(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return json.dumps(v)


def write_config(ws, buses, devices, file_name="cobridge.toml", level="info", extra="", device_dir=DEVICES_DIR):
    """buses/devices: lists of dicts; a device dict may hold 'tpdo1' (a dict). device_dir: the
    device descriptions (another build's own, for a bench that compares two daemons)."""
    lines = [
        "[gateway]",
        'id = "e2e"',
        "state_dir = %s" % toml_value(ws.state),
        "device_dirs = %s" % toml_value([device_dir]),
        "control_socket = %s" % toml_value(ws.control),
        "",
        "[logging]",
        'level = "%s"' % level,
        'target = "console"',
        "",
    ]
    for b in buses:
        lines.append("[[bus]]")
        lines += ["%s = %s" % (k, toml_value(v)) for k, v in b.items()]
        lines.append("")
    for d in devices:
        lines.append("[[device]]")
        tables = {k: v for k, v in d.items() if isinstance(v, dict)}
        lines += ["%s = %s" % (k, toml_value(v)) for k, v in d.items() if not isinstance(v, dict)]
        for name, t in tables.items():
            lines.append("[device.%s]" % name)
            lines += ["%s = %s" % (k, toml_value(v)) for k, v in t.items()]
        lines.append("")
    lines.append(extra)
    path = ws.path(file_name)
    with open(path, "w") as f:
        f.write("\n".join(lines))
    return path


class _SocketReader:
    """A socket read on a background thread until close(); subclasses keep
    what _received() is given, under self.lock."""

    def _start(self, sock, size):
        sock.settimeout(0.1)
        self.sock = sock
        self.size = size
        self.lock = threading.Lock()
        self.stop_flag = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _read(self):
        """(time, bytes) of the next datagram; the time it was read."""
        return time.time(), self.sock.recv(self.size)

    def _run(self):
        while not self.stop_flag:
            try:
                t, data = self._read()
            except socket.timeout:
                continue
            except OSError as e:
                if e.errno == errno.ENETDOWN and not self.stop_flag:
                    continue  # the interface went down (a fault test): the socket stays bound
                break
            self._received(t, data)

    def close(self):
        self.stop_flag = True
        self.thread.join()
        self.sock.close()


class CanListener(_SocketReader):
    """Every frame on an interface, with the kernel's receive time (same clock
    as time.time()). The kernel stamp, not the time Python got round to the
    frame: under a flood this thread lags by hundreds of ms, and a test that
    compares a frame's time with the daemon's must not see that lag."""

    _SO_RCVBUFFORCE = getattr(socket, "SO_RCVBUFFORCE", 33)  # <asm-generic/socket.h>
    _SO_TIMESTAMP = getattr(socket, "SO_TIMESTAMP", 29)  # struct timeval in the cmsg

    def __init__(self, iface="vcan0", errors=False):
        sock = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
        if errors:  # CAN_RAW_ERR_FILTER (linux/can/raw.h): every error class, as candump -e
            sock.setsockopt(socket.SOL_CAN_RAW, 2, struct.pack("=I", 0x1FFFFFFF))
        try:  # root in UML: beyond net.core.rmem_max, so a flood loses nothing
            sock.setsockopt(socket.SOL_SOCKET, self._SO_RCVBUFFORCE, 4 << 20)
        except OSError:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        sock.setsockopt(socket.SOL_SOCKET, self._SO_TIMESTAMP, 1)
        sock.bind((iface,))
        self.frames = []
        self._start(sock, 16)

    def _read(self):
        data, ancdata, _, _ = self.sock.recvmsg(self.size, socket.CMSG_SPACE(16))
        for level, kind, value in ancdata:
            if level == socket.SOL_SOCKET and kind == self._SO_TIMESTAMP and len(value) >= 16:
                sec, usec = struct.unpack("=qq", value[:16])
                return sec + usec / 1e6, data
        return time.time(), data

    def _received(self, t, data):
        can_id, dlc = struct.unpack("=IB3x", data[:8])
        with self.lock:
            # Error frames keep CAN_ERR_FLAG (0x20000000) in the id, so they are told apart.
            self.frames.append((t, can_id & (0x3FFFFFFF if can_id & 0x20000000 else 0x1FFFFFFF),
                                bytes(data[8:8 + dlc])))

    def snapshot(self, since=0.0):
        with self.lock:
            return [f for f in self.frames if f[0] >= since]

    def wait_quiet(self, pred, quiet, timeout):
        """Waits until no frame for which pred(can_id, data) holds has arrived
        for `quiet` seconds; returns the time the quiet began, or None when
        the bus was never that quiet within `timeout`."""
        end = time.time() + timeout
        while time.time() < end:
            now = time.time()
            last = max([f[0] for f in self.snapshot(now - quiet) if pred(f[1], f[2])], default=None)
            if last is None:
                return now - quiet
            time.sleep(min(0.05, max(0.0, last + quiet - now)))
        return None

    def wait_past(self, t, timeout=5.0):
        """Waits until a frame stamped after `t` is in (the devices' heartbeats come every 100 ms),
        so that a window ending at `t` is whole: this thread reads behind the kernel under load.
        False when none came within `timeout` (a bus quiet since then)."""
        end = time.time() + timeout
        while time.time() < end:
            with self.lock:
                if self.frames and self.frames[-1][0] > t:
                    return True
            time.sleep(0.01)
        return False

    def wait_for(self, pred, timeout, since=0.0):
        """The first frame after `since` for which pred(can_id, data) holds, or None."""
        end = time.time() + timeout
        while time.time() < end:
            for f in self.snapshot(since):
                if pred(f[1], f[2]):
                    return f
            time.sleep(0.005)
        return None


class NotifySocket(_SocketReader):
    """The sd_notify socket systemd would hold: every datagram with its time."""

    def __init__(self, ws):
        self.path = os.path.join(ws.run, "notify.sock")
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        sock.bind(self.path)
        self.messages = []
        self._start(sock, 4096)

    def _received(self, t, data):
        with self.lock:
            self.messages.append((t, data.decode(errors="replace")))

    def all(self):
        with self.lock:
            return list(self.messages)

    def wait_for(self, pred, timeout, after_index=0):
        """(index, time, text) of the first message from after_index matching pred."""
        end = time.time() + timeout
        while time.time() < end:
            msgs = self.all()
            for i in range(after_index, len(msgs)):
                if pred(msgs[i][1]):
                    return i, msgs[i][0], msgs[i][1]
            time.sleep(0.01)
        return None


class Simulator:
    def __init__(self, sim, ws, buses, log_name="sim.log", control=None, extra_args=()):
        """buses: {"vcan0": ["RFC-4800:serial=1001", ...]}; control: the socket path
        (a second simulator needs its own); extra_args: e.g. ("--truth", FILE)."""
        self.control = control or ws.sim_control
        args = [sim, "--state-dir", ws.sim_state, "--control", self.control] + list(extra_args)
        for iface, devs in buses.items():
            args += ["--iface", iface]
            for d in devs:
                args += ["--device", d]
        self.log = open(ws.path(log_name), "a")
        self.ws = ws
        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=self.log,
                                     text=True)
        line = self.proc.stdout.readline()
        if line.strip() != "ready":
            raise RuntimeError("cobridge-sim did not start: %r (see %s)" % (line, ws.path(log_name)))

    def command(self, line):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(5)
        s.connect(self.control)
        s.sendall((line + "\n").encode())
        reply = b""
        while not reply.endswith(b"\n"):
            chunk = s.recv(4096)
            if not chunk:
                break
            reply += chunk
        s.close()
        reply = reply.decode().strip()
        if not reply.startswith("ok"):
            raise RuntimeError("cobridge-sim: %s -> %s" % (line, reply))
        return reply

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


class Daemon:
    """cobridged started through `sh -c 'WATCHDOG_PID=$$ exec ...'`, so the
    PID systemd would announce is the daemon's own."""

    def __init__(self, daemon, config, ws, notify=None, watchdog_usec=None, log_name="daemon.log", extra_args=(),
                 run_as=(), stamp_exec=False):
        """run_as: a command prefix that starts the daemon as another user
        (e.g. ["setpriv", "--reuid=...", "--regid=...", "--init-groups", "--"]).
        stamp_exec: self.exec_time is the wall time in the child just before
        its exec, as a service manager's exec; without it, only self.started
        (before the fork, which costs 40-70 ms of a large Python under UML)."""
        env = dict(os.environ)
        env.pop("NOTIFY_SOCKET", None)
        env.pop("WATCHDOG_USEC", None)
        env.pop("WATCHDOG_PID", None)
        env.pop("JOURNAL_STREAM", None)
        cmd = [daemon, "--config", config, "--foreground"] + list(extra_args)
        if notify is not None:
            env["NOTIFY_SOCKET"] = notify.path
        if watchdog_usec is not None:
            env["WATCHDOG_USEC"] = str(watchdog_usec)
            cmd = ["/bin/sh", "-c", 'WATCHDOG_PID=$$; export WATCHDOG_PID; exec "$@"', "sh"] + cmd
        cmd = list(run_as) + cmd
        self.ws = ws
        self.log_path = ws.path(log_name)
        self.log = open(self.log_path, "a")
        self.started = time.time()
        self.exec_time = None
        if not stamp_exec:
            self.proc = subprocess.Popen(cmd, env=env, stdin=subprocess.DEVNULL, stdout=self.log,
                                         stderr=subprocess.STDOUT)
            return
        r, w = os.pipe()
        try:
            self.proc = subprocess.Popen(cmd, env=env, stdin=subprocess.DEVNULL, stdout=self.log,
                                         stderr=subprocess.STDOUT, pass_fds=(w,),
                                         preexec_fn=lambda: os.write(w, repr(time.time()).encode()))
            os.close(w)
            w = -1
            self.exec_time = float(os.read(r, 64))
        finally:
            os.close(r)
            if w >= 0:
                os.close(w)

    @property
    def pid(self):
        return self.proc.pid

    def wait_socket(self, timeout=30):
        end = time.time() + timeout
        while time.time() < end:
            if self.proc.poll() is not None:
                return False
            try:
                self.request("status")
                return True
            except OSError:
                time.sleep(0.05)
        return False

    def request(self, line, timeout=5):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(timeout)
        try:
            s.connect(self.ws.control)
            s.sendall((line + "\n").encode())
            data = b""
            while not data.endswith(b"\n"):
                chunk = s.recv(1 << 16)
                if not chunk:
                    break
                data += chunk
        finally:
            s.close()
        return json.loads(data.decode())

    def status(self):
        return self.request("status")

    def devices(self):
        """name -> device dict, from the status."""
        out = {}
        for b in self.status()["buses"]:
            for d in b["devices"]:
                out[d["name"]] = d
        return out

    def wait_until(self, pred, timeout, interval=0.02):
        """Polls the status until pred(status) holds; returns (status, seconds) or (last, None)."""
        t0 = time.time()
        last = None
        while time.time() - t0 < timeout:
            if self.proc.poll() is not None:
                break
            try:
                last = self.status()
                if pred(last):
                    return last, time.time() - t0
            except (OSError, ValueError):
                pass
            time.sleep(interval)
        return last, None

    def stop(self, sig=signal.SIGTERM, timeout=5):
        """Sends sig, returns (exit code, seconds to exit)."""
        if self.proc.poll() is not None:
            self.log.close()
            return self.proc.returncode, 0.0
        t0 = time.time()
        self.proc.send_signal(sig)
        try:
            rc = self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            rc = self.proc.wait()
        took = time.time() - t0
        self.log.close()
        return rc, took

    def log_size(self):
        """Where the log ends now: a mark for wait_log."""
        try:
            return os.path.getsize(self.log_path)
        except OSError:
            return 0

    def wait_log(self, text, since=0, timeout=10):
        """Waits until `text` appears in the log after byte offset `since`;
        returns True when it did (a condition, not a fixed sleep)."""
        end = time.time() + timeout
        while time.time() < end:
            with open(self.log_path, errors="replace") as f:
                f.seek(since)
                if text in f.read():
                    return True
            time.sleep(0.02)
        return False

    def tail(self, n=40):
        try:
            with open(self.log_path) as f:
                return "".join(f.readlines()[-n:])
        except OSError:
            return ""


def check_clean_exit(report, daemon, what="SIGTERM -> exit 0 within 1 s", tail=0):
    """Stops the daemon with SIGTERM and checks that it exited 0 within 1 s.
    With `tail`, prints the last `tail` lines of its log first when a check
    of the report failed: what the daemon said is the first clue."""
    if tail and report.failed:
        print(daemon.tail(tail))
    rc, took = daemon.stop()
    if SANITIZER:
        report.check(rc == 0, what + ": exit 0", "exit %s" % rc)
        return report.check_bound(took < 1.0, what, "exit %s after %.3f s" % (rc, took))
    return report.check(rc == 0 and took < 1.0, what, "exit %s after %.3f s" % (rc, took))


def shut_down(ws, daemon, *others):
    """A scenario's `finally`: stops the daemon if it still runs, then each of
    `others` in order (anything with stop() or close()), then removes the
    work directory."""
    if daemon is not None:
        daemon.stop()
    for o in others:
        (o.stop if hasattr(o, "stop") else o.close)()
    ws.cleanup()


def shut_down_pair(daemons, others, workspaces):
    """A hot-standby scenario's `finally`: stops each daemon still running,
    then each of `others` (anything with stop() or close()), then removes the
    work directories."""
    for d in daemons:
        if d.proc.poll() is None:
            d.stop()
    for o in others:
        (o.stop if hasattr(o, "stop") else o.close)()
    for w in workspaces:
        w.cleanup()


def master_heartbeat_overlaps(frames, nodes, period=0.15):
    """Times at which two gateways' heartbeats (0x700 + node-ID) both said master
    (05h) within one period: `nodes` maps a gateway's name to its node-ID."""
    last, out = {}, []
    for t, cid, data in frames:
        for k, node in nodes.items():
            if cid == 0x700 + node and data[:1] == b"\x05":
                last[k] = t
                if any(o != k and t - tl < period for o, tl in last.items()):
                    out.append(t)
    return out


@contextlib.contextmanager
def shut_down_after(ws, parts):
    """Around a scenario's body: however the body ends, shut_down(ws,
    *parts()). `parts` is called then, not now, so that the body may replace
    the daemon or the listener, or set the daemon to None once it stopped it
    itself (check_clean_exit)."""
    try:
        yield
    finally:
        shut_down(ws, *parts())


def all_operational(expected_names):
    def pred(st):
        devs = {d["name"]: d for b in st["buses"] for d in b["devices"]}
        return all(n in devs and devs[n]["state"] == "operational" and devs[n]["online"] for n in expected_names)
    return pred


def run_cli(cli, *args, timeout=10):
    r = subprocess.run([cli] + list(args), capture_output=True, text=True, timeout=timeout)
    return r.returncode, r.stdout, r.stderr


def sh(*cmd):
    """A set-up command (ip, cangw); its stdout. Raises with its stderr when it fails."""
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError("%s: %s" % (" ".join(cmd), r.stderr.strip()))
    return r.stdout


def cli_via_daemon(cli, iface, node, timeout=5.0):
    """Waits until `cobridge sdo read` of node's 0x1000 on `iface` goes through a daemon (its
    beacon) rather than the bus; returns the last answer's "via" and output."""
    via, out = None, ""
    end = time.time() + timeout
    while time.time() < end and via != "daemon":
        rc, out, _ = run_cli(cli, "sdo", "read", "-i", iface, "-n", str(node), "1000:0", "--json")
        try:
            via = json.loads(out).get("via") if rc == 0 else None
        except ValueError:
            via = None
        if via != "daemon":
            time.sleep(0.2)
    return via, out


def iso_to_epoch(text):
    """'2024-05-01T12:00:00.123Z' -> seconds since the epoch."""
    import calendar
    base, ms = text.rstrip("Z").split(".")
    return calendar.timegm(time.strptime(base, "%Y-%m-%dT%H:%M:%S")) + int(ms) / 1000.0
