"""Hot standby against a stranger on the bus ("an election
a stranger cannot steer"; CiA 302-2 flying master, docs/operations.md "Hot
standby", docs/security.md "Raw CAN").

Two real daemons (a: node 120, b: node 121, priority 0, 100 ms heartbeat)
and cobridge-sim with two encoders (nodes 10 and 20). Forged election frames
are sent from a raw CAN socket, as any local process can; every bound is
measured from the bus (a raw CAN socket's kernel receive stamps), never from
the daemons' status:
  * single forged frames, with b master and a (of higher rank) standby:
    a claim naming a configured device (071#000A), node 0 (071#0000), and a
    claim with priority 7 (071#0778): the bus has a master heartbeat (05h
    from 0x778 or 0x779) within 1 s of the forged frame and never goes 1 s
    without one;
  * a 0x76 storm (every 200 ms for 20 s; the minute of it, with the log's
    one line a minute, is the unit scenario tests/unit/bus/bus_manager_pair_test.cpp; bare, naming a, the standby of
    higher rank, as its preempt would, and naming b), with b master: one
    handover to a (the peer of higher rank, once), then nothing; at most
    2 role changes in any 60 s (a role change: a gateway's heartbeat turning
    from 05h to another state or back; both gateways counted together), a
    master heartbeat never missing for 1 s;
  * after a takeover (a killed, restarted as standby), a claim naming the
    other standby (071#0078: a, which announced itself): a master heartbeat
    within 1 s, a master after it; and with a master, a claim naming b, the
    standby of lower rank (071#0079): a stays master;
  * during each, mt-a (node 20) is power-cycled: its heartbeat says
    operational (05h) within 5 s of its boot-up;
  * never two master heartbeats within one period.
Runs inside UML:
  tests/vcan/run-in-vcan -- /usr/bin/python3 tests/vcan/daemon/test_hot_standby_forged.py --daemon ...
"""
import os
import signal
import socket
import struct
import threading
import time

import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10), ("mt-a", "MC1-2800", "MC1-2800", 2001, 20)]
NAMES = [d[0] for d in DEVICES]
NODE = {"a": 120, "b": 121}
HB = 0x700
CYCLED = 20  # mt-a's node-ID, power-cycled in every phase
MASTER_BOUND_S = 1.0
DEVICE_BOUND_S = 5.0
STORM_S = 20.0
STORM_PERIOD_S = 0.2
# The storm's frames in turn: CiA 302-2's bare 0x76, one naming a (its
# preempt's payload: priority 0, node 120) and one naming b.
STORM_FRAMES = [b"", bytes([0, 120]), bytes([0, 121])]


def config(ws, k):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 3600}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": nid, "heartbeat_ms": 100}
               for (n, m, _, s, nid) in DEVICES]
    return e2e.write_config(ws, [bus], devices, extra='[redundancy]\nmode = "hot-standby"\nnode_id = %d\n' % NODE[k])


class Forger:
    """A stranger's raw CAN socket."""

    def __init__(self, iface="vcan0"):
        self.sock = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
        self.sock.bind((iface,))

    def send(self, can_id, data=b""):
        self.sock.send(struct.pack("=IB3x8s", can_id, len(data), data.ljust(8, b"\0")))

    def close(self):
        self.sock.close()


def is_master_beat(cid, data):
    return cid in (HB + NODE["a"], HB + NODE["b"]) and data[:1] == b"\x05"


def sent_at(listener, can_id, data, after):
    """The bus's stamp of a frame we sent (the listener gets a copy), or None."""
    f = listener.wait_for(lambda c, d: c == can_id and d == data, 5.0, since=after - 0.01)
    return f[0] if f else None


def dump(frames, t0, t1):
    """The election's frames and each gateway's heartbeat state changes in [t0, t1], for a failure."""
    last = {}
    for t, cid, d in frames:
        if not t0 <= t <= t1:
            continue
        if 0x71 <= cid <= 0x76:
            print("  %+.3f %03X %s" % (t - t0, cid, d.hex()))
        elif cid in (HB + NODE["a"], HB + NODE["b"]) and last.get(cid) != d:
            print("  %+.3f %03X %s (heartbeat %s)" % (t - t0, cid, d.hex(), "a" if cid == HB + NODE["a"] else "b"))
            last[cid] = d


def master_figures(frames, t0, t1):
    """(seconds from t0 to the first master heartbeat, the longest time without one in [t0, t1])."""
    beats = [t for t, cid, d in frames if t0 < t <= t1 and is_master_beat(cid, d)]
    if not beats:
        return None, t1 - t0
    longest, last = beats[0] - t0, beats[0]
    for t in beats[1:]:
        longest, last = max(longest, t - last), t
    return beats[0] - t0, max(longest, t1 - last)


def role_change_times(frames, t0, t1):
    """Per gateway: when its heartbeat turned from 05h to another state or back within [t0, t1]."""
    out = {}
    for k, node in NODE.items():
        beats = [(t, d[:1] == b"\x05") for t, cid, d in frames if t0 <= t <= t1 and cid == HB + node and d]
        out[k] = [t for (_, x), (t, y) in zip(beats, beats[1:]) if x != y]
    return out


def most_within(times, window):
    """The most of `times` within any `window` seconds."""
    times = sorted(times)
    most, j = 0, 0
    for i, t in enumerate(times):
        while times[j] < t - window:
            j += 1
        most = max(most, i - j + 1)
    return most


def power_cycle(sim, listener, report, what):
    """Power-cycles mt-a; returns (boot-up stamp, seconds to its first 05h heartbeat) from the bus."""
    t = time.time()
    sim.command("power-off 2001")
    time.sleep(0.05)
    sim.command("power-on 2001")
    boot = listener.wait_for(lambda c, d: c == HB + CYCLED and d == b"\x00", 3.0, since=t)
    if boot is None:
        report.check(False, "%s: mt-a's boot-up on the bus" % what)
        return None, None
    op = listener.wait_for(lambda c, d: c == HB + CYCLED and d == b"\x05", DEVICE_BOUND_S + 3.0, since=boot[0])
    took = op[0] - boot[0] if op else None
    print("FIGURE %s: mt-a operational %s after its boot-up" % (what, "%.3f s" % took if took is not None else "never"))
    report.check_bound(took is not None and took <= DEVICE_BOUND_S,
                 "%s: mt-a, power-cycled, is operational (05h) within %.0f s of its boot-up" % (what, DEVICE_BOUND_S),
                 "%s" % ("%.3f s" % took if took is not None else "no 05h heartbeat"))
    return boot[0], took


def single_frame(report, listener, forger, sim, what, can_id, data):
    """One forged frame, mt-a power-cycled right after it; the master bound from the bus."""
    mark = time.time()
    forger.send(can_id, data)
    power_cycle(sim, listener, report, what)
    t0 = sent_at(listener, can_id, data, mark)
    if t0 is None:
        report.check(False, "%s: the forged frame seen on the bus" % what)
        return
    time.sleep(max(0.0, t0 + 3.0 - time.time()))
    frames = listener.snapshot(t0 - 1.0)
    first, longest = master_figures(frames, t0, t0 + 3.0)
    print("FIGURE %s: first master heartbeat %s after the forged frame, longest without one %.3f s" % (
        what, "%.3f s" % first if first is not None else "never", longest))
    if not report.check_bound(first is not None and first <= MASTER_BOUND_S and longest <= MASTER_BOUND_S,
                        "%s: a master heartbeat (05h) within 1 s of the forged frame, and never 1 s without one" % what,
                        "first %s, longest gap %.3f s" % (first, longest)):
        dump(frames, t0 - 0.5, t0 + 3.0)


def ignored_lines(daemons, offsets):
    """The election's one-a-minute lines counting the frames it ignored, from each gateway's log after `offsets`."""
    out = {}
    for k, d in daemons.items():
        with open(d.log_path, errors="replace") as f:
            f.seek(offsets[k])
            out[k] = [l.strip() for l in f if "the election ignored" in l]
    return out


def storm(report, listener, forger, sim, daemons):
    """0x76 every 200 ms for STORM_S (on a thread of its own), mt-a power-cycled 0.3 s in (while the
    handover the second frame asks for runs) and 10 s in."""
    offsets = {k: os.path.getsize(d.log_path) for k, d in daemons.items()}
    t0 = time.time()
    count = int(STORM_S / STORM_PERIOD_S)

    def send_all():
        for i in range(count):
            forger.send(0x76, STORM_FRAMES[i % len(STORM_FRAMES)])
            time.sleep(max(0.0, t0 + STORM_PERIOD_S * (i + 1) - time.time()))

    sender = threading.Thread(target=send_all)
    sender.start()
    for at in (0.3, 10.0):
        time.sleep(max(0.0, t0 + at - time.time()))
        power_cycle(sim, listener, report, "0x76 storm, %.1f s in" % at)
    sender.join()
    t1 = time.time()
    time.sleep(0.5)
    frames = listener.snapshot(t0 - 1.0)
    changes = role_change_times(frames, t0, t1 + 0.5)
    every = [t for ts in changes.values() for t in ts]
    worst = most_within(every, 60.0)
    first, longest = master_figures(frames, t0, t1)
    forged = len([1 for t, cid, _ in frames if t0 - 0.1 <= t <= t1 + 0.1 and cid == 0x76])
    print("FIGURE 0x76 storm: %d frames in %.1f s; role changes %s at %s s; most in any 60 s: %d; "
          "longest without a master heartbeat %.3f s" % (
              forged, t1 - t0, {k: len(v) for k, v in changes.items()},
              ["%.2f" % (t - t0) for t in sorted(every)], worst, longest))
    report.check(forged >= count - 5, "0x76 storm: every 200 ms for %.0f s on the bus" % STORM_S, "%d frames" % forged)
    report.check(worst <= 2, "0x76 storm: at most 2 role changes (both gateways) in any 60 s, counted from the bus",
                 "%d" % worst)
    if not report.check_bound(longest <= MASTER_BOUND_S, "0x76 storm: never 1 s without a master heartbeat",
                              "%.3f s" % longest) or worst > 2:
        dump([f for f in frames if f[1] != 0x76], t0, t1)
    # A minute's window may not end within the 20 s: at most one line each, never one per frame (the
    # whole minute, one line each with counts, is the unit scenario BusManagerPair.Cia302_2_StormOf0x76...).
    lines = ignored_lines(daemons, offsets)
    for k, ls in lines.items():
        print("FIGURE 0x76 storm: %s's log: %d line(s) on ignored election frames%s" % (
            k, len(ls), (": " + ls[-1][ls[-1].find("in the last"):]) if ls else ""))
    report.check(all(len(ls) <= 1 for ls in lines.values()),
                 "0x76 storm: each gateway logs the ignored frames at most once a minute, never per frame",
                 str({k: len(v) for k, v in lines.items()}))


def wait_roles(listener, master, timeout=10.0):
    """Until `master`'s heartbeat says 05h and the other's 7Fh, from the bus."""
    other = "a" if master == "b" else "b"
    end = time.time() + timeout
    while time.time() < end:
        recent = listener.snapshot(time.time() - 0.3)
        m = [d for t, cid, d in recent if cid == HB + NODE[master]]
        o = [d for t, cid, d in recent if cid == HB + NODE[other]]
        if m and o and all(d == b"\x05" for d in m) and all(d == b"\x7f" for d in o):
            return True
        time.sleep(0.05)
    return False


def wait_steady(listener, master, window=1.0, timeout=10.0):
    """Until both gateways' heartbeats (100 ms) came every period or nearly (no gap over 130 ms) in
    the last `window` s, in their roles: a claim is weighed against its gateway's last heartbeat
    (a peer is live for 1.5 periods, CiA 302-2 heartbeat), and a gateway just started on a loaded
    guest may still lag (CI 2026-11-30: a's heartbeat late 0.1 s after its start, b took the claim
    naming a for a stranger's)."""
    end = time.time() + timeout
    while time.time() < end:
        now = time.time()
        recent = listener.snapshot(now - window)
        steady = True
        for k in ("a", "b"):
            beats = [(t, d) for t, cid, d in recent if cid == HB + NODE[k]]
            want = b"\x05" if k == master else b"\x7f"
            times = [t for t, _ in beats]  # kernel stamps: the listener's own lag does not count
            steady = steady and len(beats) >= 8 and all(d == want for _, d in beats) and \
                max(b - a for a, b in zip(times, times[1:])) <= 0.13
        if steady:
            return True
        time.sleep(0.05)
    return False


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_hot_standby_forged")
    ws = {k: e2e.Workspace("forged-" + k, args.keep, base="/run") for k in NODE}
    cfg = {k: config(ws[k], k) for k in NODE}
    listener = e2e.CanListener("vcan0")
    forger = Forger()
    sim = e2e.Simulator(args.sim, ws["a"], {"vcan0": ["%s:serial=%d,node=%d" % (sm, s, n)
                                                     for (_, _, sm, s, n) in DEVICES]})
    daemons = {}
    starts = {k: 0 for k in NODE}

    def start(k):
        starts[k] += 1
        daemons[k] = e2e.Daemon(args.daemon, cfg[k], ws[k], log_name="daemon-%d.log" % starts[k])
        return daemons[k]

    def b_master_a_standby(what):
        """b master and a (of higher rank) standby, as after a takeover: a killed and started again."""
        if wait_roles(listener, "b", 1.0):
            return True
        os.kill(daemons["a"].pid, signal.SIGKILL)
        daemons["a"].proc.wait(5)
        daemons["a"].log.close()
        ok = wait_roles_single(listener, "b")
        start("a").wait_socket()
        ok = ok and wait_roles(listener, "b")
        _, up = daemons["b"].wait_until(e2e.all_operational(NAMES), 20, interval=0.05)
        ok = ok and wait_steady(listener, "b")
        return report.check(ok and up is not None, "%s: b master, a standby behind it (a killed and started again), "
                            "every device operational, both heartbeats steady for 1 s" % what)

    try:
        b = start("b")
        report.check(b.wait_socket(), "gateway b up")
        _, ok = b.wait_until(e2e.all_operational(NAMES), 30, interval=0.05)
        report.check(ok is not None, "b alone: every device operational")
        a = start("a")
        report.check(a.wait_socket(), "gateway a up")
        report.check(wait_roles(listener, "b"), "on the bus: b master (05h), a standby (7Fh)")

        # Single forged frames: the master stays.
        single_frame(report, listener, forger, sim, "claim naming device rot-a (071#000A)", 0x71, bytes([0, 10]))
        single_frame(report, listener, forger, sim, "claim naming node 0 (071#0000)", 0x71, bytes([0, 0]))
        single_frame(report, listener, forger, sim, "claim with priority 7 (071#0778)", 0x71, bytes([7, 120]))

        # A 0x76 storm beside a standby of higher rank: one handover at most, then nothing.
        if b_master_a_standby("before the 0x76 storm"):
            storm(report, listener, forger, sim, daemons)

        # A claim naming the standby of higher rank, a: b yields to it, a never sends a master heartbeat
        # for it, the claim is forgotten and the gateways negotiate.
        if b_master_a_standby("before the claim naming the other standby"):
            single_frame(report, listener, forger, sim, "claim naming the other standby (071#0078)", 0x71,
                         bytes([0, 120]))
            report.check(wait_roles(listener, "a", 3.0), "after it: a master, b standby (the rank decides)")
            # The standby of lower rank named: a answers with its claim and stays master.
            single_frame(report, listener, forger, sim, "claim naming the standby of lower rank (071#0079)", 0x71,
                         bytes([0, 121]))
            report.check(wait_roles(listener, "a", 1.0), "after it: a still master, b standby")

        bad = e2e.master_heartbeat_overlaps(listener.snapshot(0), NODE)
        report.check(not bad, "never two masters: no two master heartbeats within one period", "%d" % len(bad))
        if report.failed:
            for k, d in daemons.items():
                print("---- %s's log (last 30 lines)" % k)
                print(d.tail(30))
    finally:
        e2e.shut_down_pair(list(daemons.values()), [sim, listener, forger], ws.values())
    return report.finish()


def wait_roles_single(listener, master, timeout=5.0):
    """Until `master`'s heartbeat says 05h (the other is gone)."""
    end = time.time() + timeout
    while time.time() < end:
        recent = listener.snapshot(time.time() - 0.3)
        m = [d for t, cid, d in recent if cid == HB + NODE[master]]
        if m and all(d == b"\x05" for d in m):
            return True
        time.sleep(0.05)
    return False


if __name__ == "__main__":
    raise SystemExit(main())
