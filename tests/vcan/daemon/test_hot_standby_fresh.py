"""Hot standby with factory-fresh devices (docs/operations.md "Hot standby",
"The standby's memory"): the master commissions them with LSS Fastscan (CiA
305) and gives them node-IDs from the pool; the standby, which sends
nothing, learns each device's node-ID from the master's reads of the
identity object 0x1018 (CiA 301 7.5.2.36) on the bus, decodes its values,
and remembers it in its own state file. Then the master is killed.

Then again with the master killed in the middle of its commissioning: the
standby, master now, finishes it (every device operational at its own
node-ID from the pool).

Checks:
  * the standby's status names the node-ID the master gave each device,
    and its state file holds them, before any takeover;
  * after the kill the new master commissions nothing (no LSS configure
    node-ID, 0x11, and no switch-selective, 0x40..0x43, from it), and every
    device is operational at the same node-ID with 0 SDO download requests
    to them on the bus;
  * the CLI on the pair's interface reaches the survivor through the bus
    beacon it took over from the dead master (via the daemon, not the bus).
Runs inside UML:
  tests/vcan/run-in-vcan -- /usr/bin/python3 tests/vcan/daemon/test_hot_standby_fresh.py --daemon ...
"""
import os
import signal
import socket
import struct
import time

import bus_trace
import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001), ("mt-a", "MC1-2800", "MC1-2800", 2001),
           ("rot-b", "RFC-4800", "RFC-4800", 1002)]
NAMES = [d[0] for d in DEVICES]
LSS_MASTER = 0x7E5
COMMISSIONING_CS = {0x11, 0x40, 0x41, 0x42, 0x43}  # configure node-ID, switch state selective


def config(ws, node):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery": True, "discovery_period_s": 2,
           "node_pool": "40-60", "commissioning": "automatic"}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 20}}
               for (n, m, _, s) in DEVICES]
    return e2e.write_config(ws, [bus], devices, extra='[redundancy]\nmode = "hot-standby"\nnode_id = %d\n' % node)


def nodes(daemon):
    return {d["name"]: d["node_id"] for d in daemon.status()["buses"][0]["devices"]}


def states(daemon):
    return {d["name"]: d["state"] for d in daemon.status()["buses"][0]["devices"]}


def unasked_identity(report, b, ws, given):
    """A stranger's expedited upload response (CiA 301 7.2.4.3.3: 43 18 10 04 + serial) naming
    rot-a's serial at node 77, with no request before it: the standby learns nothing from it."""
    forged = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    try:
        forged.bind(("vcan0",))
        forged.send(struct.pack("=IB3x8s", 0x580 + 77, 8, bytes([0x43, 0x18, 0x10, 0x04]) + struct.pack("<I", 1001)))
    finally:
        forged.close()
    time.sleep(1.0)  # a standby that believed it would have moved rot-a by now (the next loop turn)
    path = os.path.join(ws["b"].state, "assignments.state")
    state = open(path).read() if os.path.exists(path) else ""
    report.check(nodes(b) == given and "node=77" not in state,
                 "an upload response nobody asked for (rot-a's serial at node 77) teaches the standby nothing",
                 "%s; state file has node=77: %s" % (nodes(b), "node=77" in state))


class Scene:
    """Two gateways, then fresh devices on vcan0: a started first (it will be master and
    commission them), b right after (standby), the devices once b is up, so that b hears every
    identity read of a's (on a slow bed, a guest under QEMU, a had read one before b listened);
    a finds them at its next discovery (every 2 s)."""

    def __init__(self, args, report, name):
        self.ws = {k: e2e.Workspace(name + "-" + k, args.keep, base="/run") for k in "ab"}
        cfg = {"a": config(self.ws["a"], 120), "b": config(self.ws["b"], 121)}
        self.listener = e2e.CanListener("vcan0")
        self.sim = None
        self.daemons = []
        for k in "ab":
            d = e2e.Daemon(args.daemon, cfg[k], self.ws[k])
            self.daemons.append(d)
            report.check(d.wait_socket(), "%s: gateway %s up" % (name, k))
        self.a, self.b = self.daemons
        self.sim = e2e.Simulator(args.sim, self.ws["a"],
                                 {"vcan0": ["%s:serial=%d" % (sm, s) for (_, _, sm, s) in DEVICES]})
        self.t_devices = time.time()

    def close(self):
        e2e.shut_down_pair(self.daemons, [p for p in (self.sim, self.listener) if p], self.ws.values())


def during_commissioning(args, report):
    """The master killed in the middle of its LSS commissioning: the standby, master now, finishes it."""
    scene = Scene(args, report, "fresh-mid")
    listener, a, b = scene.listener, scene.a, scene.b
    try:
        # Kill a once its LSS commissioning has begun (the first Fastscan frames on the bus
        # after the devices were powered).
        end = time.time() + 10
        while time.time() < end and not [1 for t, cid, d in listener.snapshot(scene.t_devices) if cid == LSS_MASTER]:
            time.sleep(0.01)
        time.sleep(0.05)
        lss_before = len([1 for t, cid, d in listener.snapshot(scene.t_devices) if cid == LSS_MASTER])
        os.kill(a.pid, signal.SIGKILL)
        a.proc.wait(5)
        report.check(lss_before > 0, "a killed during its LSS commissioning (%d LSS frames sent)" % lss_before)
        _, back = b.wait_until(e2e.all_operational(NAMES), 60, interval=0.05)
        got = nodes(b)
        report.check(back is not None and len(set(got.values())) == len(NAMES) and
                     all(40 <= n <= 60 for n in got.values()),
                     "b, master now, finished the commissioning: every device operational at its own pool node-ID",
                     str(got))
    finally:
        scene.close()


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_hot_standby_fresh")
    scene = Scene(args, report, "fresh")
    listener, a, b, ws = scene.listener, scene.a, scene.b, scene.ws
    try:
        _, took = a.wait_until(e2e.all_operational(NAMES), 60, interval=0.05)
        report.check(took is not None, "a commissioned every fresh device (LSS Fastscan)", str(nodes(a)))
        given = nodes(a)
        end = time.time() + 5
        while time.time() < end and nodes(b) != given:
            time.sleep(0.05)
        report.check(nodes(b) == given and all(given.values()),
                     "the standby knows the node-ID the master gave each device, from the bus", str(nodes(b)))
        path = os.path.join(ws["b"].state, "assignments.state")
        state = open(path).read() if os.path.exists(path) else ""
        remembered = all(("node=%d " % n) in state + " " or ("node=%d\n" % n) in state for n in given.values())
        report.check(remembered, "the standby's state file holds them", state[:300])
        report.check(all(v == "operational" for v in states(b).values()),
                     "the standby's status shows the devices operational, as their heartbeats say", str(states(b)))
        unasked_identity(report, b, ws, given)

        os.kill(a.pid, signal.SIGKILL)
        a.proc.wait(5)
        t_kill = time.time()
        _, back = b.wait_until(e2e.all_operational(NAMES), 30, interval=0.05)
        report.check(back is not None and nodes(b) == given,
                     "after the kill: every device operational under b at the same node-ID", str(nodes(b)))
        frames = listener.snapshot(t_kill)
        lss = [d.hex() for t, cid, d in frames if cid == LSS_MASTER and d[0] in COMMISSIONING_CS]
        report.check(not lss, "the new master commissions nothing (no LSS configure/switch-selective)", str(lss[:5]))
        listener.wait_past(time.time())
        writes = bus_trace.sdo_downloads(listener.snapshot(t_kill), set(given.values()))
        report.check(back is not None and not writes,
                     "and writes no configuration (0 SDO download requests to the devices on the bus)",
                     "%d: %s" % (len(writes), bus_trace.describe_downloads(writes)))
        # The CLI finds the bus's daemon by its beacon: the survivor's, once the dead one's is gone.
        via, out = e2e.cli_via_daemon(args.cli, "vcan0", min(given.values()))
        report.check(via == "daemon", "after the kill: the CLI reaches the survivor (via the daemon, not the bus)",
                     out.strip()[:200])
    finally:
        scene.close()
    during_commissioning(args, report)
    return report.finish()


if __name__ == "__main__":
    raise SystemExit(main())
