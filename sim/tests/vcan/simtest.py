"""Shared fixture of the cobridge-sim end-to-end tests (run inside UML by
tests/vcan/run-in-vcan): a raw CAN socket per interface, the simulator as a
subprocess driven through its stdin control channel, and checks that fail
the test (exit code 1) on the first mismatch. Nothing here ever skips.

Frames are written as whole 8-byte payloads (the manuals print the command byte
and "Byte0 .. Byte6" in separate columns), hex bytes
separated by blanks ("23 10 10 01 73 61 76 65").
"""

import argparse
import os
import select
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time
import traceback

CAN_FMT = "=IB3x8s"
CAN_FRAME_SIZE = struct.calcsize(CAN_FMT)
CAN_EFF_FLAG = 0x80000000
CAN_RTR_FLAG = 0x40000000
CAN_ERR_FLAG = 0x20000000
SOL_CAN_RAW = 101
CAN_RAW_ERR_FILTER = 2

# UML is slow (one CPU, the simulator and the test share it): generous
# answer timeouts; a frame that must NOT come is awaited for QUIET seconds.
ANSWER_TIMEOUT = 2.0
QUIET = 0.3


class TestFailure(Exception):
    pass


def hexs(data):
    return " ".join("%02X" % b for b in data)


def parse_hex(text):
    return bytes(int(x, 16) for x in text.split())


def check(condition, message):
    if not condition:
        raise TestFailure(message)


class Frame:
    __slots__ = ("can_id", "data", "t", "flags")

    def __init__(self, can_id, data, t=0.0, flags=0):
        self.can_id = can_id
        self.data = bytes(data)
        self.t = t
        self.flags = flags

    @property
    def is_error(self):
        return bool(self.flags & CAN_ERR_FLAG)

    def __repr__(self):
        kind = "ERR " if self.is_error else ""
        return "%s%03X: %s" % (kind, self.can_id, hexs(self.data))


class Bus:
    """A CAN_RAW socket on one interface."""

    def __init__(self, iface, errors=False, rcvbuf=8 << 20):
        self.iface = iface
        self.sock = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        except OSError:
            pass
        if errors:
            self.sock.setsockopt(SOL_CAN_RAW, CAN_RAW_ERR_FILTER, struct.pack("=I", 0x1FFFFFFF))
        self.sock.bind((iface,))
        self.sock.setblocking(False)

    def close(self):
        self.sock.close()

    def send(self, can_id, data, rtr=False):
        data = bytes(data)
        raw_id = can_id | (CAN_EFF_FLAG if can_id > 0x7FF else 0) | (CAN_RTR_FLAG if rtr else 0)
        self.sock.send(struct.pack(CAN_FMT, raw_id, len(data), data.ljust(8, b"\0")))

    def recv(self, timeout):
        """One frame or None after `timeout` seconds."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                raw = self.sock.recv(CAN_FRAME_SIZE)
            except BlockingIOError:
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                select.select([self.sock], [], [], left)
                continue
            can_id, length, data = struct.unpack(CAN_FMT, raw)
            flags = can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)
            if can_id & CAN_ERR_FLAG:
                ident = can_id & 0x1FFFFFFF
            elif can_id & CAN_EFF_FLAG:
                ident = can_id & 0x1FFFFFFF
            else:
                ident = can_id & 0x7FF
            return Frame(ident, data[:length], time.monotonic(), flags)

    def drain(self):
        n = 0
        while self.recv(0) is not None:
            n += 1
        return n

    def wait_for(self, predicate, timeout=ANSWER_TIMEOUT):
        """The first frame matching predicate, or None. Others are dropped."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            f = self.recv(left)
            if f is None:
                return None
            if predicate(f):
                return f

    def collect(self, predicate, duration):
        """Every frame matching predicate during `duration` seconds."""
        out = []
        deadline = time.monotonic() + duration
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return out
            f = self.recv(left)
            if f is not None and predicate(f):
                out.append(f)


RUNNING = []


class Sim:
    """cobridge-sim as a subprocess; control commands go through its stdin."""

    def __init__(self, exe, args, name="cobridge-sim"):
        self.name = name
        self.args = [exe] + list(args)
        self.proc = subprocess.Popen(self.args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=None, bufsize=0)
        RUNNING.append(self)
        self._buf = b""
        line = self._readline(20.0)
        if line != "ready":
            self.proc.kill()
            raise TestFailure("%s did not start (%r): %s" % (name, line, " ".join(self.args)))

    def _readline(self, timeout):
        deadline = time.monotonic() + timeout
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            r, _, _ = select.select([self.proc.stdout], [], [], left)
            if not r:
                return None
            chunk = os.read(self.proc.stdout.fileno(), 4096)
            if not chunk:
                return None
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return line.decode()

    def command(self, line, expect_ok=True):
        self.proc.stdin.write((line + "\n").encode())
        self.proc.stdin.flush()
        reply = self._readline(10.0)
        check(reply is not None, "%s: no reply to %r" % (self.name, line))
        if expect_ok:
            check(reply.startswith("ok"), "%s: %r -> %r" % (self.name, line, reply))
        return reply

    def stop(self):
        if self.proc.poll() is not None:
            return self.proc.returncode
        try:
            self.proc.stdin.write(b"quit\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            pass
        try:
            return self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            raise TestFailure("%s did not end on 'quit'" % self.name)

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def wait_boot_ups(bus, nodes, timeout=10.0):
    """Waits until every node in `nodes` (a list; repeats allowed) sent 0x700+n `00`."""
    want = {}
    for n in nodes:
        want[n] = want.get(n, 0) + 1
    deadline = time.monotonic() + timeout
    while any(v > 0 for v in want.values()):
        left = deadline - time.monotonic()
        check(left > 0, "boot-ups missing on %s: %s" % (bus.iface, {hex(0x700 + k): v for k, v in want.items() if v}))
        f = bus.recv(left)
        if f is None:
            continue
        node = f.can_id - 0x700
        if 0 < node < 128 and f.data == b"\x00" and want.get(node, 0) > 0:
            want[node] -= 1


class Report:
    """Counts the checks and prints one line per check. Telegram checks are
    soft (the script goes on and reports every mismatch); the script still
    exits 1 if any failed."""

    def __init__(self):
        self.checks = 0
        self.failures = []

    def ok(self, label, detail=""):
        self.checks += 1
        print("  ok   %s%s" % (label, (" " + detail) if detail else ""), flush=True)

    def fail(self, message):
        self.checks += 1
        self.failures.append(message)
        print("  FAIL %s" % message, flush=True)


REPORT = Report()


def exchange(bus, req_id, req, resp_id, timeout=ANSWER_TIMEOUT):
    """Sends one request and returns the first frame on resp_id (or None)."""
    bus.drain()
    bus.send(req_id, req)
    return bus.wait_for(lambda f: f.can_id == resp_id and not f.is_error, timeout)


def expect_telegram(bus, label, req_id, req_hex, resp_id, resp_hex, note=None):
    """The manual's request must give the manual's answer byte for byte."""
    f = exchange(bus, req_id, parse_hex(req_hex), resp_id)
    if f is None:
        REPORT.fail("%s: no answer on %03X to %03X: %s" % (label, resp_id, req_id, req_hex))
        return None
    want = parse_hex(resp_hex)
    if f.data != want:
        REPORT.fail("%s: %03X: %s -> %03X: %s, expected %s" % (label, req_id, req_hex, resp_id,
                                                               hexs(f.data), hexs(want)))
        return None
    REPORT.ok(label, "%03X: %s -> %03X: %s%s" % (req_id, req_hex, resp_id, hexs(f.data),
                                                (" (" + note + ")") if note else ""))
    return f


def expect_silence(bus, label, req_id, req_hex, resp_id, note=None):
    """The request must get no answer at all on resp_id."""
    bus.drain()
    bus.send(req_id, parse_hex(req_hex))
    f = bus.wait_for(lambda fr: fr.can_id == resp_id, QUIET)
    if f is not None:
        REPORT.fail("%s: unexpected answer %r to %03X: %s" % (label, f, req_id, req_hex))
        return
    REPORT.ok(label, "%03X: %s -> (no answer)%s" % (req_id, req_hex, (" (" + note + ")") if note else ""))


def sdo_read(bus, node, index, sub):
    req = bytes([0x40, index & 0xFF, index >> 8, sub, 0, 0, 0, 0])
    f = exchange(bus, 0x600 + node, req, 0x580 + node)
    check(f is not None, "SDO read %04X/%d of node %d: no answer" % (index, sub, node))
    check(len(f.data) == 8, "SDO answer of %d bytes: %r" % (len(f.data), f))
    check(f.data[0] != 0x80, "SDO read %04X/%d of node %d aborted: %s" % (index, sub, node, hexs(f.data[4:])))
    cs = f.data[0]
    check(cs & 0xE3 == 0x43 or cs == 0x42, "SDO read %04X/%d: not an expedited answer: %r" % (index, sub, f))
    size = 4 - ((cs >> 2) & 3) if cs & 0x01 else 4
    return int.from_bytes(f.data[4:4 + size], "little")


def sdo_write(bus, node, index, sub, value, size):
    cs = {1: 0x2F, 2: 0x2B, 3: 0x27, 4: 0x23}[size]
    req = bytes([cs, index & 0xFF, index >> 8, sub]) + (value & ((1 << (8 * size)) - 1)).to_bytes(size, "little")
    req = req.ljust(8, b"\0")
    f = exchange(bus, 0x600 + node, req, 0x580 + node)
    check(f is not None, "SDO write %04X/%d of node %d: no answer" % (index, sub, node))
    want = bytes([0x60, index & 0xFF, index >> 8, sub, 0, 0, 0, 0])
    check(f.data == want, "SDO write %04X/%d=%#x of node %d: %s, expected %s" % (
        index, sub, value, node, hexs(f.data), hexs(want)))


def sdo_abort_code(bus, node, req):
    f = exchange(bus, 0x600 + node, req, 0x580 + node)
    check(f is not None, "node %d: no answer to %s" % (node, hexs(req)))
    check(f.data[0] == 0x80, "node %d: expected an abort for %s, got %s" % (node, hexs(req), hexs(f.data)))
    return int.from_bytes(f.data[4:8], "little")


def nmt(bus, command, node):
    bus.send(0x000, bytes([command, node]))


def main(run):
    """Entry point of every test script: parses --sim, runs `run(args)`,
    exits 0 only when it returned without a failure."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--sim", required=True, help="path of cobridge-sim")
    parser.add_argument("--iface", default="vcan0")
    parser.add_argument("--iface2", default="vcan1")
    args = parser.parse_args()
    args.tmp = tempfile.mkdtemp(prefix="cobridge-sim-e2e-")
    started = time.monotonic()
    try:
        run(args)
    except TestFailure as e:
        REPORT.fail(str(e))
    except Exception:  # noqa: BLE001 - any crash is a failure, never a skip
        traceback.print_exc()
        REPORT.fail("exception")
    finally:
        for sim in RUNNING:
            sim.kill()
        shutil.rmtree(args.tmp, ignore_errors=True)
    elapsed = time.monotonic() - started
    if REPORT.failures:
        print("FAIL (%d of %d checks failed, %.1f s)" % (len(REPORT.failures), REPORT.checks, elapsed), flush=True)
        for f in REPORT.failures:
            print("  - " + f, flush=True)
        sys.exit(1)
    if REPORT.checks == 0:
        print("FAIL: no checks ran", flush=True)
        sys.exit(1)
    print("PASS (%d checks, %.1f s)" % (REPORT.checks, elapsed), flush=True)
    sys.exit(0)
