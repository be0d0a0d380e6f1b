#!/usr/bin/python3
"""End-to-end tests of the Modbus TCP output plugin (libcobridge_modbus.so).

Each suite starts modbus_test_host (which loads the plugin through the real
PluginHost and feeds samples: see modbus_test_host.cpp for the values) on the
loopback with port 0, learns the port from the plugin's log line, and talks
to it with pymodbus and with raw sockets (for what pymodbus cannot send).

References: Modbus Application Protocol Specification V1.1b3 ("MBAP §"),
Modbus Messaging on TCP/IP Implementation Guide V1.0b ("TCP §"),
docs/modbus.md (the register map).

Usage: modbus_e2e.py --host PATH --plugin PATH [Suite ...]
"""
import argparse
import os
import resource
import queue
import re
import socket
import statistics
import struct
import subprocess
import sys
import threading
import time
import types
import unittest

# Debian's python3-pymodbus imports serial_asyncio for its serial client even
# when only TCP is used; the package is not a dependency. TCP needs none of it.
try:
    import serial_asyncio  # noqa: F401
except ImportError:
    _stub = types.ModuleType("serial_asyncio")
    _stub.create_serial_connection = None
    sys.modules["serial_asyncio"] = _stub
from pymodbus.client import ModbusTcpClient  # noqa: E402

ARGS = None
MAP_VERSION = 3  # gateway register 0 (docs/modbus.md)
DEVICE_BASE = 256
STRIDE = 32


class Host:
    """A running modbus_test_host."""

    def __init__(self, config, devices=4, rate=1000, extra=(), nofile=None):
        cfg = 'bind = "127.0.0.1"\nport = 0\n' + config

        def limit():
            if nofile is not None:
                resource.setrlimit(resource.RLIMIT_NOFILE, (nofile, nofile))

        self.proc = subprocess.Popen(
            [ARGS.host, ARGS.plugin, cfg, str(devices), str(rate), *extra],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, preexec_fn=limit)
        self.lines = queue.Queue()
        self.log = []
        threading.Thread(target=self._pump, daemon=True).start()
        self.port = None
        self.error = None
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.5)
            except queue.Empty:
                if self.proc.poll() is not None:
                    break
                continue
            m = re.search(r"listening on .*:(\d+) ", line)
            if m:
                self.port = int(m.group(1))
            if line.startswith("ERROR"):
                self.error = line
                break
            if line.startswith("READY"):
                break

    def _pump(self):
        for line in self.proc.stdout:
            self.log.append(line)
            self.lines.put(line)

    def alive(self):
        return self.proc.poll() is None

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def connect(port, timeout=5.0):
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def frame(tid, unit, pdu, proto=0, length=None):
    if length is None:
        length = len(pdu) + 1
    return struct.pack(">HHHB", tid, proto, length, unit) + pdu


def read_req(tid, address, count, unit=1, fc=3):
    return frame(tid, unit, struct.pack(">BHH", fc, address, count))


def recv_exact(sock, n):
    """n bytes, or None if the peer closed first."""
    buf = b""
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            return None
        buf += chunk
    return buf


def recv_frame(sock):
    """One response frame, or None if the connection was closed."""
    head = recv_exact(sock, 7)
    if head is None:
        return None
    _, _, length, _ = struct.unpack(">HHHB", head)
    body = recv_exact(sock, length - 1)
    return None if body is None else head + body


def is_closed(sock, timeout=3.0):
    sock.settimeout(timeout)
    try:
        return sock.recv(1) == b""
    except ConnectionResetError:
        return True
    except socket.timeout:
        return False


def regs_of(resp):
    """Register values of a read response."""
    n = resp[8] // 2
    return list(struct.unpack(">%dH" % n, resp[9:9 + 2 * n]))


def u32(regs, i, big=True):
    hi, lo = (regs[i], regs[i + 1]) if big else (regs[i + 1], regs[i])
    return (hi << 16) | lo


def s32(v):
    return v - (1 << 32) if v & 0x80000000 else v


class HostCase(unittest.TestCase):
    CONFIG = ""
    DEVICES = 4
    RATE = 1000
    EXTRA = ()

    @classmethod
    def setUpClass(cls):
        cls.host = Host(cls.CONFIG, cls.DEVICES, cls.RATE, cls.EXTRA)
        if cls.host.port is None:
            cls.host.stop()
            raise RuntimeError("host did not start: " + "".join(cls.host.log))

    @classmethod
    def tearDownClass(cls):
        cls.host.stop()

    def read(self, address, count, unit=1, fc=3):
        with connect(self.host.port) as s:
            s.sendall(read_req(1, address, count, unit, fc))
            r = recv_frame(s)
        self.assertIsNotNone(r)
        return r

    def assert_serving(self):
        self.assertTrue(self.host.alive())
        r = self.read(0, 1)
        self.assertEqual(r[7], 3)
        self.assertEqual(regs_of(r), [MAP_VERSION])


class Values(HostCase):
    """docs/modbus.md register map, read with pymodbus (MBAP §6.3 / §6.4)."""

    def check_slot(self, d, regs, big=True):
        seq = u32(regs, 12, big)
        self.assertEqual(regs[26], 1, "present")
        self.assertEqual(s32(u32(regs, 0, big)), d * 1_000_000 + seq, "position matches its sequence")
        self.assertEqual(s32(u32(regs, 2, big)), d * 10 + 1, "speed")
        self.assertEqual(regs[4], seq & 0xFF, "cam_state")
        self.assertEqual(regs[8], 5, "NMT operational")
        self.assertEqual(regs[9], 1, "online")
        self.assertEqual(regs[10], 0, "stale")
        self.assertEqual(regs[16], 200 + d, "temperature")
        self.assertEqual(regs[17], 240, "voltage")
        self.assertEqual(regs[18], d + 1, "node_id")
        self.assertEqual(regs[19], d % 2, "bus_index")
        self.assertEqual(u32(regs, 20, big), 1000 + d, "serial")
        self.assertEqual(u32(regs, 22, big), 0x12D, "vendor")
        self.assertEqual(u32(regs, 24, big), 0x100 + d, "product")
        return seq

    def test_device_registers_hold_the_fed_values(self):
        client = ModbusTcpClient("127.0.0.1", port=self.host.port, timeout=5)
        self.assertTrue(client.connect())
        try:
            last = {}
            for _ in range(3):
                for d in range(self.DEVICES):
                    rr = client.read_holding_registers(DEVICE_BASE + d * STRIDE, 28, slave=1)
                    self.assertFalse(rr.isError(), rr)
                    seq = self.check_slot(d, rr.registers)
                    self.assertGreater(seq, last.get(d, 0))
                    last[d] = seq
                    ri = client.read_input_registers(DEVICE_BASE + d * STRIDE, 28, slave=1)
                    self.assertFalse(ri.isError(), ri)
                    self.check_slot(d, ri.registers)
                time.sleep(0.05)
        finally:
            client.close()

    def test_gateway_and_bus_blocks(self):
        client = ModbusTcpClient("127.0.0.1", port=self.host.port, timeout=5)
        self.assertTrue(client.connect())
        try:
            gw = client.read_holding_registers(0, 16, slave=1).registers
            self.assertEqual(gw[0], MAP_VERSION)
            self.assertEqual(gw[6], 2)            # buses 0 and 1
            self.assertEqual(gw[7], self.DEVICES)
            self.assertEqual(gw[8], self.DEVICES)  # all online
            self.assertEqual(gw[9], 32)           # slots
            self.assertEqual(gw[10], DEVICE_BASE)
            self.assertEqual(gw[11], STRIDE)
            bus = client.read_holding_registers(16, 16, slave=1).registers
            for b in range(2):
                blk = bus[b * 8:(b + 1) * 8]
                self.assertEqual(blk[0], 1)  # state ok
                self.assertEqual(blk[1], 2)  # devices
                self.assertEqual(blk[2], 2)
                self.assertGreater(u32(blk, 4), 0)  # frames
                self.assertEqual(u32(blk, 6), 0)    # drops
                self.assertEqual(blk[3], 0)  # controller_state: unknown, no on_bus from this host
            ctl = client.read_holding_registers(144, 8, slave=1).registers
            self.assertEqual(ctl[0:2], [65535, 65535])  # controller block 0: counters not reported
            self.assertEqual(u32(ctl, 2), 0)            # restarts
        finally:
            client.close()

    def test_little_word_order(self):
        host = Host('word_order = "little"\n', 2, 1000)
        try:
            self.assertIsNotNone(host.port)
            with connect(host.port) as s:
                s.sendall(read_req(1, DEVICE_BASE + STRIDE, 28))
                regs = regs_of(recv_frame(s))
                s.sendall(read_req(2, 12, 1))
                self.assertEqual(regs_of(recv_frame(s)), [1])  # word_order = little
            self.check_slot(1, regs, big=False)
        finally:
            host.stop()


class DataAge(HostCase):
    """docs/modbus.md data_age: computed at read time from the rx timestamp."""
    EXTRA = ("--frozen", "3")

    def test_data_age_matches_1ms_feed(self):
        ages = []
        with connect(self.host.port) as s:
            for i in range(100):
                s.sendall(read_req(i, DEVICE_BASE + 11, 1))
                ages.append(regs_of(recv_frame(s))[0])
                time.sleep(0.003)
        ages.sort()
        print("data age at 1 kHz: median %d ms, p95 %d ms, max %d ms" % (
            statistics.median(ages), ages[94], ages[-1]))
        self.assertLessEqual(statistics.median(ages), 3)
        self.assertLessEqual(ages[94], 20)
        self.assertLessEqual(ages[-1], 50)

    def test_frozen_device_ages_in_real_time(self):
        addr = DEVICE_BASE + 3 * STRIDE + 11
        with connect(self.host.port) as s:
            s.sendall(read_req(1, addr, 1))
            a = regs_of(recv_frame(s))[0]
            t0 = time.monotonic()
            time.sleep(0.5)
            s.sendall(read_req(2, addr, 1))
            b = regs_of(recv_frame(s))[0]
            dt = (time.monotonic() - t0) * 1000
        self.assertAlmostEqual(b - a, dt, delta=15)


class Offline(HostCase):
    """MBAP §7 exception 0x0B for an offline device (offline_exception = true)."""
    CONFIG = "offline_exception = true\n"
    EXTRA = ("--offline", "1")

    def test_offline_device_answers_0x0B(self):
        r = self.read(DEVICE_BASE + STRIDE, 10)
        self.assertEqual(r[7:9], bytes([0x83, 0x0B]))
        r = self.read(DEVICE_BASE + STRIDE - 2, 4, fc=4)  # straddles slots 0 and 1
        self.assertEqual(r[7:9], bytes([0x84, 0x0B]))
        ok = self.read(DEVICE_BASE, 28)
        self.assertEqual(ok[7], 3)
        gw = regs_of(self.read(0, 16))
        self.assertEqual(gw[8], self.DEVICES - 1)  # devices_online


class Writes(HostCase):
    """writes_enabled = true: the command registers (+28 value, +30 command,
    +31 status) hand preset / NMT reset / store to the host (plugin ABI 2
    submit_command) and show the outcome; everything else stays read-only
    (MBAP §6.6 Write Single Register, §6.12 Write Multiple Registers, §7)."""
    # This test's client is on the loopback address: listed.
    CONFIG = 'writes_enabled = true\nwrite_allow = ["127.0.0.1/32"]\n'
    EXTRA = ("--offline", "3")

    def exchange(self, pdu, tid=9):
        with connect(self.host.port) as s:
            s.sendall(frame(tid, 1, pdu))
            s.settimeout(5)
            return recv_frame(s)

    def write_multiple(self, address, values, tid=9):
        pdu = struct.pack(">BHHB", 0x10, address, len(values), 2 * len(values))
        pdu += b"".join(struct.pack(">H", v & 0xFFFF) for v in values)
        return self.exchange(pdu, tid)

    def write_single(self, address, value, tid=9):
        return self.exchange(struct.pack(">BHH", 0x06, address, value), tid)

    def commands_logged(self):
        return [l for l in self.host.log if l.startswith("COMMAND")]

    def wait_status(self, slot, want, timeout=3.0):
        deadline = time.monotonic() + timeout
        regs = None
        while time.monotonic() < deadline:
            regs = regs_of(self.read(DEVICE_BASE + slot * STRIDE + 28, 4))
            if regs[3] == want:
                return regs
            time.sleep(0.02)
        self.fail(f"slot {slot}: command_status {regs} never became {want}")

    def test_every_write_is_logged_with_the_client(self):
        """A write, applied or refused, is logged at info
        with the client's address and port, the registers and the values."""
        base = DEVICE_BASE + 1 * STRIDE
        with connect(self.host.port) as s:
            here = "127.0.0.1:%d" % s.getsockname()[1]
            s.sendall(frame(0x31, 1, struct.pack(">BHHB", 0x10, base + 28, 2, 4) + struct.pack(">HH", 0, 100)))
            s.settimeout(5)
            self.assertIsNotNone(recv_frame(s))
            s.sendall(frame(0x32, 1, struct.pack(">BHH", 0x06, 5, 7)))  # a read-only register
            r = recv_frame(s)
            self.assertEqual(r[7], 0x86)
        want = ["write by %s (unit 1): registers %d..%d = 0x0000 0x0064: applied" % (here, base + 28, base + 29),
                "write by %s (unit 1): register 5 = 0x0007: refused, exception 0x%02X" % (here, r[8])]
        deadline = time.monotonic() + 3
        while time.monotonic() < deadline and not all(any(w in l for l in self.host.log) for w in want):
            time.sleep(0.02)
        info = [l for l in self.host.log if l.startswith("LOG ") and "write by" in l]
        for w in want:
            self.assertTrue(any(w in l for l in info), "%r not logged; logged: %r" % (w, info))
        # At info: the level of the "listening on" line.
        level = next(l.split()[1] for l in self.host.log if "listening on" in l)
        self.assertTrue(all(l.split()[1] == level for l in info if here in l), info)

    def test_preset_is_submitted_and_its_outcome_shown(self):
        base = DEVICE_BASE + 2 * STRIDE
        value = -123456
        hi, lo = (value >> 16) & 0xFFFF, value & 0xFFFF
        r = self.write_multiple(base + 28, [hi, lo, 1], tid=0x21)
        # §6.12: the response echoes address and quantity.
        self.assertEqual(r, bytes([0, 0x21, 0, 0, 0, 6, 1, 0x10]) + struct.pack(">HH", base + 28, 3))
        regs = regs_of(self.read(base + 28, 4))
        self.assertEqual(regs[:3], [hi, lo, 1])
        self.assertIn(regs[3], (1, 2))  # pending (the host answers after 300 ms)
        if regs[3] == 1:
            # A second command while the first is pending: 0x06 Server Device Busy.
            busy = self.write_single(base + 30, 3, tid=0x22)
            self.assertEqual(busy, bytes([0, 0x22, 0, 0, 0, 3, 1, 0x86, 0x06]))
        self.wait_status(2, 2)
        self.assertIn("COMMAND device=2 kind=1 tag=", "".join(self.commands_logged()))
        self.assertTrue(any("device=2 kind=1" in l and l.strip().endswith("value=-123456")
                            for l in self.commands_logged()), self.commands_logged())

    def test_refused_preset_shows_the_reason(self):
        base = DEVICE_BASE + 0 * STRIDE
        self.write_multiple(base + 28, [0xFFFF, 0xFFFF, 1])  # -1: the host's device refuses it
        self.assertEqual(self.wait_status(0, 2 + 6)[2], 1)  # 8 = refused by the device

    def test_single_register_write_submits_nmt_reset(self):
        base = DEVICE_BASE + 1 * STRIDE
        r = self.write_single(base + 30, 2, tid=0x31)
        # §6.6: the response is the request.
        self.assertEqual(r, bytes([0, 0x31, 0, 0, 0, 6, 1, 0x06]) + struct.pack(">HH", base + 30, 2))
        self.wait_status(1, 2)
        self.assertTrue(any("device=1 kind=2" in l for l in self.commands_logged()))

    def test_value_only_write_submits_nothing(self):
        before = len(self.commands_logged())
        base = DEVICE_BASE + 1 * STRIDE
        r = self.write_multiple(base + 28, [0x0001, 0x0002])
        self.assertEqual(r[7], 0x10)
        self.assertEqual(regs_of(self.read(base + 28, 2)), [1, 2])
        time.sleep(0.1)
        self.assertEqual(len(self.commands_logged()), before)

    def test_read_only_registers_and_bad_values_are_refused(self):
        base = DEVICE_BASE + 1 * STRIDE
        before = len(self.commands_logged())
        self.assertEqual(self.write_single(base + 27, 1)[7:9], bytes([0x86, 0x02]))      # read-only
        self.assertEqual(self.write_single(base + 31, 1)[7:9], bytes([0x86, 0x02]))      # status: read-only
        self.assertEqual(self.write_multiple(base + 29, [0, 1, 0])[7:9], bytes([0x90, 0x02]))  # reaches +31
        self.assertEqual(self.write_single(0, 1)[7:9], bytes([0x86, 0x02]))              # gateway block
        self.assertEqual(self.write_single(base + 30, 9)[7:9], bytes([0x86, 0x03]))      # no command 9
        self.assertEqual(self.write_single(base + 30, 0)[7:9], bytes([0x86, 0x03]))
        end = DEVICE_BASE + 32 * STRIDE
        self.assertEqual(self.write_single(end, 1)[7:9], bytes([0x86, 0x02]))            # beyond the map
        # An offline device (3) and an empty slot (10): 0x0B, nothing submitted.
        self.assertEqual(self.write_single(DEVICE_BASE + 3 * STRIDE + 30, 2)[7:9], bytes([0x86, 0x0B]))
        self.assertEqual(self.write_single(DEVICE_BASE + 10 * STRIDE + 30, 2)[7:9], bytes([0x86, 0x0B]))
        time.sleep(0.1)
        self.assertEqual(len(self.commands_logged()), before)
        self.assert_serving()

    def test_pymodbus_client_writes(self):
        """An independent client library (pymodbus) drives the same registers."""
        from pymodbus.client import ModbusTcpClient
        c = ModbusTcpClient("127.0.0.1", port=self.host.port)
        self.assertTrue(c.connect())
        try:
            base = DEVICE_BASE + 0 * STRIDE
            rr = c.write_registers(base + 28, [0, 4242, 3], slave=1)
            self.assertFalse(rr.isError(), rr)
            rr = c.write_register(base + 27, 1, slave=1)
            self.assertTrue(rr.isError())
            self.assertEqual(rr.exception_code, 2)
        finally:
            c.close()
        self.wait_status(0, 2)
        self.assertTrue(any("device=0 kind=3" in l for l in self.commands_logged()))


class WritesDisabledDaemon(HostCase):
    """Writes refused with 0x01 while writes_enabled = false, whatever the register."""

    def test_command_register_write_is_0x01(self):
        with connect(self.host.port) as s:
            s.sendall(frame(5, 1, struct.pack(">BHH", 0x06, DEVICE_BASE + 30, 1)))
            s.settimeout(5)
            self.assertEqual(recv_frame(s), bytes([0, 5, 0, 0, 0, 3, 1, 0x86, 0x01]))
        self.assertFalse(any(l.startswith("COMMAND") for l in self.host.log))


class StallWitness(threading.Thread):
    """Sleeps 1 ms at a time and keeps each wake-up more than 5 ms late.

    A stall of the host (a VM's vCPU taken away, the test process descheduled)
    delays the test's own clock readings as much as it delays the server, so
    the part of a measured latency that a stall covers is not the server's.
    """

    def __init__(self):
        super().__init__(daemon=True)
        self.stalls = []  # (start, end) of each late sleep, perf_counter seconds
        self.halt = threading.Event()

    def run(self):
        while not self.halt.is_set():
            t0 = time.perf_counter()
            time.sleep(0.001)
            t1 = time.perf_counter()
            if t1 - t0 > 0.005:
                self.stalls.append((t0 + 0.001, t1))

    def covered(self, t0, t1):
        """Seconds of [t0, t1] the host was stalled."""
        return sum(max(0.0, min(t1, b) - max(t0, a)) for a, b in self.stalls)


class SlowClient(HostCase):
    """A client sending one byte per second, and one that never reads its
    answers, do not delay another client by more than 50 ms.

    The delay is the fast client's latency less the time a StallWitness in
    this process saw the host stalled during it: a server that waited for the
    slow client would add up to a second to the latency, a stall of the VM
    adds the same to the witness's sleep."""

    def test_slow_and_stalled_clients_do_not_delay_others(self):
        slow = connect(self.host.port)
        stalled = connect(self.host.port)
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        request = read_req(0x5151, DEVICE_BASE, 14)
        done = threading.Event()

        def trickle():
            for b in request:
                slow.sendall(bytes([b]))
                time.sleep(1.0)
            done.set()

        def flood():
            # Pipelined requests, answers never read: its output buffer and
            # the socket fill up, then the server stops reading from it.
            payload = b"".join(read_req(i & 0xFFFF, DEVICE_BASE, 125) for i in range(200))
            stalled.setblocking(False)
            while not done.is_set():
                try:
                    stalled.send(payload)
                except BlockingIOError:
                    time.sleep(0.01)
                except OSError:
                    return

        threading.Thread(target=trickle, daemon=True).start()
        threading.Thread(target=flood, daemon=True).start()
        witness = StallWitness()
        witness.start()
        spans = []
        with connect(self.host.port) as fast:
            tid = 0
            while not done.is_set():
                tid = (tid + 1) & 0xFFFF
                t0 = time.perf_counter()
                fast.sendall(read_req(tid, DEVICE_BASE, 28))
                r = recv_frame(fast)
                spans.append((t0, time.perf_counter()))
                self.assertIsNotNone(r)
                self.assertEqual(r[:2], struct.pack(">H", tid))
                self.assertEqual(r[7], 3)
                time.sleep(0.01)
        witness.halt.set()
        witness.join()
        latencies = sorted((t1 - t0) * 1000 for t0, t1 in spans)
        delays = sorted((t1 - t0 - witness.covered(t0, t1)) * 1000 for t0, t1 in spans)
        print("fast client during a 1 byte/s client and a stalled client: %d requests, "
              "latency p50 %.2f ms, p99 %.2f ms, max %.2f ms; host stalls seen: %d, "
              "longest %.1f ms; max latency less the stall it covers: %.2f ms" % (
                  len(latencies), latencies[len(latencies) // 2],
                  latencies[int(len(latencies) * 0.99)], latencies[-1], len(witness.stalls),
                  max(((b - a) * 1000 for a, b in witness.stalls), default=0.0), delays[-1]))
        self.assertGreater(len(latencies), 300)
        self.assertLess(delays[-1], 50.0)
        # The slow client's request was answered in full once complete.
        slow.settimeout(5)
        r = recv_frame(slow)
        self.assertIsNotNone(r)
        self.assertEqual(r[:2], b"\x51\x51")
        self.assertEqual(r[7:9], bytes([3, 28]))
        slow.close()
        stalled.close()
        self.assert_serving()


class InvalidRequests(HostCase):
    """Bad requests get the right exception (MBAP §7) or a closed connection
    (TCP §3.1.3 framing), and the server keeps serving."""

    def exchange(self, data):
        with connect(self.host.port) as s:
            s.sendall(data)
            s.settimeout(5)
            return recv_frame(s)

    def test_unknown_function_is_0x01(self):
        self.assertEqual(self.exchange(frame(0x0102, 7, b"\x2b\x0e\x01\x00")),
                         bytes([1, 2, 0, 0, 0, 3, 7, 0xAB, 0x01]))
        self.assertEqual(self.exchange(frame(3, 1, b"\x41")), bytes([0, 3, 0, 0, 0, 3, 1, 0xC1, 0x01]))
        self.assert_serving()

    def test_writes_disabled_are_0x01(self):
        self.assertEqual(self.exchange(frame(4, 1, b"\x06\x01\x00\x00\x01")),
                         bytes([0, 4, 0, 0, 0, 3, 1, 0x86, 0x01]))
        self.assert_serving()

    def test_address_out_of_range_is_0x02(self):
        end = DEVICE_BASE + 32 * STRIDE
        self.assertEqual(self.exchange(read_req(5, end - 1, 2)), bytes([0, 5, 0, 0, 0, 3, 1, 0x83, 0x02]))
        self.assertEqual(self.exchange(read_req(6, 65000, 1, fc=4)), bytes([0, 6, 0, 0, 0, 3, 1, 0x84, 0x02]))
        self.assertEqual(self.exchange(read_req(7, end - 1, 1))[7], 3)
        self.assert_serving()

    def test_oversized_count_is_0x03(self):
        self.assertEqual(self.exchange(read_req(8, 0, 126)), bytes([0, 8, 0, 0, 0, 3, 1, 0x83, 0x03]))
        self.assertEqual(self.exchange(read_req(9, 0, 0)), bytes([0, 9, 0, 0, 0, 3, 1, 0x83, 0x03]))
        self.assert_serving()

    def test_truncated_frame_closes(self):
        # PDU shorter than a read request needs (length field consistent).
        with connect(self.host.port) as s:
            s.sendall(frame(1, 1, b"\x03\x00\x00"))
            self.assertTrue(is_closed(s))
        # Half a request, then the client shuts its side: no answer, closed.
        with connect(self.host.port) as s:
            s.sendall(read_req(1, 0, 1)[:8])
            s.shutdown(socket.SHUT_WR)
            self.assertTrue(is_closed(s))
        self.assert_serving()

    def test_oversized_frame_closes(self):
        with connect(self.host.port) as s:  # length field 300 > 254
            s.sendall(frame(1, 1, b"\x03" + bytes(298)))
            self.assertTrue(is_closed(s))
        with connect(self.host.port) as s:  # maximal frame, but too long for function 3
            s.sendall(frame(1, 1, b"\x03" + bytes(252)))
            self.assertTrue(is_closed(s))
        self.assert_serving()

    def test_wrong_protocol_id_closes(self):
        with connect(self.host.port) as s:
            s.sendall(frame(1, 1, b"\x03\x00\x00\x00\x01", proto=1))
            self.assertTrue(is_closed(s))
        self.assert_serving()

    def test_garbage_streams_close_and_server_survives(self):
        rnd = __import__("random").Random(1234)
        for _ in range(50):
            with connect(self.host.port) as s:
                try:
                    s.sendall(bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 600))))
                    s.shutdown(socket.SHUT_WR)
                    s.settimeout(3)
                    while s.recv(4096):
                        pass
                except OSError:  # reset or already closed by the server
                    pass
        self.assert_serving()


class ConcurrentClients(HostCase):
    """32 clients (max_clients default) served at the same time; a 33rd takes
    the place of the connection idle longest."""
    CONFIG = "first_request_timeout_ms = 30000\n"  # the clients wait for each other before their first request

    def test_32_concurrent_clients(self):
        n = 32
        barrier = threading.Barrier(n)
        errors = []
        counts = [0] * n

        def worker(i):
            try:
                client = ModbusTcpClient("127.0.0.1", port=self.host.port, timeout=10)
                if not client.connect():
                    raise RuntimeError("connect failed")
                barrier.wait(timeout=30)
                for k in range(50):
                    d = (i + k) % self.DEVICES
                    rr = client.read_holding_registers(DEVICE_BASE + d * STRIDE, 14, slave=1)
                    if rr.isError():
                        raise RuntimeError(str(rr))
                    regs = rr.registers
                    if s32(u32(regs, 0)) != d * 1_000_000 + u32(regs, 12):
                        raise RuntimeError("inconsistent slot")
                    counts[i] += 1
                barrier.wait(timeout=30)  # everyone still connected here
                client.close()
            except Exception as e:  # noqa: BLE001
                errors.append("%d: %r" % (i, e))
                barrier.abort()

        threads = [threading.Thread(target=worker, args=(i,)) for i in range(n)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=60)
        self.assertEqual(errors, [])
        self.assertEqual(counts, [50] * n)
        self.assert_serving()

    # When full, the connection idle longest makes room.
    def test_client_beyond_max_clients_evicts_the_idlest(self):
        socks = [connect(self.host.port) for _ in range(32)]
        try:
            time.sleep(0.1)
            for s in socks[:2] + socks[3:]:
                s.sendall(read_req(1, 0, 1))
                self.assertIsNotNone(recv_frame(s))
            extra = connect(self.host.port)
            extra.sendall(read_req(2, 0, 1))
            self.assertEqual(regs_of(recv_frame(extra)), [MAP_VERSION], "the 33rd client is served")
            self.assertTrue(is_closed(socks[2]), "the one that never asked anything was closed")
            for s in socks[:2]:
                s.sendall(read_req(3, 0, 1))
                self.assertIsNotNone(recv_frame(s), "active clients keep their connection")
            extra.close()
        finally:
            for s in socks:
                s.close()
        time.sleep(0.2)
        self.assert_serving()


def assert_write_refused(case, tid):
    """A command write (preset, +28) answers exception 0x01, a read on the same
    connection is still answered, the refusal is logged with the client's
    address and port, and nothing reached the host (MBAP §7)."""
    base = DEVICE_BASE + 1 * STRIDE
    with connect(case.host.port) as s:
        s.settimeout(5)
        s.sendall(frame(tid, 1, struct.pack(">BHHB", 0x10, base + 28, 2, 4) + struct.pack(">HH", 0, 100)))
        r = recv_frame(s)
        case.assertEqual(r[7:9], bytes([0x90, 0x01]), r.hex())
        s.sendall(read_req(tid + 1, base, 2))
        r = recv_frame(s)
        case.assertEqual(r[7], 0x03, r.hex())
        here = "127.0.0.1:%d" % s.getsockname()[1]
    deadline = time.monotonic() + 3
    while time.monotonic() < deadline and not any(here in l and "refused, exception 0x01" in l for l in case.host.log):
        time.sleep(0.02)
    case.assertTrue(any(here in l and "refused, exception 0x01" in l for l in case.host.log), case.host.log[-5:])
    case.assertFalse([l for l in case.host.log if l.startswith("COMMAND")], "a refused write reached the host")


class WriteAllow(HostCase):
    """With writes_enabled, only clients inside write_allow
    write; the others still read, and their writes answer exception 0x01
    (MBAP §7, as when writes are disabled) and are logged as refused."""
    CONFIG = 'writes_enabled = true\nwrite_allow = ["10.0.0.0/8"]\n'

    def test_a_client_outside_write_allow_reads_but_may_not_write(self):
        assert_write_refused(self, 0x41)


class LoopbackNotListed(HostCase):
    """Any account of the gateway's host reaches 127.0.0.1,
    around the Unix sockets' write_group, so with writes_enabled and an empty
    write_allow (every network client) a loopback client still reads but its
    writes answer exception 0x01 (MBAP §7) and are logged as refused."""
    CONFIG = 'writes_enabled = true\n'

    def test_a_loopback_client_may_not_write_unless_listed(self):
        assert_write_refused(self, 0x44)


class WriteAllowLoopback(HostCase):
    """A client inside write_allow writes (a loopback one: listed explicitly)."""
    CONFIG = 'writes_enabled = true\nwrite_allow = ["127.0.0.1/32"]\n'

    def test_a_client_inside_write_allow_writes(self):
        base = DEVICE_BASE + 1 * STRIDE
        with connect(self.host.port) as s:
            s.settimeout(5)
            s.sendall(frame(0x43, 1, struct.pack(">BHHB", 0x10, base + 28, 2, 4) + struct.pack(">HH", 0, 100)))
            r = recv_frame(s)
        self.assertEqual(r[7], 0x10, r.hex())


class Hostile(unittest.TestCase):
    """Clients a plant's network produces."""

    # TCP §3.1.3: after an invalid MBAP header the stream cannot be framed any
    # more, but the complete requests before it were valid: answered first.
    def test_pipelined_requests_answered_before_a_framing_error_closes(self):
        host = Host("")
        try:
            with connect(host.port) as s:
                bad = frame(9, 1, b"\x03\x00\x00\x00\x01", proto=7)
                s.sendall(read_req(1, 0, 1) + read_req(2, 0, 1) + read_req(3, 0, 1) + bad)
                s.settimeout(5)
                tids = []
                for _ in range(3):
                    r = recv_frame(s)
                    self.assertIsNotNone(r, "answers %s, then closed early" % tids)
                    tids.append(struct.unpack(">H", r[:2])[0])
                self.assertEqual(tids, [1, 2, 3])
                self.assertTrue(is_closed(s))
        finally:
            host.stop()

    # Connections that never send anything free their slots within 2 s.
    def test_silent_connections_closed_by_the_first_request_deadline(self):
        host = Host("idle_timeout_s = 60\n")
        try:
            socks = [connect(host.port) for _ in range(32)]
            t0 = time.monotonic()
            self.assertTrue(all(is_closed(s, timeout=4) for s in socks))
            took = time.monotonic() - t0
            self.assertLess(took, 2.6, "closed %.2f s after connecting" % took)
            for s in socks:
                s.close()
            with connect(host.port) as s:
                s.sendall(read_req(1, 0, 1))
                self.assertEqual(regs_of(recv_frame(s)), [MAP_VERSION])
        finally:
            host.stop()

    # Out of descriptors (EMFILE) on accept: the level-triggered listen socket
    # must not spin the server at 100 % CPU; clients are served again after.
    def test_emfile_backs_off_instead_of_spinning(self):
        host = Host("first_request_timeout_ms = 0\nidle_timeout_s = 0\n", nofile=32)
        socks = []
        try:
            for _ in range(40):  # more than the descriptors left: the rest waits in the backlog
                socks.append(connect(host.port))
            time.sleep(0.3)

            def cpu_s():
                with open("/proc/%d/stat" % host.proc.pid) as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

            c0, t0 = cpu_s(), time.monotonic()
            time.sleep(1.5)
            share = (cpu_s() - c0) / (time.monotonic() - t0)
            self.assertLess(share, 0.2, "server used %.0f %% of a core while out of descriptors" % (share * 100))
            self.assertTrue(any("not accepting for" in line for line in host.log), "the pause is logged")
            for s in socks:
                s.close()
            socks = []
            time.sleep(1.2)
            with connect(host.port) as s:
                s.sendall(read_req(1, 0, 1))
                s.settimeout(5)
                self.assertEqual(regs_of(recv_frame(s)), [MAP_VERSION])
        finally:
            for s in socks:
                s.close()
            host.stop()


class Admission(unittest.TestCase):
    """allow list, idle timeout, unit id, unknown keys (docs/modbus.md Configuration)."""

    def test_allow_list_refuses_other_networks(self):
        host = Host('allow = ["10.0.0.0/8"]\n')
        try:
            with connect(host.port) as s:
                self.assertTrue(is_closed(s))
        finally:
            host.stop()
        host = Host('allow = ["127.0.0.0/8"]\n')
        try:
            with connect(host.port) as s:
                s.sendall(read_req(1, 0, 1))
                self.assertEqual(regs_of(recv_frame(s)), [MAP_VERSION])
        finally:
            host.stop()

    def test_idle_timeout_closes_silent_connections(self):
        host = Host("idle_timeout_s = 1\n")
        try:
            with connect(host.port) as s:
                t0 = time.monotonic()
                self.assertTrue(is_closed(s, timeout=5))
                self.assertGreater(time.monotonic() - t0, 0.9)
                self.assertLess(time.monotonic() - t0, 2.0)
        finally:
            host.stop()

    # TCP §4.4.1.2: a unit this gateway has no path to -> 0x0A.
    def test_unit_id_filter(self):
        host = Host("unit_id = 3\n")
        try:
            with connect(host.port) as s:
                s.sendall(read_req(1, 0, 1, unit=1))
                self.assertEqual(recv_frame(s), bytes([0, 1, 0, 0, 0, 3, 1, 0x83, 0x0A]))
                s.sendall(read_req(2, 0, 1, unit=3))
                self.assertEqual(regs_of(recv_frame(s)), [MAP_VERSION])
        finally:
            host.stop()

    def test_unknown_key_is_named(self):
        host = Host("bogus_key = 1\n")
        try:
            self.assertIsNone(host.port)
            self.assertIsNotNone(host.error)
            self.assertIn("'bogus_key'", host.error)
        finally:
            host.stop()


def main():
    global ARGS
    parser = argparse.ArgumentParser()
    parser.add_argument("--host", required=True)
    parser.add_argument("--plugin", required=True)
    parser.add_argument("suites", nargs="*")
    ARGS, rest = parser.parse_known_args()
    loader = unittest.TestLoader()
    module = sys.modules[__name__]
    if ARGS.suites:
        suite = unittest.TestSuite(loader.loadTestsFromName(n, module) for n in ARGS.suites)
    else:
        suite = loader.loadTestsFromModule(module)
    result = unittest.TextTestRunner(verbosity=2, stream=sys.stdout).run(suite)
    return 0 if result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main())
