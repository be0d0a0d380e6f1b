#!/usr/bin/python3
"""Sparkplug B over MQTT, the session's later life, inside the CAN bed on
vcan0 (run by tests/vcan/run-in-vcan): DCMD commands, store and forward
across a broker restart, bdSeq across a daemon restart.

cobridge-sim (rot moving, ifm standing still, --truth) -> cobridged with
[outputs.mqtt] -> a real Mosquitto on 127.0.0.1 (started here, persistent,
queueing QoS 0 for its offline subscribers so that the subscriber misses
nothing while both reconnect) -> the subscriber of test_mqtt_e2e.py
(paho-mqtt + sparkplug_b.proto compiled by protoc), with a persistent session.

Asserts (Eclipse Sparkplug 3.0):
* DCMD Command/Preset (with Command/Client) on a device in write_allow: the
  simulator's own frames carry the preset (its truth file), and a DDATA
  Command/Result Code 0 comes back; the daemon's log names the client;
* DCMD on a device not in write_allow: refused, Result Code 17, nothing done;
  a malformed DCMD (unknown metric): Result Code 18 naming the metric;
* broker restart: a new NBIRTH (bdSeq + 1), the DBIRTHs, then the DDATA
  taken while the broker was away with is_historical = true, in order,
  every position change the simulator sent meanwhile, seq unbroken over
  the new session;
* daemon restart (SIGTERM): NDEATH of the old session, then NBIRTH with a
  larger bdSeq (the persisted one + 1), the bdseq file holding it;
* with writes_enabled = false: a DCMD preset is refused (Result Code 16)
  and the simulator's position stays;
* primary host (primary_host_id, 3.0 STATE, retained JSON): while its STATE
  says offline no birth; online -> NBIRTH and DBIRTHs; an offline STATE
  older than the last one heard is ignored (its timestamp); a newer one ->
  NDEATH of the session (same bdSeq) and no message while offline; online
  again -> NBIRTH with the next bdSeq, the DBIRTHs, then what was taken
  meanwhile as historical DDATA (spec 5: the edge node terminates its
  session when the primary host goes offline, births wait for online).
"""
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import e2e  # noqa: E402
import test_mqtt_e2e as mq  # noqa: E402

DEVICES = [("rot", "RFC-4800", "RFC-4800", 101, 10, ["position", "speed"], "constant:0.3"),
           ("ifm", "RM9000", "RM9000", 103, 12, ["position"], "constant:0")]
PRESET = 3333
CLIENT = "e2e-scada"


class PersistentBroker:
    """Mosquitto that keeps its subscribers' sessions over a restart and queues QoS 0 for them."""

    def __init__(self, ws):
        self.ws = ws
        self.conf = ws.path("mosquitto.conf")
        with open(self.conf, "w") as f:
            f.write("listener %d 127.0.0.1\nallow_anonymous true\npersistence true\npersistence_location %s/\n"
                    "queue_qos0_messages true\nmax_queued_messages 100000\nset_tcp_nodelay true\n"
                    # run as root (the bed is), it would switch to the user mosquitto and fail to save
                    "user root\n"
                    % (mq.PORT, ws.path("")))
        self.log = open(ws.path("mosquitto.log"), "a")
        self.proc = None
        self.start()

    def start(self):
        self.proc = subprocess.Popen(["/usr/sbin/mosquitto", "-c", self.conf], stdout=self.log, stderr=subprocess.STDOUT)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()


class PersistentSubscriber(mq.Subscriber):
    """The e2e host with clean_session = False: the broker keeps its subscription across a restart."""

    def __init__(self, pb):
        super().__init__(pb)
        import paho.mqtt.client as mqtt
        self.c = mqtt.Client(client_id="e2e-host", clean_session=False)
        self.c.on_message = self._on_message
        self.c.on_subscribe = lambda *a: self.subscribed.set()
        self.c.on_connect = lambda c, u, f, rc: c.subscribe("spBv1.0/%s/#" % mq.GROUP, qos=1)
        self.c.reconnect_delay_set(min_delay=1, max_delay=2)


def dcmd(pb, metrics):
    """A DCMD payload: metrics = [(name, datatype, value)]."""
    p = pb.Payload()
    p.timestamp = int(time.time() * 1000)
    for name, dt, value in metrics:
        m = p.metrics.add()
        m.name, m.datatype = name, dt
        if dt == 12:
            m.string_value = value
        elif dt == 11:
            m.boolean_value = value
        else:
            m.long_value = value & 0xFFFFFFFFFFFFFFFF
    return p.SerializeToString()


def result_after(sub, name, since, timeout=10):
    """(code, text, client) of the device's next DDATA carrying Command/Result Code."""
    births = [p for _, t, p in sub.all() if t == mq.topic("DBIRTH", name) and p is not None]
    if not births:
        return None
    alias = {m.name: m.alias for m in births[-1].metrics}
    want = alias.get("Command/Result Code")

    def has(t, p):
        return t == mq.topic("DDATA", name) and p is not None and any(m.alias == want for m in p.metrics)
    i = sub.wait_for(has, timeout, since)
    if i is None:
        return None
    ms = {m.alias: m for m in sub.all()[i][2].metrics}
    code = ms[want].int_value
    code = code - (1 << 32) if code >= (1 << 31) else code
    return code, ms[alias["Command/Result"]].string_value, ms[alias["Command/Client"]].string_value


def truth_positions(path, node, since_ns=0):
    return [(ts, pos) for ts, pos in mq.read_truth(path).get(node, []) if ts >= since_ns]


def check_commands(report, sub, pb, daemon, truth_path):
    n0 = len(sub.all())
    t0 = time.time_ns()
    sub.publish(mq.topic("DCMD", "ifm"), dcmd(pb, [("Command/Client", 12, CLIENT), ("Command/Preset", 4, PRESET)]))
    r = result_after(sub, "ifm", n0)
    report.check(r is not None and r[0] == 0 and r[2] == CLIENT,
                 "DCMD Command/Preset on ifm (write_allow): Result Code 0 back to %s" % CLIENT, str(r))
    time.sleep(1.0)  # the truth file is flushed every 100 ms
    after = truth_positions(truth_path, 12, t0)
    report.check(after and after[-1][1] == PRESET,
                 "the simulator's ifm sends the preset position %d (its truth file)" % PRESET,
                 str(after[-3:] if after else None))
    log = open(daemon.log_path).read()
    report.check("client '%s'" % CLIENT in log and "preset to %d on device ifm" % PRESET in log,
                 "the daemon's log names the DCMD's client and command")
    n1 = len(sub.all())
    sub.publish(mq.topic("DCMD", "rot"), dcmd(pb, [("Command/Client", 12, CLIENT), ("Command/Preset", 4, 5)]))
    r = result_after(sub, "rot", n1)
    report.check(r is not None and r[0] == 17 and "write_allow" in r[1],
                 "DCMD on rot (not in write_allow): refused, Result Code 17 with the reason", str(r))
    n2 = len(sub.all())
    sub.publish(mq.topic("DCMD", "ifm"), dcmd(pb, [("Command/Client", 12, CLIENT), ("Command/Reboot", 11, True)]))
    r = result_after(sub, "ifm", n2)
    report.check(r is not None and r[0] == 18 and "Command/Reboot" in r[1],
                 "a malformed DCMD (unknown metric): Result Code 18 naming the metric", str(r))


def historical_run(sub, since, pos_alias):
    """(timestamps, positions, flags) of rot's Position in DDATA from message `since` on, in arrival order."""
    out = []
    for _, t, p in sub.all()[since:]:
        if t == mq.topic("DDATA", "rot") and p is not None:
            out += [(m.timestamp, m.long_value & 0xFFFFFFFF, m.is_historical) for m in p.metrics if m.alias == pos_alias]
    return out


def check_broker_restart(report, sub, broker, truth_path, bd_before):
    n0 = len(sub.all())
    broker.stop()
    t_stop = time.time()
    time.sleep(4.0)
    broker.start()
    i = sub.wait_for(lambda t, p: t == mq.topic("NBIRTH"), 30, n0)
    if not report.check(i is not None, "after a broker restart: NBIRTH again"):
        return None
    nb = sub.all()[i][2]
    bd = mq.metric(nb, "bdSeq").long_value
    report.check(bd != bd_before, "the new session's bdSeq differs from the lost one's (%d -> %d)" % (bd_before, bd))
    d = sub.wait_for(lambda t, p: t == mq.topic("DBIRTH", "rot"), 10, i)
    report.check(d is not None, "DBIRTH of rot in the new session")
    time.sleep(2.0)
    msgs = sub.all()
    alias = {m.name: m.alias for m in msgs[d][2].metrics} if d is not None else {}
    run = historical_run(sub, i, alias.get("Position"))
    hist = [(ts, pos) for ts, pos, h in run if h]
    first_live = next((k for k, x in enumerate(run) if not x[2]), len(run))
    report.check(len(hist) > 50 and all(x[2] for x in run[:len(hist)]) and first_live == len(hist),
                 "historical DDATA (is_historical) after the births, before any live DDATA (%d positions)" % len(hist))
    stamps = [ts for ts, _ in hist]
    report.check(stamps == sorted(stamps) and hist and hist[0][0] >= t_stop * 1e3 - 1000,
                 "historical positions in order, stamped within the outage")
    time.sleep(0.5)
    sent = [(ts // 1_000_000, pos) for ts, pos in truth_positions(truth_path, 10)]
    if hist:
        lo, hi = hist[0][0] + 100, hist[-1][0] - 100
        expected = mq.dedup([pos for ms, pos in sent if lo <= ms <= hi])
        seen = mq.dedup([pos for _, pos in hist])
        k = seen.index(expected[0]) if expected and expected[0] in seen else -1
        report.check(k >= 0 and seen[k:k + len(expected)] == expected,
                     "the history holds every position change the simulator sent meanwhile, in order (%d)" % len(expected),
                     "k=%d, %d expected" % (k, len(expected)))
    seqs = [p.seq for _, t, p in sub.all()[i:] if p is not None and t.startswith("spBv1.0/%s/" % mq.GROUP)
            and t.split("/")[2] in ("NBIRTH", "DBIRTH", "DDATA", "DDEATH")]
    breaks = [(a, b) for a, b in zip(seqs, seqs[1:]) if b != (a + 1) % 256]
    report.check(seqs and seqs[0] == 0 and not breaks and len(seqs) > 20,
                 "seq unbroken over the new session, from NBIRTH's 0 (%d messages)" % len(seqs), str(breaks[:5]))
    return bd


HOST = "scada"


def publish_state(sub, online, stamp):
    """The primary host's STATE as a 3.0 host publishes it: retained, QoS 1, JSON."""
    sub.c.publish("spBv1.0/STATE/" + HOST, '{"online": %s, "timestamp": %d}' % ("true" if online else "false", stamp),
                  qos=1, retain=True)


def node_messages(sub, since):
    return [(t, p) for _, t, p in sub.all()[since:] if t.startswith("spBv1.0/%s/" % mq.GROUP)]


def check_primary_host(report, args, ws, sub, daemon, truth_path):
    """The primary host's STATE rules the session (see the module's docstring)."""
    n0 = len(sub.all())
    daemon.stop()
    sub.wait_for(lambda t, p: t == mq.topic("NDEATH"), 10, n0)
    stamp = int(time.time() * 1000)
    publish_state(sub, False, stamp)
    daemon, ok = start_daemon(args, ws, daemon_config(ws, False, "primary.toml", primary=True), "daemon-3.log")
    report.check(ok, "daemon with primary_host_id started, devices operational")
    n1 = len(sub.all())
    time.sleep(3.0)
    report.check(not node_messages(sub, n1), "primary host offline (STATE): no NBIRTH or any message in 3 s",
                 str([t for t, _ in node_messages(sub, n1)][:5]))
    publish_state(sub, True, stamp + 1)
    i = sub.wait_for(lambda t, p: t == mq.topic("NBIRTH"), 10, n1)
    d = sub.wait_for(lambda t, p: t == mq.topic("DBIRTH", "rot"), 10, i or n1)
    report.check(i is not None and d is not None, "STATE online: NBIRTH and the DBIRTHs")
    bd = mq.metric(sub.all()[i][2], "bdSeq").long_value if i is not None else None
    n2 = len(sub.all())
    publish_state(sub, False, stamp)  # older than the last: a stale retained message
    time.sleep(2.0)
    report.check(sub.wait_for(lambda t, p: t == mq.topic("NDEATH"), 0.1, n2) is None
                 and daemon.wait_log("is older than the last one heard", timeout=1),
                 "an offline STATE older than the last one heard is ignored (no NDEATH; logged)")
    n3 = len(sub.all())
    t_off = time.time()
    publish_state(sub, False, stamp + 2)
    k = sub.wait_for(lambda t, p: t == mq.topic("NDEATH"), 5, n3)
    report.check(k is not None and mq.metric(sub.all()[k][2], "bdSeq").long_value == bd,
                 "primary host offline: NDEATH of the session (bdSeq %s) within %.1f s" % (
                     bd, (sub.all()[k][0] - t_off) if k is not None else -1))
    time.sleep(3.0)
    held = ["%s (bdSeq %s)" % (t, mq.metric(p, "bdSeq").long_value if p is not None and mq.metric(p, "bdSeq") else "-")
            for t, p in node_messages(sub, (k or n3) + 1)]
    report.check(not held, "no message while the primary host is offline", str(held[:5]))
    n4 = len(sub.all())
    publish_state(sub, True, stamp + 3)
    j = sub.wait_for(lambda t, p: t == mq.topic("NBIRTH"), 10, n4)
    bd2 = mq.metric(sub.all()[j][2], "bdSeq").long_value if j is not None else None
    report.check(bd is not None and bd2 == (bd + 1) % 256,
                 "online again: NBIRTH of a new session, the next bdSeq (%s -> %s)" % (bd, bd2))
    d2 = sub.wait_for(lambda t, p: t == mq.topic("DBIRTH", "rot"), 10, j or n4)
    time.sleep(1.5)
    alias = {m.name: m.alias for m in sub.all()[d2][2].metrics} if d2 is not None else {}
    run = historical_run(sub, j or n4, alias.get("Position"))
    hist = [ts for ts, _, h in run if h]
    report.check(len(hist) > 20 and hist == sorted(hist) and hist[0] >= t_off * 1e3 - 1000,
                 "what was taken while the host was offline follows as historical DDATA, in order (%d positions)"
                 % len(hist))
    return daemon


def daemon_config(ws, writes, file_name, primary=False):
    bus = {"name": "line1", "interface": "vcan0", "lss_timeout_ms": 30, "sdo_timeout_ms": 200}
    devices = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
                "tpdo1": {"mapping": mp, "transmission": 254, "event_timer_ms": 20}}
               for (name, m, _, s, n, mp, _) in DEVICES]
    extra = ('[outputs.mqtt]\nhost = "127.0.0.1"\nport = %d\ngroup_id = "%s"\nedge_node_id = "%s"\nkeepalive_s = 5\n'
             'bdseq_file = "%s"\nwrites_enabled = %s\nwrite_allow = ["ifm"]\n'
             % (mq.PORT, mq.GROUP, mq.EDGE, ws.path("mqtt.bdseq"), "true" if writes else "false"))
    if primary:
        extra += 'primary_host_id = "%s"\n' % HOST
    return e2e.write_config(ws, [bus], devices, file_name=file_name, extra=extra)


def start_daemon(args, ws, cfg, log_name):
    daemon = e2e.Daemon(args.daemon, cfg, ws, extra_args=("--plugin-dir", args.plugins), log_name=log_name)
    ok = daemon.wait_socket() and daemon.wait_until(e2e.all_operational([d[0] for d in DEVICES]), 60, interval=0.1)[1]
    return daemon, ok is not None


def check_restart(report, args, ws, sub, pb, daemon, bd_before, truth_path):
    n0 = len(sub.all())
    daemon.stop()
    i = sub.wait_for(lambda t, p: t == mq.topic("NDEATH"), 10, n0)
    report.check(i is not None and mq.metric(sub.all()[i][2], "bdSeq").long_value == bd_before,
                 "SIGTERM: NDEATH with the session's bdSeq %d" % bd_before)
    daemon, ok = start_daemon(args, ws, daemon_config(ws, False, "nowrites.toml"), "daemon-2.log")
    report.check(ok, "daemon restarted (writes disabled), devices operational")
    j = sub.wait_for(lambda t, p: t == mq.topic("NBIRTH"), 30, n0)
    bd = mq.metric(sub.all()[j][2], "bdSeq").long_value if j is not None else None
    report.check(bd == (bd_before + 1) % 256, "after the restart NBIRTH's bdSeq is the persisted one + 1 (%s -> %s)"
                 % (bd_before, bd))
    stored = open(ws.path("mqtt.bdseq")).read()
    report.check(stored == "%s\n" % bd, "the bdseq file holds it", repr(stored))
    sub.wait_for(lambda t, p: t == mq.topic("DBIRTH", "ifm"), 10, j or n0)
    n1 = len(sub.all())
    t1 = time.time_ns()
    sub.publish(mq.topic("DCMD", "ifm"), dcmd(pb, [("Command/Client", 12, CLIENT), ("Command/Preset", 4, 77)]))
    r = result_after(sub, "ifm", n1)
    report.check(r is not None and r[0] == 16 and "writes are disabled" in r[1],
                 "writes disabled: DCMD preset refused, Result Code 16", str(r))
    time.sleep(1.0)
    after = truth_positions(truth_path, 12, t1)
    report.check(after and all(pos == PRESET for _, pos in after),
                 "the simulator's ifm position stays %d" % PRESET, str(after[-3:] if after else None))
    return daemon


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_mqtt_session")
    ws = e2e.Workspace("mqtt-session", args.keep)
    pb = mq.compile_proto(ws, e2e.SOURCE_DIR)
    broker = PersistentBroker(ws)
    sub = PersistentSubscriber(pb)
    sim = daemon = None
    try:
        report.check(sub.connect(), "subscriber connected and subscribed")
        truth_path = ws.path("truth.txt")
        sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d,motion=%s" % (sm, s, n, mo)
                                                     for (_, _, sm, s, n, _, mo) in DEVICES]},
                            extra_args=("--truth", truth_path))
        daemon, ok = start_daemon(args, ws, daemon_config(ws, True, "cobridge.toml"), "daemon.log")
        if not report.check(ok, "devices operational"):
            print(daemon.tail(60))
            return report.finish()
        i = sub.wait_for(lambda t, p: t == mq.topic("DBIRTH", "ifm"), 30)
        nb = sub.wait_for(lambda t, p: t == mq.topic("NBIRTH"), 1)
        report.check(i is not None and nb is not None, "births")
        bd0 = mq.metric(sub.all()[nb][2], "bdSeq").long_value if nb is not None else 0
        check_commands(report, sub, pb, daemon, truth_path)
        bd1 = check_broker_restart(report, sub, broker, truth_path, bd0)
        fig = next((o["figures"] for o in daemon.status().get("outputs", []) if o["type"] == "mqtt"), {})
        report.check(fig.get("mqtt_replayed", 0) > 50 and fig.get("mqtt_store_drops", -1) == 0,
                     "status: mqtt_replayed > 50, mqtt_store_drops 0", str(fig))
        if bd1 is not None:
            daemon = check_restart(report, args, ws, sub, pb, daemon, bd1, truth_path)
            daemon = check_primary_host(report, args, ws, sub, daemon, truth_path)
        if report.failed:
            print(daemon.tail(40))
    finally:
        sub.close()
        e2e.shut_down(ws, daemon, sim, broker)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
