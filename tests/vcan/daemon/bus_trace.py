"""What the end-to-end tests read from the bus itself, never from the daemon's
own word: traces recorded outside the daemon, with kernel
receive stamps, and the readings the tests take from them.

 * Candump: can-utils' candump on one interface (in a network namespace when
   asked), to a file. With -x it tells each frame's direction: TX for a frame
   a socket on this side of the interface sent, RX for one that came in (over
   vxcan from its peer, or forwarded by can-gw). A gateway on an interface of
   its own is therefore told apart from every other sender by direction and
   COB-ID, not by its counters.
 * sdo_downloads(): the SDO download requests to given nodes in a trace.
 * takeover(): from the dead master's last frame to the survivor's first
   heartbeat saying master (05h).
 * compare_capture(): a flight-recorder capture frame by frame against an
   independent candump -L of the same seconds.
 * wait_until(): the wait on a condition that replaces a sleep.
Each frame is (time, can_id, data); Candump's are (time, direction, can_id,
data). Error frames keep CAN_ERR_FLAG (0x20000000) in their id.
"""
import bisect
import subprocess
import threading
import time

HEARTBEAT = 0x700  # CiA 301 §7.2.8.3.2: heartbeat COB-ID 0x700 + node-ID, state in byte 0
STATE_OPERATIONAL = 0x05  # a gateway of a pair says master with 05h (canopen/master_election.hpp)
STATE_PRE_OPERATIONAL = 0x7F  # ... and standby with 7Fh
SDO_REQUEST = 0x600  # CiA 301 §7.2.4.3: client -> server SDO COB-ID 0x600 + node-ID


def wait_until(pred, timeout, what, interval=0.02):
    """Polls pred() until it returns something true; returns it. On the deadline raises
    TimeoutError naming what was awaited (a test's check fails with it, no sleep guesses)."""
    end = time.time() + timeout
    while True:
        got = pred()
        if got:
            return got
        if time.time() >= end:
            raise TimeoutError("waited %.1f s for %s" % (timeout, what))
        time.sleep(interval)


def parse_candump_line(line):
    """One candump line, '-t a' long form with or without -x, or '-L' log form:
      (1700000000.123456)  vcan0  TX - -  701   [1]  05
      (1700000000.123456)  vcan0  701   [1]  05
      (1700000000.123456) vcan0 701#05
    -> (time, direction or None, can_id, data), or None for anything else."""
    p = line.split()
    if len(p) < 3 or not p[0].startswith("("):
        return None
    t = float(p[0].strip("()"))
    if "#" in p[2]:  # log form
        ident, _, data = p[2].partition("#")
        data = "" if data.startswith("R") else data
        return t, None, int(ident, 16), bytes.fromhex(data)
    rest = p[2:]
    direction = None
    if rest[0] in ("TX", "RX"):
        direction, rest = rest[0], rest[3:]  # TX/RX, then the BRS and ESI marks of CAN FD
    if len(rest) < 2 or not rest[1].startswith("["):
        return None
    n = int(rest[1].strip("[]"))
    data = bytes(int(b, 16) for b in rest[2:2 + n]) if "remote" not in line else b""
    return t, direction, int(rest[0], 16), data


class Candump:
    """candump on `iface` (inside network namespace `netns` when given) writing to `path`:
    with direction (-x, '-t a'), or in candump's log form (log=True, '-L', as the flight
    recorder writes). errors: error frames too (filter '#FFFFFFFF'). candump flushes each
    frame, so a frame in the file is a frame seen; wait_past() waits for the file to reach a
    time before a window is read."""

    def __init__(self, iface, path, netns=None, log=False, errors=False):
        self.path = path
        self.out = open(path, "w")
        spec = iface + (",0:0,#FFFFFFFF" if errors else "")
        # -d: a frame the kernel dropped for candump (socket buffer full) is reported on a line of
        # its own (dropped()); -r: 4 MiB of socket buffer (root: beyond rmem_max), as CanListener.
        opts = ["-d", "-r", str(4 << 20)]
        cmd = ["candump"] + opts + (["-L", spec] if log else ["-x", "-t", "a", spec])
        if netns:
            cmd = ["ip", "netns", "exec", netns] + cmd
        self.proc = subprocess.Popen(cmd, stdout=self.out, stderr=subprocess.DEVNULL)
        # The lines parsed so far and where the next starts: each call parses only what candump
        # wrote since. (Parsing the whole file on every call made a long test quadratic: on the
        # QEMU bed the hot-standby test spent its last minutes in it and met the guest's limit.)
        self._parsed = []
        self._times = []
        self._offset = 0
        self._lock = threading.Lock()

    def _read_new(self):
        with open(self.path, "rb") as f:
            f.seek(self._offset)
            chunk = f.read()
        end = chunk.rfind(b"\n") + 1  # whole lines only: candump may be writing the next
        self._offset += end
        for line in chunk[:end].decode(errors="replace").splitlines():
            fr = parse_candump_line(line)
            if fr:
                self._parsed.append(fr)
                self._times.append(fr[0])

    def frames(self, t0=0.0, t1=float("inf")):
        """Every (time, direction, can_id, data) between t0 and t1, in the order candump saw them."""
        with self._lock:
            self.out.flush()
            self._read_new()
            # Receive order is stamp order but for frames microseconds apart (two CPUs): a
            # second's margin on both sides finds every frame of [t0, t1].
            i = bisect.bisect_left(self._times, t0 - 1.0) if t0 > 0 else 0
            out = []
            for fr in self._parsed[i:]:
                if fr[0] > t1 + 1.0:
                    break
                if t0 <= fr[0] <= t1:
                    out.append(fr)
            return out

    def dropped(self):
        """candump's reports of frames the kernel dropped before it read them (-d)."""
        self.out.flush()
        with open(self.path) as f:
            return [l.strip() for l in f if "DROPCOUNT" in l]

    def sent(self, t0=0.0, t1=float("inf")):
        """(time, can_id, data) of every frame sent from this side of the interface (TX)."""
        return [(t, i, d) for t, direction, i, d in self.frames(t0, t1) if direction == "TX"]

    def wait_past(self, t, timeout=5.0):
        """Waits until candump has written a frame stamped after `t` (the bus's periodic
        heartbeats come every 100 ms), so that a window ending at `t` is whole; False when none
        came within `timeout` (a bus quiet since: the window is whole too)."""
        try:
            return bool(wait_until(lambda: self.frames(t), timeout, "candump past %.3f" % t, interval=0.05))
        except TimeoutError:
            return False

    def close(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(5)
        self.out.close()


def sdo_downloads(frames, nodes):
    """The SDO download requests among `frames` ((time, can_id, data)) to the servers in
    `nodes`: client -> server COB-ID 0x600 + node-ID with the client command specifier
    (byte 0, bits 7..5) 1, initiate download (CiA 301 §7.2.4.3.3), or 6 with cs (bit 0) 0,
    initiate block download (§7.2.4.3.9). Every write starts with one of these, whether
    the daemon logs it or not."""
    out = []
    for f in frames:
        cid, data = f[-2], f[-1]
        if cid - SDO_REQUEST in nodes and data:
            ccs = data[0] >> 5
            if ccs == 1 or (ccs == 6 and not data[0] & 0x01):
                out.append(f)
    return out


def download_target(frame):
    """(index, subindex, value) of an initiate download request (CiA 301 §7.2.4.3.3: index
    little-endian in bytes 1..2, subindex in byte 3; expedited (e, bit 1) with its size
    indicated (s, bit 0) by n (bits 3..2), the bytes 4..7 that hold no data; value None when
    not expedited)."""
    data = frame[-1]
    index, sub = data[1] | data[2] << 8, data[3]
    value = None
    if data[0] >> 5 == 1 and data[0] & 0x02:
        size = 4 - (data[0] >> 2 & 0x03) if data[0] & 0x01 else 4
        value = int.from_bytes(data[4:4 + size], "little")
    return index, sub, value


def describe_downloads(downloads, n=4):
    """'0x60A 2B17100064000000 at 12.345, ...' for a check's detail."""
    return ", ".join("0x%03X %s at %.3f" % (f[-2], f[-1].hex().upper(), f[0]) for f in downloads[:n])


def master_heartbeat(node):
    """pred(can_id, data): a heartbeat of gateway `node` saying master (05h)."""
    return lambda cid, data: cid == HEARTBEAT + node and data[:1] == bytes([STATE_OPERATIONAL])


def takeover(dead_sent, bus, survivor_node):
    """Seconds from the dead master's last frame (the last of `dead_sent`, its own sends as
    candump -x marks them) to the first heartbeat of `survivor_node` saying master (05h) on
    the bus (`bus`: (time, can_id, data)) after it. None when either is missing."""
    if not dead_sent:
        return None
    last = max(t for t, _, _ in dead_sent)
    first = next((t for t, cid, d in bus if t > last and master_heartbeat(survivor_node)(cid, d)), None)
    return None if first is None else first - last


def not_heartbeat(sent, node, state):
    """The frames of `sent` that are not `node`'s heartbeat with `state` (for a check's detail)."""
    return [(t, cid, d) for t, cid, d in sent if not (cid == HEARTBEAT + node and d == bytes([state]))]


def read_log(path):
    """A candump -l / -L file as (time, can_id, data)."""
    out = []
    with open(path) as f:
        for line in f:
            fr = parse_candump_line(line)
            if fr:
                out.append((fr[0], fr[2], fr[3]))
    return out


def compare_capture(capture, independent, tolerance, window=None, tail_allowance=0.0, gaps=None):
    """A capture (frames of its file) against the independent trace: the trace's frames
    stamped from the capture's first frame to its last, or over `window` (start, end): the
    seconds the capture is for, so that a capture missing frames at either edge fails too,
    must be the capture's frames, same ids and data in the same order, each stamp within
    `tolerance` seconds; the capture is in stamp order (the candump need not be: it is sorted).
    tail_allowance: the capture may end short of the window by frames
    of its last that many seconds (counted in the detail). gaps: {line: frames} from the
    capture's sidecar, the frames the kernel dropped at the daemon's socket before that line
    (1-based): exactly that many of the trace's frames are missing there (before line 1: at
    most that many, the rest of the drop may lie before the window), and nowhere else.
    Returns (ok, detail)."""
    if not capture:
        return False, "the capture holds no frame"
    back = next((k for k in range(1, len(capture)) if capture[k][0] < capture[k - 1][0]), None)
    if back is not None:
        return False, "the capture is not in stamp order: line %d at %.6f after %.6f" % (
            back + 1, capture[back][0], capture[back - 1][0])
    # Both in bus time order: two CPUs may hand two sockets the same frames in different orders;
    # frames of one stamp (whole microseconds) in the order of their content.
    capture = sorted(capture, key=lambda f: (f[0], f[1], f[2]))
    independent = sorted(independent, key=lambda f: (f[0], f[1], f[2]))
    gaps = gaps or {}
    t0, t1 = capture[0][0], capture[-1][0]
    short = 0
    if window is not None:
        # Stamps are whole microseconds: a frame in the window's first or last one may fall
        # either side of its edge.
        t0 = min(t0, window[0] + 1e-6)
        short = len([f for f in independent if max(t1, window[1] - 1e-6 - tail_allowance) < f[0] <= window[1] - 1e-6])
        t1 = max(t1, window[1] - 1e-6 - tail_allowance)
    # The trace's frames that match the capture's first and last ones bound the same seconds.
    window = [f for f in independent if t0 - tolerance <= f[0] <= t1 + tolerance]
    c0 = capture[0][0]
    start = next((i for i, f in enumerate(window) if f[1:] == capture[0][1:] and abs(f[0] - c0) <= tolerance), None)
    if start is None:
        return False, "the capture's first frame %03X#%s at %.6f is not in the candump" % (
            capture[0][1], capture[0][2].hex(), c0)
    before = [f for f in window[:start] if f[0] >= t0]
    if len(before) > gaps.get(1, 0):
        return False, "the candump holds %d frames more before the capture's first (from %.6f), first %03X#%s at %.6f" % (
            len(before), t0, before[0][1], before[0][2].hex(), before[0][0])
    j, worst, declared = start, 0.0, len(before)
    for k, c in enumerate(capture):
        if k > 0 and k + 1 in gaps:  # the frames the kernel dropped before this line
            j += gaps[k + 1]
            declared += gaps[k + 1]
        f = window[j] if j < len(window) else None
        if f is None:
            return False, "the candump holds %d of the capture's %d frames" % (k, len(capture))
        if c[1:] != f[1:]:
            return False, "frame %d of %d differs: capture %03X#%s at %.6f, candump %03X#%s at %.6f%s" % (
                k + 1, len(capture), c[1], c[2].hex(), c[0], f[1], f[2].hex(), f[0],
                " (after a declared gap of %d)" % gaps[k + 1] if k + 1 in gaps else "")
        worst = max(worst, abs(c[0] - f[0]))
        j += 1
    after = [f for f in window[j:] if f[0] <= t1]
    if after:
        return False, "the candump holds %d frames more in the capture's seconds, first %03X#%s at %.6f" % (
            len(after), after[0][1], after[0][2].hex(), after[0][0])
    if worst > tolerance:
        return False, "a stamp differs by %.6f s (tolerance %.6f s)" % (worst, tolerance)
    return True, "%d frames, same order, stamps within %.6f s (worst %.6f s)%s%s" % (
        len(capture), tolerance, worst, "; %d frames of the window's last %.0f ms not in it (allowed)" % (
            short, tail_allowance * 1e3) if short else "",
        "; %d frames the kernel dropped at the daemon's socket, each where the sidecar says" % declared
        if declared else "")

