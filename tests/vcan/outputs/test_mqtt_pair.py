#!/usr/bin/python3
"""A hot-standby pair as one Sparkplug edge node, inside the CAN bed on
vcan0 (run by tests/vcan/run-in-vcan): two cobridged on one bus
([redundancy], docs/operations.md "Hot standby") with the same
[outputs.mqtt] edge node id, a real Mosquitto on 127.0.0.1 and the
subscriber of test_mqtt_e2e.py (a host written from the specification).

Gateway a (priority 1) starts alone and is master; gateway b (priority 0,
preempt, hold_s = 2) joins as standby, then takes the role while a still
runs; then b is killed (SIGKILL) and a takes the role again.

Asserts (Eclipse Sparkplug 3.0, the pair as one edge node):
* only the master publishes: while b stands by, one NBIRTH (a's) and no
  second; b's status says it is not the edge node;
* the handover while a runs: a publishes NDEATH itself with its session's
  bdSeq, then b's NBIRTH with the next bdSeq and every DBIRTH published
  (their payload timestamps) within 1 s of b becoming master (its role's
  `since`);
* b killed: the broker's will NDEATH (b's bdSeq), then a's NBIRTH (the next
  bdSeq) and every DBIRTH within 1 s of a becoming master;
* the primary host offline (its STATE, Sparkplug 3.0 5: both gateways name
  it in primary_host_id): the master (a) ends its session (NDEATH); b,
  restarted as standby, takes the role when a is killed while the host is
  still offline, and publishes no NBIRTH until the host's STATE says online
  again, then its NBIRTH and every DBIRTH, one session alive;
* over the whole run a host never sees two sessions alive at once: every
  NBIRTH comes when no session is alive (the last NBIRTH's bdSeq had its
  NDEATH), and the seq of each session is unbroken (no message of an old
  session after the new NBIRTH).
"""
import os
import signal
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import e2e  # noqa: E402
import test_mqtt_e2e as mq  # noqa: E402

# rot moves (10 DDATA/s, so that a session's data is in flight at each
# takeover); the others stand still (report by exception sends nothing for
# them), which keeps the bed's one CPU for the broker: loaded with three moving
# encoders, Mosquitto fell seconds behind (its subscriber lag printed) and
# delivered a killed master's last DDATA and will after the new NBIRTH.
DEVICES = [("rot", "RFC-4800", "RFC-4800", 1001, 10, "constant:0.2"), ("mt", "MC1-2800", "MC1-2800", 2001, 20, "constant:0"),
           ("ifm", "RM9", "RM9000", 3001, 30, "constant:0")]
NAMES = [d[0] for d in DEVICES]
NODE = {"a": 120, "b": 121}
HOLD_S = 2
HOST = "scada"  # the primary host application (Sparkplug 3.0 5), played by the subscriber


def publish_state(sub, online, stamp):
    """The primary host's STATE as a 3.0 host publishes it: retained, QoS 1, JSON."""
    sub.c.publish("spBv1.0/STATE/" + HOST, '{"online": %s, "timestamp": %d}' % ("true" if online else "false", stamp),
                  qos=1, retain=True)


def config(ws, k, extra):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 3600}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": nid, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": 254, "event_timer_ms": 100}}
               for (n, m, _, s, nid, _mo) in DEVICES]
    mqtt = ('[outputs.mqtt]\nhost = "127.0.0.1"\nport = %d\ngroup_id = "%s"\nedge_node_id = "%s"\nkeepalive_s = 5\n'
            'bdseq_file = "%s"\nprimary_host_id = "%s"\n' % (mq.PORT, mq.GROUP, mq.EDGE, ws.path("mqtt.bdseq"), HOST))
    return e2e.write_config(ws, [bus], devices,
                            extra='[redundancy]\nmode = "hot-standby"\nnode_id = %d\n%s%s' % (NODE[k], extra, mqtt))


def redundancy(daemon):
    try:
        return daemon.status()["buses"][0].get("redundancy")
    except (OSError, ValueError, KeyError):
        return None


def wait_role(daemon, role, timeout):
    end = time.time() + timeout
    while time.time() < end:
        r = redundancy(daemon)
        if r and r["role"] == role:
            return r
        time.sleep(0.02)
    return None


def edge_node_figure(daemon):
    try:
        outs = [o for o in daemon.status().get("outputs", []) if o["type"] == "mqtt"]
    except (OSError, ValueError):
        return None
    return outs[0]["figures"].get("mqtt_edge_node") if outs else None


def node_events(sub, since=0):
    """[(index, arrival, 'NBIRTH'|'NDEATH', bdSeq)] from message `since` on."""
    out = []
    for i, (t, top, p) in enumerate(sub.all()[since:], since):
        kind = top.split("/")[2] if top.startswith("spBv1.0/%s/" % mq.GROUP) else None
        if kind in ("NBIRTH", "NDEATH") and p is not None:
            bd = mq.metric(p, "bdSeq")
            out.append((i, t, kind, bd.long_value if bd else None))
    return out


def check_takeover(report, sub, since, what, old_bd, t_master):
    """One NDEATH (old bdSeq) then one NBIRTH (the next) and every DBIRTH within 1 s of t_master; returns the new bdSeq."""
    j = sub.wait_for(lambda t, p: t == mq.topic("NBIRTH"), 10, since)
    ev = [(k, b) for _, _, k, b in node_events(sub, since)]
    report.check(len(ev) >= 2 and ev[0] == ("NDEATH", old_bd) and ev[1] == ("NBIRTH", (old_bd + 1) % 256)
                 and len(ev) == 2,
                 "%s: one NDEATH (bdSeq %d) then one NBIRTH (bdSeq %d)" % (what, old_bd, (old_bd + 1) % 256), str(ev))
    if j is None:
        return None
    # Judged by when the gateway built each birth (its payload timestamp, the
    # daemon's wall clock, as the role's `since`): the Python subscriber on the
    # bed's one CPU receives with a lag of its own (printed).
    msgs = sub.all()
    stamps, lags = [("NBIRTH", msgs[j][2].timestamp / 1e3)], [msgs[j][0] - msgs[j][2].timestamp / 1e3]
    for name in NAMES:
        k = sub.wait_for(lambda t, p: t == mq.topic("DBIRTH", name), 10, j)
        if k is None:
            stamps.append((name, None))
            continue
        msgs = sub.all()
        stamps.append((name, msgs[k][2].timestamp / 1e3))
        lags.append(msgs[k][0] - msgs[k][2].timestamp / 1e3)
    print("info %s: published %s after the role's since; subscriber lag up to %.0f ms" % (
        what, ", ".join("%s %+.0f ms" % (n, (ts - t_master) * 1e3) for n, ts in stamps if ts is not None),
        max(lags) * 1e3), flush=True)
    took = None if any(ts is None for _, ts in stamps) else max(ts for _, ts in stamps) - t_master
    report.check_bound(took is not None and took <= 1.0,
                       "%s: NBIRTH and every DBIRTH published within 1 s of becoming master" % what,
                       "%.0f ms" % (took * 1e3) if took is not None else "missing DBIRTH")
    print("FIGURE %s: last DBIRTH published %.0f ms after the role's since" % (what, took * 1e3 if took else -1),
          flush=True)
    return ev[1][1] if len(ev) >= 2 else None


def node_messages(sub, since):
    return [(t, p) for _, t, p in sub.all()[since:] if t.startswith("spBv1.0/%s/" % mq.GROUP)]


def check_takeover_host_offline(report, args, ws, sub, a, extra):
    """The primary host goes offline; b (restarted, without preempt: a
    handover is held down for a minute after the last) stands by, a is
    killed, and b, master now, holds its births until the host is online
    again. Returns b."""
    n0 = len(sub.all())
    publish_state(sub, False, int(time.time() * 1000))
    k = sub.wait_for(lambda t, p: t == mq.topic("NDEATH"), 5, n0)
    report.check(k is not None, "primary host offline: the master (a) publishes NDEATH")
    b = e2e.Daemon(args.daemon, config(ws["b"], "b", "priority = 0\n"), ws["b"], log_name="daemon-b2.log",
                   extra_args=extra)
    if not report.check(b.wait_socket() and wait_role(b, "standby", 10) is not None, "b restarted: standby"):
        return b
    os.kill(a.pid, signal.SIGKILL)
    a.proc.wait(5)
    rb = wait_role(b, "master", 10)
    if not report.check(rb is not None, "a killed while the host is offline: b is master", str(rb)):
        return b
    time.sleep(2.0)
    births = [t for t, _ in node_messages(sub, (k or n0) + 1) if "BIRTH" in t]
    report.check(not births, "host offline: no NBIRTH or DBIRTH of either gateway, b master for 2 s", str(births[:4]))
    n1 = len(sub.all())
    t_online = time.time()
    publish_state(sub, True, int(t_online * 1000))
    i = sub.wait_for(lambda t, p: t == mq.topic("NBIRTH"), 10, n1)
    report.check(i is not None and all(sub.wait_for(lambda t, p, n=n: t == mq.topic("DBIRTH", n), 10, i) is not None
                                       for n in NAMES),
                 "host online again: b's NBIRTH and every DBIRTH (%.1f s after the STATE)" % (
                     (sub.all()[i][0] - t_online) if i is not None else -1))
    report.check(b.wait_log("connecting as edge node", timeout=1), "b's log: it connected as the edge node")
    return b


def check_never_two_alive(report, sub):
    alive, bad = None, []
    for i, _, kind, bd in node_events(sub):
        if kind == "NBIRTH":
            if alive is not None and alive != bd:
                bad.append((i, "NBIRTH %d while %d alive" % (bd, alive)))
            alive = bd
        elif kind == "NDEATH" and bd == alive:
            alive = None
    report.check(not bad, "a host never sees two sessions alive at once", str(bad[:4]))
    prev, n, breaks = None, 0, []
    for i, (_, t, p) in enumerate(sub.all()):
        kind = t.split("/")[2] if t.startswith("spBv1.0/%s/" % mq.GROUP) else None
        if kind not in ("NBIRTH", "DBIRTH", "DDATA", "DDEATH") or p is None:
            continue
        n += 1
        if kind == "NBIRTH":
            if p.seq != 0:
                breaks.append((i, t, p.seq, 0))
        elif prev is not None and p.seq != (prev + 1) % 256:
            breaks.append((i, t, p.seq, (prev + 1) % 256))
        prev = p.seq
    report.check(n > 50 and not breaks, "seq unbroken within every session (%d messages)" % n,
                 str(breaks[:4]))


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_mqtt_pair")
    ws = {k: e2e.Workspace("mqtt-pair-" + k, args.keep, base="/run") for k in NODE}
    pb = mq.compile_proto(ws["a"], e2e.SOURCE_DIR)
    broker = mq.Broker(ws["a"])
    sub = mq.Subscriber(pb)
    cfg = {"a": config(ws["a"], "a", "priority = 1\n"),
           "b": config(ws["b"], "b", "priority = 0\npreempt = true\nhold_s = %d\n" % HOLD_S)}
    sim = e2e.Simulator(args.sim, ws["a"], {"vcan0": ["%s:serial=%d,node=%d,motion=%s" % (sm, s, n, mo)
                                                     for (_, _, sm, s, n, mo) in DEVICES]})
    daemons = {}
    extra = ("--plugin-dir", args.plugins)
    try:
        report.check(sub.connect(), "subscriber connected")
        publish_state(sub, True, int(time.time() * 1000))
        a = daemons["a"] = e2e.Daemon(args.daemon, cfg["a"], ws["a"], extra_args=extra)
        report.check(a.wait_socket() and wait_role(a, "master", 30) is not None, "a (priority 1) alone: master")
        i = sub.wait_for(lambda t, p: t == mq.topic("DBIRTH", "ifm"), 30)
        ev = node_events(sub)
        report.check(i is not None and [k for _, _, k, _ in ev] == ["NBIRTH"], "a's NBIRTH and DBIRTHs", str(ev))
        bd_a = ev[0][3] if ev else 0
        n_join = len(sub.all())
        b = daemons["b"] = e2e.Daemon(args.daemon, cfg["b"], ws["b"], extra_args=extra)
        report.check(b.wait_socket() and wait_role(b, "standby", 5) is not None, "b joins as standby")
        time.sleep(0.5)
        report.check(edge_node_figure(b) == 0 and edge_node_figure(a) == 1 and not node_events(sub, n_join),
                     "while b stands by only a is the edge node: no NBIRTH of b",
                     "a %s, b %s, %s" % (edge_node_figure(a), edge_node_figure(b), node_events(sub, n_join)))
        rb = wait_role(b, "master", HOLD_S + 10)
        if not report.check(rb is not None and wait_role(a, "standby", 5) is not None,
                            "after its hold time b takes the role, a (still running) stands by", str(rb)):
            return report.finish()
        bd_b = check_takeover(report, sub, n_join, "handover while a runs", bd_a, e2e.iso_to_epoch(rb["since"]))
        log_a = open(a.log_path).read()
        report.check("NDEATH published, observing as the standby" in log_a, "a's log: it published NDEATH itself")
        time.sleep(1.0)
        n_kill = len(sub.all())
        t_kill = time.time()
        os.kill(b.pid, signal.SIGKILL)
        b.proc.wait(5)
        print("info b killed: its process gone after %.0f ms" % ((time.time() - t_kill) * 1e3), flush=True)
        ra = wait_role(a, "master", 10)
        if report.check(ra is not None and bd_b is not None, "b killed: a is master again", str(ra)):
            print("info b killed: a master %.0f ms after the kill" % ((e2e.iso_to_epoch(ra["since"]) - t_kill) * 1e3))
            check_takeover(report, sub, n_kill, "b killed", bd_b, e2e.iso_to_epoch(ra["since"]))
            time.sleep(1.0)
            daemons["b"] = check_takeover_host_offline(report, args, ws, sub, a, extra)
        time.sleep(1.0)
        check_never_two_alive(report, sub)
        if report.failed:
            for d in daemons.values():
                print(d.tail(30))
    finally:
        sub.close()
        e2e.shut_down_pair(list(daemons.values()), [sim, broker], list(ws.values()))
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
