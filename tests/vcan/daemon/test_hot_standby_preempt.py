"""Hot standby, no flapping (docs/configuration.md [redundancy] preempt,
hold_s; CiA 302-2 flying master): a gateway of higher rank that returns
takes the master role back only when configured to, after its hold time,
and never while the master is configuring a device.

Gateway a (priority 1) starts alone and is master; gateway b (priority 0,
preempt, hold_s = 2) joins:
  * b stands by first (an active master answered);
  * after its hold time b asks for the role back and is master, a stands
    by; a device rebooting every 0.4 s meanwhile keeps a configuring it
    often, and a hands the role over only between two configurations;
  * never two master heartbeats within one period, every device operational
    under b with 0 configuration writes on the devices a configured.
Runs inside UML:
  tests/vcan/run-in-vcan -- /usr/bin/python3 tests/vcan/daemon/test_hot_standby_preempt.py --daemon ...
"""
import os
import time

import bus_trace
import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10), ("mt-a", "MC1-2800", "MC1-2800", 2001, 20)]
NAMES = [d[0] for d in DEVICES]
NODE = {"a": 120, "b": 121}
HOLD_S = 2


def config(ws, k, extra):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 3600}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": nid, "heartbeat_ms": 100}
               for (n, m, _, s, nid) in DEVICES]
    return e2e.write_config(ws, [bus], devices,
                            extra='[redundancy]\nmode = "hot-standby"\nnode_id = %d\n%s' % (NODE[k], extra))


def redundancy(daemon):
    try:
        return daemon.status()["buses"][0].get("redundancy")
    except (OSError, ValueError, KeyError):
        return None


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_hot_standby_preempt")
    ws = {k: e2e.Workspace("preempt-" + k, args.keep, base="/run") for k in NODE}
    cfg = {"a": config(ws["a"], "a", "priority = 1\n"),
           "b": config(ws["b"], "b", "priority = 0\npreempt = true\nhold_s = %d\n" % HOLD_S)}
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws["a"], {"vcan0": ["%s:serial=%d,node=%d" % (sm, s, n)
                                                     for (_, _, sm, s, n) in DEVICES]})
    daemons = []
    try:
        a = e2e.Daemon(args.daemon, cfg["a"], ws["a"])
        daemons.append(a)
        report.check(a.wait_socket(), "gateway a up")
        _, ok = a.wait_until(e2e.all_operational(NAMES), 30, interval=0.05)
        report.check(ok is not None and redundancy(a)["role"] == "master", "a (priority 1) alone: master")

        b = e2e.Daemon(args.daemon, cfg["b"], ws["b"])
        daemons.append(b)
        report.check(b.wait_socket(), "gateway b up")
        t_join = time.time()
        end = t_join + 3
        r = None
        while time.time() < end and (r is None or r["role"] != "standby"):
            r = redundancy(b)
            time.sleep(0.02)
        report.check(r is not None and r["role"] == "standby" and r["cause"] == "an active master answered",
                     "b (priority 0, preempt) joins as standby first", str(r))
        # mt-a reboots every 0.4 s while b's hold time runs out, so a is often configuring it when b asks
        # for the role: the handover waits until a has finished (a's log shows each configuration done
        # before it stands down).
        a_off = os.path.getsize(a.log_path)
        end = t_join + HOLD_S + 6
        rb = None
        while time.time() < end and (rb is None or rb["role"] != "master"):
            sim.command("power-off 2001")
            time.sleep(0.03)
            sim.command("power-on 2001")
            time.sleep(0.37)
            rb = redundancy(b)
        report.check(rb is not None and rb["role"] == "master", "after its hold time b takes the role back", str(rb))
        report.check(rb is not None and e2e.iso_to_epoch(rb["since"]) - t_join >= HOLD_S,
                     "not before the hold time (%d s)" % HOLD_S, str(rb))
        with open(a.log_path) as f:
            f.seek(a_off)
            lines = f.read().splitlines()
        # a gives the role up when it answers b's request (it negotiates from then on).
        down = next((i for i, l in enumerate(lines) if "negotiating the master role (a gateway of higher rank" in l),
                    None)
        before = lines[:down] if down is not None else []
        booted = [i for i, l in enumerate(before) if "mt-a (node 20) rebooted" in l]
        done = [i for i, l in enumerate(before) if "mt-a back in operation" in l or "mt-a operational at node" in l]
        finished = not booted or any(d > booted[-1] for d in done)
        report.check(down is not None and len(booted) >= 3 and finished,
                     "a stands down only between two of mt-a's configurations, never in one",
                     "%d reboots before the stand-down; the last configured before it: %s" % (len(booted), finished))
        ra = redundancy(a)
        report.check(ra is not None and ra["role"] == "standby" and ra["master_node"] == NODE["b"],
                     "a stands by, naming b", str(ra))
        t_b_master = e2e.iso_to_epoch(rb["since"]) if rb else time.time()
        _, ok = b.wait_until(e2e.all_operational(NAMES), 20, interval=0.05)
        # Counted on the bus: SDO download requests to rot-a (mt-a rebooted on purpose) since b took the role.
        listener.wait_past(time.time())
        writes = bus_trace.sdo_downloads(listener.snapshot(t_b_master - 0.1), {DEVICES[0][4]})
        report.check(ok is not None and not writes,
                     "every device operational under b; 0 SDO download requests to rot-a on the bus",
                     bus_trace.describe_downloads(writes))
        # A second of both heartbeats after the handover observed: a window, not a wait.
        time.sleep(max(0.0, t_b_master + 1.0 - time.time()))
        bad = e2e.master_heartbeat_overlaps(listener.snapshot(0), NODE)
        report.check(not bad, "never two masters: no two master heartbeats within one period", "%d" % len(bad))
    finally:
        e2e.shut_down_pair(daemons, [sim, listener], ws.values())
    return report.finish()


if __name__ == "__main__":
    raise SystemExit(main())
