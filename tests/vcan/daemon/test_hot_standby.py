"""Hot standby: two cobridged on one bus ([redundancy], docs/operations.md
"Hot standby"), one master decided on the bus (CiA 302-2 flying master:
0x73 active master request, 0x72 negotiation, 0x71 claims).

Two daemons with their own state directories on the same vcan, the simulator
with three devices. Checks, from the daemons' status and from every frame on
the bus (kernel receive stamps):
  * the first started is master, the second standby naming it; their
    heartbeats say so (05h master, 7Fh standby);
  * the master is killed (SIGKILL: its frames stop) KILLS times, at random
    moments; each time the survivor is master within 1 s of the dead one's
    last frame (printed per kill, p100 asserted), every device operational
    again with 0 configuration writes, and the dead one, started again on
    its state directory, joins as standby without an election of its own;
  * at no time do both gateways' heartbeats say master within one period,
    and the standby's frames are only its heartbeat and election frames;
  * a device rebooted right after a takeover is configured by the new master;
  * with the outputs (--plugins, --probe): a DDS subscriber with EXCLUSIVE
    readers (cobridge_dds_probe, as a cell controller of a pair subscribes)
    sees one stream per device that fails over by itself at each takeover
    (the gap printed, at most 1 s) with no sequence gap in any gateway's
    stream, and each gateway's GatewayStatus says its role; a Modbus client
    polling both gateways all the time never reads a data age above 1 s
    from the one that stays up.
Runs inside UML:
  tests/vcan/run-in-vcan -- /usr/bin/python3 tests/vcan/daemon/test_hot_standby.py --daemon ... --kills 3
"""
import json
import os
import random
import signal
import subprocess
import threading
import time

import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10),
           ("mt-a", "MC1-2800", "MC1-2800", 2001, 20),
           ("ifm-a", "RM9", "RM9000", 3001, 30)]
NAMES = [d[0] for d in DEVICES]
NODE = {"a": 120, "b": 121}
MODBUS_PORT = {"a": 1502, "b": 1503}
HB = 0x700
ELECTION_IDS = range(0x71, 0x77)


def outputs(k):
    return ('[outputs.dds]\nsample_reliability = "reliable"\nsample_depth = 1000\n'
            '[outputs.modbus]\nbind = "127.0.0.1"\nport = %d\noffline_exception = false\n'
            'writes_enabled = true\nwrite_allow = ["127.0.0.1/32"]\n' % MODBUS_PORT[k])


def config(ws, node, k, with_outputs):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 3600}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": nid, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 20}}
               for (n, m, _, s, nid) in DEVICES]
    extra = '[redundancy]\nmode = "hot-standby"\nnode_id = %d\n' % node
    if with_outputs:
        extra += outputs(k)
    return e2e.write_config(ws, [bus], devices, extra=extra)


def redundancy(daemon):
    try:
        st = daemon.status()
    except (OSError, ValueError):
        return None
    return st["buses"][0].get("redundancy")


def role_is(daemon, role, master=None, timeout=10):
    end = time.time() + timeout
    while time.time() < end:
        r = redundancy(daemon)
        if r and r["role"] == role and (master is None or r["master_node"] == master):
            return r
        time.sleep(0.01)
    return None


def writes_since(daemon, offset):
    """Configuration writes per device logged since `offset` ("operational at node ... N writes")."""
    with open(daemon.log_path) as f:
        f.seek(offset)
        text = f.read()
    writes = {}
    for line in text.split("\n"):
        if "operational at node" in line and " writes" in line:
            name = line.split(" device ")[1].split()[0]
            writes[name] = writes.get(name, 0) + int(line.split(" writes")[0].split()[-1])
    return writes


class Pair:
    def __init__(self, args, report):
        self.args, self.report = args, report
        self.ws = {k: e2e.Workspace("standby-" + k, args.keep, base="/run") for k in NODE}
        self.outputs = bool(args.plugins and args.probe)
        self.cfg = {k: config(self.ws[k], NODE[k], k, self.outputs) for k in NODE}
        self.daemon = {}
        self.starts = {k: 0 for k in NODE}

    def start(self, k):
        self.starts[k] += 1
        extra = ["--plugin-dir", self.args.plugins] if self.outputs else []
        self.daemon[k] = e2e.Daemon(self.args.daemon, self.cfg[k], self.ws[k], log_name="daemon-%d.log" % self.starts[k],
                                    extra_args=extra)
        return self.daemon[k]

    def kill(self, k):
        d = self.daemon[k]
        os.kill(d.pid, signal.SIGKILL)
        d.proc.wait(5)
        d.log.close()


class ModbusPoller:
    """Reads the first device's data age (input register 256 + 11, docs/modbus.md)
    from both gateways every 20 ms; a gateway that is down simply fails."""

    def __init__(self):
        import logging
        from pymodbus.client import ModbusTcpClient
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # a gateway down is expected here
        self.clients = {k: ModbusTcpClient("127.0.0.1", port=p, timeout=2) for k, p in MODBUS_PORT.items()}
        self.reads = []  # (time, gateway, data age ms)
        self.seqs = []  # (time, gateway, data age ms, sequence)
        self.stop_flag = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        from pymodbus.client import ModbusTcpClient
        while not self.stop_flag:
            for k, c in list(self.clients.items()):
                ok = False
                try:
                    if c.connected or c.connect():
                        # +11 data age, +12..13 sequence, +18 node-ID, +26 present (docs/modbus.md)
                        r = c.read_input_registers(256 + 11, 16, slave=1)
                        ok = not r.isError()
                        if ok:
                            # An empty slot reads as zeros: no device there is no live value either.
                            age = r.registers[0] if r.registers[15] == 1 else 0xFFFF
                            self.reads.append((time.time(), k, age))
                            self.seqs.append((time.time(), k, age, r.registers[1] << 16 | r.registers[2],
                                              r.registers[7]))
                except Exception:  # the gateway is down or restarting
                    pass
                if not ok:  # a fresh client: a dead server's connection is not reused
                    c.close()
                    self.clients[k] = ModbusTcpClient("127.0.0.1", port=MODBUS_PORT[k], timeout=2)
            time.sleep(0.02)

    def live_after(self, k, t0, limit):
        """Seconds from t0 until k's reads show a data age of at most 200 ms, or None."""
        while time.time() < t0 + limit:
            fresh = [t for t, g, a in self.reads if g == k and t >= t0 and a <= 200]
            if fresh:
                return fresh[0] - t0
            time.sleep(0.05)
        return None

    def worst(self, k, t0, t1):
        ages = [a for t, g, a in self.reads if g == k and t0 <= t <= t1]
        return (max(ages), len(ages)) if ages else (None, 0)

    def close(self):
        self.stop_flag = True
        self.thread.join(5)
        for c in self.clients.values():
            c.close()


def start_probe(args, ws):
    stop = ws.path("probe.stop")
    out = open(ws.path("probe.jsonl"), "w")
    p = subprocess.Popen([args.probe, "--domain", "0", "--seconds", "600", "--stop-file", stop, "--exclusive", "1"],
                         stdout=out, stderr=subprocess.STDOUT)
    return p, stop, out


def check_dds(report, ws, kills, rebooting):
    """rebooting: (time, node) of a device that was rebooting at a kill: it sends no values until the new
    master starts it, so its failover is not bounded by the takeover."""
    with open(ws.path("probe.jsonl")) as f:
        ev = [json.loads(l) for l in f if l.startswith("{")]
    switches = [e for e in ev if e["ev"] == "switch"]
    excused = [e for e in switches if any(e["node"] == n and 0 <= e["t"] / 1e9 - t <= 1.5 for t, n in rebooting)]
    for e in excused:
        print("FIGURE DDS failover of node %d, rebooting at the kill: %.0f ms" % (e["node"], e["gap_ms"]))
    per_device = {}
    for s in switches:
        per_device.setdefault(s["node"], []).append(s["gap_ms"])
    gaps = sorted(e["gap_ms"] for e in switches if e not in excused)
    if gaps:
        print("FIGURE DDS failover at the subscriber: p50 %.0f ms, p100 %.0f ms (%d switches)" % (
            gaps[len(gaps) // 2], gaps[-1], len(gaps)))
    report.check(all(len(per_device.get(n, [])) >= kills for (_, _, _, _, n) in DEVICES),
                 "DDS: every device's stream fell over to the survivor at every takeover (EXCLUSIVE reader)",
                 str({n: len(v) for n, v in per_device.items()}))
    report.check(gaps and gaps[-1] <= 1000, "DDS: each failover within 1 s at the subscriber", str(gaps[-5:]))
    writers = [e for e in ev if e["ev"] == "device"]
    bad = [w for w in writers if w["gaps"] != 0]
    report.check(writers and not bad, "DDS: no sequence gap in any gateway's stream (%d streams)" % len(writers),
                 str(bad[:3]))
    roles = {e["node"]: e["role"] for e in ev if e["ev"] == "gateway" and e.get("valid")}
    report.check(set(roles) == set(NODE.values()) and "master" in roles.values(),
                 "DDS GatewayStatus: one instance per gateway of the pair, with its role", str(roles))


def one_takeover(pair, report, listener, master, standby, i, no_wait=False):
    """Kills the master (at a random moment within 1 s, or at once); returns the takeover time in seconds."""
    if not no_wait:
        time.sleep(random.uniform(0.0, 1.0))
    pair.kill(master)
    dead = NODE[master]
    t_kill = time.time()
    r = role_is(pair.daemon[standby], "master", timeout=5)
    frames = listener.snapshot(t_kill - 1.0)
    last_dead = max([t for t, cid, _ in frames if cid == HB + dead or cid in ELECTION_IDS and t < t_kill], default=t_kill)
    took = None
    if r:
        became = e2e.iso_to_epoch(r["since"])
        took = became - last_dead
    print("FIGURE takeover %d: %s" % (i, "%.3f s after the master's last frame" % took if took is not None else "none"))
    return took


def main():
    def extra(p):
        p.add_argument("--kills", type=int, default=3)
        p.add_argument("--probe", help="cobridge_dds_probe: with --plugins, check DDS and Modbus through takeovers")
    args = e2e.parse_args(extra)
    report = e2e.Report("test_hot_standby")
    listener = e2e.CanListener("vcan0")
    pair = Pair(args, report)
    keep_logs = os.environ.get("STANDBY_LOGS")
    sim = e2e.Simulator(args.sim, pair.ws["a"], {"vcan0": ["%s:serial=%d,node=%d%s" % (
        sm, s, n, ",bitrate=250" if sm.startswith("RM") else "") for (_, _, sm, s, n) in DEVICES]})
    probe = poller = None
    if pair.outputs:
        probe = start_probe(args, pair.ws["a"])
    try:
        a = pair.start("a")
        report.check(a.wait_socket(), "gateway a: control socket up")
        report.check(role_is(a, "master", NODE["a"], timeout=10) is not None, "gateway a alone: master of the bus",
                     str(redundancy(a)))
        _, took = a.wait_until(e2e.all_operational(NAMES), 30, interval=0.05)
        report.check(took is not None, "gateway a: every device operational")
        b = pair.start("b")
        report.check(b.wait_socket(), "gateway b: control socket up")
        rb = role_is(b, "standby", NODE["a"], timeout=10)
        report.check(rb is not None, "gateway b: standby, naming a (node 120) as master", str(redundancy(b)))
        rc, out, _ = e2e.run_cli(args.cli, "status", "--control", pair.ws["b"].control)
        report.check(rc == 0 and "hot standby: standby, master node 120" in out,
                     "cobridge status (text) shows b's role and its master", " | ".join(out.splitlines()[:4]))
        # A request the standby would have to send on the bus (on its own control socket: the CLI
        # itself goes to the daemon that holds the bus's beacon) is refused, naming the master.
        answer = b.request("sdo-read vcan0 20 1000 0 500", timeout=15)
        text = str(answer.get("error", ""))
        report.check(answer.get("ok") is False and "standby" in text and "120" in text,
                     "an SDO read sent to the standby is refused, naming the master", str(answer)[:300])
        if pair.outputs:
            # A Modbus command written to the standby is refused (busy), naming the master in its log;
            # the standby sends nothing for it (the tx count below covers this window too).
            from pymodbus.client import ModbusTcpClient
            mb = ModbusTcpClient("127.0.0.1", port=MODBUS_PORT["b"], timeout=3)
            off = os.path.getsize(b.log_path)
            mb.connect()
            w = mb.write_registers(256 + 28, [0, 1234, 1], slave=1)
            status = None
            end = time.time() + 5
            while time.time() < end and status in (None, 0, 1):
                r = mb.read_holding_registers(256 + 31, 1, slave=1)
                status = None if r.isError() else r.registers[0]
                time.sleep(0.05)
            mb.close()
            report.check(not w.isError() and status == 5 and b.wait_log("standby", since=off, timeout=2),
                         "a Modbus preset written to the standby is refused (command_status 5, busy), "
                         "the log naming the master", "status %s" % status)
        tx0 = b.status()["buses"][0]["counters"]["tx_frames"]
        t_b = time.time()
        time.sleep(1.0)
        tx1 = b.status()["buses"][0]["counters"]["tx_frames"]
        t_e = time.time()
        frames = listener.snapshot(t_b)
        hb = {k: {d[:1] for t, cid, d in frames if cid == HB + NODE[k]} for k in NODE}
        report.check(hb["a"] == {b"\x05"} and hb["b"] == {b"\x7f"},
                     "the heartbeats tell the roles: a 05h (master), b 7Fh (standby)", str(hb))
        # Everything b sent in the window (its control socket's count) is its heartbeat: no NMT, SYNC,
        # SDO, LSS or guarding. The counters are read a little before and after the window's edges
        # (a status request takes time on a loaded machine): the heartbeats are counted over the window
        # widened by 0.2 s on each side, and b's sends may not exceed them (and not fall short by more
        # than the edges, two heartbeats).
        wide = listener.snapshot(t_b - 0.2)
        b_heartbeats = len([1 for t, cid, _ in wide if cid == HB + NODE["b"] and t <= t_e + 0.2])
        report.check(0 <= b_heartbeats - (tx1 - tx0) <= 4,
                     "the standby sends nothing but its heartbeat",
                     "%d frames sent, %d of them heartbeats on the bus" % (tx1 - tx0, b_heartbeats))

        if pair.outputs:
            poller = ModbusPoller()
            time.sleep(1.0)  # DDS discovery: the subscriber matches both gateways
        master, standby = "a", "b"
        takeovers = []
        rebooting = []  # (kill time, node) of a device rebooting at a kill
        survivor_worst = []  # the survivor's worst Modbus data age around each kill
        for i in range(1, args.kills + 1):
            log_offset = os.path.getsize(pair.daemon[standby].log_path)
            t_before = time.time()
            if poller:
                # Live before any takeover: the standby decodes every TPDO (20 ms event timer) from
                # the devices' first heartbeats after it joined.
                live = poller.live_after(standby, t_before, 5.0)
                report.check(live is not None,
                             "kill %d: before it, the standby's Modbus data is live (%s s after the check began)"
                             % (i, "%.2f" % live if live is not None else "never"))
                t_before = time.time()
            mid_config = None
            if i == 2:
                # A kill in the middle of a device's configuration: the device reboots (power cycle) and the
                # master is killed as soon as it starts configuring it again.
                mid_config = "mt-a"
                off = os.path.getsize(pair.daemon[master].log_path)
                sim.command("power-off 2001")
                time.sleep(0.2)
                sim.command("power-on 2001")
                report.check(pair.daemon[master].wait_log("mt-a (node 20) rebooted", since=off, timeout=5),
                             "kill 2: the master sees mt-a's boot-up and starts configuring it")
                rebooting.append((time.time(), 20))
            took = one_takeover(pair, report, listener, master, standby, i, no_wait=mid_config is not None)
            takeovers.append(took)
            if poller:
                worst, n = poller.worst(standby, t_before, time.time() + 1.0)
                mine = [(t, a, q, nd) for t, g, a, q, nd in poller.seqs if g == standby and t >= t_before - 1.0]
                old = ["%.3f:%d seq %d node %d (before: %s)" % (t - t_before, a, q, nd, [
                    "%.3f/%d/%d/%d" % (x[0] - t_before, x[1], x[2], x[3]) for x in mine[max(0, j - 4):j]])
                       for j, (t, a, q, nd) in enumerate(mine) if a > 1000 and t >= t_before]
                survivor_worst.append(worst)
                report.check(n > 0 and worst is not None and worst <= 1000,
                             "kill %d: Modbus on the survivor stays live (data age at most %s ms over %d reads)" % (
                                 i, worst, n), " ".join(old[:10]))
            survivor = pair.daemon[standby]
            _, back = survivor.wait_until(e2e.all_operational(NAMES), 20, interval=0.05)
            writes = writes_since(survivor, log_offset)
            healthy = {n: w for n, w in writes.items() if n != mid_config}
            report.check(back is not None and not any(healthy.values()),
                         "kill %d%s: the new master (%s) has every device operational, 0 configuration writes%s" % (
                             i, " (during %s's configuration)" % mid_config if mid_config else "", standby,
                             " on the healthy ones" if mid_config else ""), "%s; writes %s" % (back, writes))
            if mid_config:
                # Its settings are stored in the device, so a reboot needs an NMT start and no writes: the
                # new master verifies them (reads) and starts it.
                report.check(mid_config in writes,
                             "kill %d: %s, rebooted while the dead master configured it, is verified and started by "
                             "the new master" % (i, mid_config), str(writes))
            if i == 1:
                # The CLI finds the bus's daemon by its beacon: the survivor's, once the dead one's is gone.
                via = None
                end = time.time() + 5
                while time.time() < end and via != "daemon":
                    rc, out, _ = e2e.run_cli(args.cli, "sdo", "read", "-i", "vcan0", "-n", "20", "1000:0", "--json")
                    try:
                        via = json.loads(out).get("via") if rc == 0 else None
                    except ValueError:
                        via = None
                    time.sleep(0.2)
                report.check(via == "daemon", "kill 1: the CLI reaches the survivor (via the daemon, not the bus)",
                             out.strip()[:200])
            since = redundancy(survivor)["since"]
            returned = pair.start(master)
            returned.wait_socket()
            r = role_is(returned, "standby", NODE[standby], timeout=10)
            # No second election: the survivor stays master throughout (on a loaded machine the returning
            # gateway may miss the answer and ask for a negotiation, which the master answers by claiming).
            rs = redundancy(survivor)
            report.check(r is not None and rs["role"] == "master" and rs["since"] == since,
                         "kill %d: %s back on its state directory joins as standby, the master unchanged" % (
                             i, master), "%s / %s" % (redundancy(returned), rs))
            master, standby = standby, master

        if poller:
            survivors = [w for w in survivor_worst if w is not None]
            if survivors:
                print("FIGURE Modbus data age on the survivor around each takeover: worst %d ms (%d kills)" % (
                    max(survivors), len(survivors)))
        ok = [t for t in takeovers if t is not None]
        if ok:
            ok.sort()
            print("FIGURE takeover p50 %.3f s, p100 %.3f s (%d kills)" % (ok[len(ok) // 2], ok[-1], len(ok)))
        report.check(len(ok) == len(takeovers) and max(ok) <= 1.0,
                     "every takeover within 1 s of the master's last frame", str(takeovers))
        overlaps = e2e.master_heartbeat_overlaps(listener.snapshot(0), NODE)
        report.check(not overlaps, "never two masters: no two master heartbeats within one period",
                     "%d overlaps" % len(overlaps))

        # A device that reboots right after a takeover is configured by the new master.
        pair.kill(master)
        r = role_is(pair.daemon[standby], "master", timeout=5)
        report.check(r is not None, "one more takeover")
        off = os.path.getsize(pair.daemon[standby].log_path)
        sim.command("power-off 2001")
        time.sleep(0.3)
        sim.command("power-on 2001")
        survivor = pair.daemon[standby]
        configured = survivor.wait_log("mt-a operational at node 20", since=off, timeout=20)
        st, back = survivor.wait_until(
            lambda s: any(d["name"] == "mt-a" and d["state"] == "operational" for bb in s["buses"]
                          for d in bb["devices"]), 20, interval=0.05)
        if not report.check(back is not None and configured,
                            "a device rebooted right after the takeover: configured by the new master", "%s" % back):
            print(survivor.tail(60))
        if probe:
            time.sleep(1.0)
            open(probe[1], "w").close()
            probe[0].wait(10)
            check_dds(report, pair.ws["a"], args.kills + 1, rebooting)
    finally:
        if poller:
            poller.close()
        if probe and probe[0].poll() is None:
            probe[0].kill()
        if keep_logs:
            import shutil
            for k, ws in pair.ws.items():
                shutil.copytree(ws.dir, os.path.join(keep_logs, k), dirs_exist_ok=True)
        for d in pair.daemon.values():
            if d.proc.poll() is None:
                d.stop()
        sim.stop()
        listener.close()
        for ws in pair.ws.values():
            ws.cleanup()
    return report.finish()


if __name__ == "__main__":
    raise SystemExit(main())
