#!/usr/bin/python3
"""Sparkplug B over MQTT end to end, inside the CAN bed on vcan0 (run by
tests/vcan/run-in-vcan):

cobridge-sim (three encoders, TPDO1 every 20 ms, --truth)
-> cobridged with [outputs.mqtt] (libcobridge_mqtt.so)
-> a real Mosquitto broker on 127.0.0.1 (started here)
-> a subscriber of ours (paho-mqtt + the payload compiled from
   plugins/mqtt/sparkplug_b.proto by protoc at test time).

Asserts (Eclipse Sparkplug 3.0):
* NBIRTH first (seq 0, bdSeq, Node Control/Rebirth), then a DBIRTH per
  device with every metric of its set (name, alias, datatype; ifm's set from
  [outputs.mqtt.metrics], exactly those) and its identity (serial = the
  simulator's);
* seq unbroken mod 256 over NBIRTH/DBIRTH/DDATA/DDEATH, 0 at each NBIRTH;
* DDATA positions equal the simulator's truth, in order, none lost, each
  stamped with its frame's receive time;
* DDEATH within the supervision bound of a device going silent, DBIRTH when
  it is back;
* NCMD Node Control/Rebirth -> NBIRTH (same bdSeq) and every DBIRTH again;
* status shows the output's figures (connected, births, messages);
* SIGKILL of the daemon -> the broker publishes NDEATH (the will, same
  bdSeq, no seq) within 1.5 x keepalive;
* --check-config refuses a password file open to others, naming the key.
"""
import os
import signal
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
import e2e  # noqa: E402

PORT = 18830
GROUP, EDGE = "e2e", "gw1"
KEEPALIVE = 5
# name, config model, simulator spec, serial, node, mapping
DEVICES = [("rot", "RFC-4800", "RFC-4800", 101, 10, ["position", "speed"], "constant:0.3"),
           ("mt", "MC1-2800", "MC1-2800", 102, 11, ["position", "speed"], "constant:0.5"),
           ("ifm", "RM9000", "RM9000", 103, 12, ["position"], "constant:0")]
# The ifm encoder stands still: its frames (every few ms, whatever the event
# timer) still pass the plugin, but report by exception sends no DDATA for an
# unchanged position, which keeps the bed's one CPU for the checks; its
# value is judged in its DBIRTH (or, when the session came up before its
# first frame and the DBIRTH said null, in the first DDATA after it), the
# others' in DDATA.
MOVING = ("rot", "mt")
PROCESS_METRICS = ["Position", "Position/Engineering", "Speed", "CAM State", "Work Area State", "Alarms", "Warnings",
                   "Temperature", "Supply Voltage", "NMT State", "Stale", "EMCY/Error Code", "EMCY/Error Register"]
# [outputs.mqtt.metrics]: ifm publishes only these; the others every process metric.
METRIC_SETS = {"ifm": ["Position", "NMT State", "Stale"]}


def compile_proto(ws, source_dir):
    out = ws.path("pb")
    os.makedirs(out, exist_ok=True)
    proto_dir = os.path.join(source_dir, "plugins", "mqtt")
    subprocess.run(["protoc", "--proto_path=" + proto_dir, "--python_out=" + out,
                    os.path.join(proto_dir, "sparkplug_b.proto")], check=True)
    sys.path.insert(0, out)
    import sparkplug_b_pb2
    return sparkplug_b_pb2


class Broker:
    def __init__(self, ws):
        conf = ws.path("mosquitto.conf")
        with open(conf, "w") as f:
            f.write("listener %d 127.0.0.1\nallow_anonymous true\npersistence false\nset_tcp_nodelay true\n" % PORT)
        self.log = open(ws.path("mosquitto.log"), "w")
        self.proc = subprocess.Popen(["/usr/sbin/mosquitto", "-c", conf], stdout=self.log, stderr=subprocess.STDOUT)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        self.log.close()


class Subscriber:
    """Every Sparkplug message of the group, decoded, with its arrival time."""

    def __init__(self, pb):
        import paho.mqtt.client as mqtt
        self.pb = pb
        self.lock = threading.Lock()
        self.msgs = []  # (time, topic, Payload or None)
        self.c = mqtt.Client(client_id="e2e-host", clean_session=True)
        self.c.on_message = self._on_message
        self.subscribed = threading.Event()
        self.c.on_subscribe = lambda *a: self.subscribed.set()
        self.c.on_connect = lambda c, u, f, rc: c.subscribe("spBv1.0/%s/#" % GROUP, qos=1)

    def connect(self, timeout=20):
        end = time.time() + timeout
        while time.time() < end:
            try:
                self.c.connect("127.0.0.1", PORT, keepalive=30)
                break
            except OSError:
                time.sleep(0.1)
        self.c.loop_start()
        return self.subscribed.wait(max(0.1, end - time.time()))

    def _on_message(self, client, userdata, msg):
        p = self.pb.Payload()
        try:
            p.ParseFromString(msg.payload)
        except Exception:
            p = None
        with self.lock:
            self.msgs.append((time.time(), msg.topic, p))

    def all(self):
        with self.lock:
            return list(self.msgs)

    def wait_for(self, pred, timeout, since=0):
        """Index of the first message from `since` with pred(topic, payload), or None."""
        end = time.time() + timeout
        while time.time() < end:
            msgs = self.all()
            for i in range(since, len(msgs)):
                if pred(msgs[i][1], msgs[i][2]):
                    return i
            time.sleep(0.01)
        return None

    def publish(self, topic, payload):
        self.c.publish(topic, payload, qos=0)

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()


def topic(kind, device=None):
    return "spBv1.0/%s/%s/%s%s" % (GROUP, kind, EDGE, "/" + device if device else "")


def metric(p, name):
    return next((m for m in p.metrics if m.name == name), None)


def read_truth(path):
    """node -> [(ts_ns, pos & 0xFFFFFFFF)] of every TPDO1 the simulator sent."""
    truth = {}
    for line in open(path):
        f = line.split()
        if len(f) < 8 or f[4] != "tpdo1":
            continue
        pos = next((int(x[4:]) for x in f[8:] if x.startswith("pos=")), None)
        if pos is not None:
            truth.setdefault(int(f[3]), []).append((int(f[0]), pos & 0xFFFFFFFF))
    return truth


def dedup(values):
    out = []
    for v in values:
        if not out or out[-1] != v:
            out.append(v)
    return out


def check_births(report, sub, since):
    """NBIRTH then a DBIRTH per device; returns (bdSeq, {device: {alias: name}}) or None."""
    i = sub.wait_for(lambda t, p: t == topic("NBIRTH"), 30, since)
    if not report.check(i is not None, "NBIRTH received"):
        return None
    first = [m for m in sub.all()[since:] if m[1].startswith("spBv1.0/%s/" % GROUP) and "/STATE/" not in m[1]]
    report.check(first[0][1] == topic("NBIRTH"), "NBIRTH is the edge node's first message", first[0][1])
    nb = sub.all()[i][2]
    bd = metric(nb, "bdSeq") if nb else None
    rebirth = metric(nb, "Node Control/Rebirth") if nb else None
    report.check(nb is not None and nb.seq == 0 and nb.HasField("seq"), "NBIRTH decodes, seq 0")
    report.check(bd is not None and bd.datatype == 4, "NBIRTH has bdSeq (Int64)", str(bd).replace("\n", " "))
    report.check(rebirth is not None and rebirth.datatype == 11 and not rebirth.boolean_value,
                 "NBIRTH has Node Control/Rebirth (Boolean, false)")
    aliases = {}
    for name, _m, _s, serial, node, _map, _mo in DEVICES:
        j = sub.wait_for(lambda t, p: t == topic("DBIRTH", name), 20, i)
        if not report.check(j is not None, "%s: DBIRTH received" % name):
            continue
        p = sub.all()[j][2]
        names = {m.name: m for m in p.metrics}
        wanted = METRIC_SETS.get(name, PROCESS_METRICS)
        missing = [n for n in wanted if n not in names]
        extra = [n for n in PROCESS_METRICS if n in names and n not in wanted]
        report.check(not missing and not extra, "%s: DBIRTH has every process metric of its set (%s)" % (
            name, "all" if wanted is PROCESS_METRICS else ", ".join(wanted)), "missing %s, extra %s" % (missing, extra))
        report.check(all(m.alias != 0 and m.datatype != 0 for m in p.metrics), "%s: every metric has alias and datatype" % name)
        sn = names.get("Properties/Serial Number")
        report.check(sn is not None and sn.int_value == serial, "%s: identity serial = the simulator's %d" % (name, serial),
                     str(sn.int_value if sn else None))
        nid = names.get("Properties/Node ID")
        report.check(nid is not None and nid.int_value == node, "%s: node-ID %d" % (name, node))
        aliases[name] = {m.alias: m.name for m in p.metrics}
    all_aliases = [a for d in aliases.values() for a in d]
    report.check(len(all_aliases) == len(set(all_aliases)), "aliases unique across the edge node")
    return (bd.long_value if bd else None), aliases


def check_seq(report, msgs):
    """seq +1 mod 256 over every message but NDEATH; 0 at NBIRTH."""
    prev, bad, n = None, [], 0
    for _, t, p in msgs:
        if not t.startswith("spBv1.0/%s/" % GROUP) or "/NDEATH/" in t or "/NCMD/" in t or p is None:
            continue
        n += 1
        if "/NBIRTH/" in t:
            if p.seq != 0:
                bad.append((t, p.seq, 0))
        elif prev is not None and p.seq != (prev + 1) % 256:
            bad.append((t, p.seq, (prev + 1) % 256))
        prev = p.seq
    report.check(n > 300 and not bad, "seq unbroken mod 256 over %d messages" % n, str(bad[:5]))


def check_static_position(report, sub, aliases, truth, name, node):
    """The Position a host holds for a device that does not move: its last DBIRTH's, or, when that
    DBIRTH said null (a value not heard yet is sent as null, Sparkplug 3.0 tck-id-payloads-dbirth-*:
    the session came up before the device's first TPDO), the first DDATA after it."""
    msgs = sub.all()
    births = [i for i, (_, t, p) in enumerate(msgs) if t == topic("DBIRTH", name) and p is not None]
    pos = metric(msgs[births[-1]][2], "Position") if births else None
    value, where = (None, "no DBIRTH") if pos is None else (None, "DBIRTH null") if pos.is_null else (
        pos.long_value & 0xFFFFFFFF, "DBIRTH")
    pos_alias = next((a for a, n in aliases.get(name, {}).items() if n == "Position"), None)
    if births and value is None and pos is not None:
        for _, t, p in msgs[births[-1] + 1:]:
            hit = [m for m in p.metrics if m.alias == pos_alias] if t == topic("DDATA", name) and p else []
            if hit:
                value, where = hit[0].long_value & 0xFFFFFFFF, "first DDATA after a null DBIRTH"
                break
    sent = set(v for _, v in truth.get(node, []))
    report.check(value is not None and value in sent,
                 "%s: the Position a host holds (its DBIRTH's, or the first DDATA after a null one) is one the "
                 "simulator sent" % name, "%s from the %s (the simulator sent %d values, first %s)" % (
                     value, where, len(truth.get(node, [])), truth.get(node, [])[:3]))


def check_values(report, sub, aliases, truth, since):
    """DDATA positions against the truth file: each value sent with its time, none lost in the window."""
    for name, _m, _s, _serial, node, _map, _mo in DEVICES:
        if name not in MOVING:
            check_static_position(report, sub, aliases, truth, name, node)
            continue
        pos_alias = next((a for a, n in aliases.get(name, {}).items() if n == "Position"), None)
        got, lag = [], []
        for arrived, t, p in sub.all()[since:]:
            if t == topic("DDATA", name) and p is not None:
                got += [(m.timestamp, m.long_value & 0xFFFFFFFF) for m in p.metrics if m.alias == pos_alias]
                lag += [arrived * 1e3 - m.timestamp for m in p.metrics if m.alias == pos_alias]
        if lag:
            lag.sort()
            print("info %s: frame to subscriber %d DDATA, median %.0f ms, max %.0f ms, last %.0f ms" % (
                name, len(lag), lag[len(lag) // 2], lag[-1], lag[-1]), flush=True)
        sent = truth.get(node, [])
        if not report.check(len(got) > 50 and sent, "%s: DDATA positions received (%d)" % (name, len(got))):
            continue
        sent_ms = [(ts // 1_000_000, pos) for ts, pos in sent]
        # The truth file lags by its 100 ms flush period: judge what it covers.
        cover = min(got[-1][0], sent_ms[-1][0]) - 200
        got = [(ms, pos) for ms, pos in got if ms <= cover]
        by_pos = {}
        for ms, pos in sent_ms:
            by_pos.setdefault(pos, []).append(ms)
        unmatched = [(ms, pos) for ms, pos in got if not any(abs(ms - s) <= 100 for s in by_pos.get(pos, ()))]
        report.check(not unmatched, "%s: every DDATA position is one the simulator sent, stamped with its frame's time "
                     "(within 100 ms)" % name, "%d unmatched, e.g. %s" % (len(unmatched), unmatched[:3]))
        # Every change the simulator sent inside the window must be a run of
        # what arrived (matched by value: a frame's send and receive times may
        # fall on either side of the window's edge).
        lo, hi = got[0][0] + 100, got[-1][0] - 100
        expected = dedup([pos for ms, pos in sent_ms if lo <= ms <= hi])
        seen = dedup([pos for ms, pos in got])
        k = seen.index(expected[0]) if expected and expected[0] in seen else -1
        report.check(k >= 0 and seen[k:k + len(expected)] == expected and len(expected) > 20,
                     "%s: DDATA carries every position change the simulator sent, in order (%d)" % (name, len(expected)),
                     "expected %d, got %d in the run" % (len(expected), len(seen[k:k + len(expected)]) if k >= 0 else 0))


def check_death_and_return(report, sub, sim, name, serial):
    n0 = len(sub.all())
    t0 = time.time()
    sim.command("silence %d on" % serial)
    i = sub.wait_for(lambda t, p: t == topic("DDEATH", name), 5, n0)
    took = (sub.all()[i][0] - t0) if i is not None else None
    report.check_bound(took is not None and took <= 1.0, "%s: DDEATH within 1 s of going silent (heartbeat 100 ms)" % name,
                       "%.0f ms (silenced at %s)" % (took * 1e3 if took is not None else -1,
                                                     time.strftime("%H:%M:%S", time.localtime(t0)) + ("%.3f" % (t0 % 1))[1:]))
    time.sleep(0.5)
    n1 = len(sub.all())
    sim.command("silence %d off" % serial)
    j = sub.wait_for(lambda t, p: t == topic("DBIRTH", name), 10, n1)
    report.check(j is not None, "%s: DBIRTH again when it is back" % name)
    msgs = sub.all()
    between = [(m[1].split("/")[2], m[2].seq if m[2] else None) for m in msgs[(i or n0) + 1:(j or len(msgs))]
               if m[1].endswith("/" + name)]
    report.check(i is not None and not between, "%s: nothing of it between its DDEATH and its DBIRTH" % name,
                 str(between[:6]))


def check_rebirth(report, sub, pb, bd_seq):
    n0 = len(sub.all())
    cmd = pb.Payload()
    cmd.timestamp = int(time.time() * 1000)
    m = cmd.metrics.add()
    m.name = "Node Control/Rebirth"
    m.datatype = 11
    m.boolean_value = True
    sub.publish(topic("NCMD"), cmd.SerializeToString())
    i = sub.wait_for(lambda t, p: t == topic("NBIRTH"), 5, n0)
    if not report.check(i is not None, "NCMD Node Control/Rebirth -> NBIRTH"):
        return
    nb = sub.all()[i][2]
    report.check(metric(nb, "bdSeq").long_value == bd_seq and nb.seq == 0, "rebirth NBIRTH: same bdSeq, seq 0")
    for name, *_ in DEVICES:
        report.check(sub.wait_for(lambda t, p: t == topic("DBIRTH", name), 5, i) is not None,
                     "rebirth: DBIRTH of %s" % name)


def check_stats(report, daemon):
    outs = [o for o in daemon.status().get("outputs", []) if o["type"] == "mqtt"]
    fig = outs[0]["figures"] if outs else {}
    report.check(fig.get("mqtt_connected") == 1 and fig.get("mqtt_births", 0) >= 4 and fig.get("mqtt_messages", 0) > 100,
                 "status shows the MQTT output (connected, births, messages)", str(fig))


def check_password_file(report, args, ws, bus, devices):
    pw = ws.path("password")
    with open(pw, "w") as f:
        f.write("secret\n")
    os.chmod(pw, 0o644)
    cfg = e2e.write_config(ws, [bus], devices, file_name="bad.toml",
                           extra='[outputs.mqtt]\nusername = "u"\npassword_file = "%s"\n' % pw)
    r = subprocess.run([args.daemon, "--check-config", cfg, "--plugin-dir", args.plugins], capture_output=True,
                       text=True, timeout=30)
    text = r.stdout + r.stderr
    report.check(r.returncode != 0 and "password_file" in text and "0644" in text,
                 "--check-config refuses a password file open to others, naming the key",
                 "exit %d: %r" % (r.returncode, text.strip()[-300:]))


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_mqtt_e2e")
    ws = e2e.Workspace("mqtt", args.keep)
    pb = compile_proto(ws, e2e.SOURCE_DIR)
    broker = Broker(ws)
    sub = Subscriber(pb)
    sim = daemon = None
    try:
        report.check(sub.connect(), "subscriber connected to the broker and subscribed")
        truth_path = ws.path("truth.txt")
        sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d,motion=%s" % (sm, s, n, mo)
                                                     for (_, _, sm, s, n, _, mo) in DEVICES]},
                            extra_args=("--truth", truth_path))
        bus = {"name": "line1", "interface": "vcan0", "lss_timeout_ms": 30, "sdo_timeout_ms": 200}
        devices = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
                    "tpdo1": {"mapping": mp, "transmission": 254, "event_timer_ms": 20}}
                   for (name, m, _, s, n, mp, _) in DEVICES]
        extra = ('[outputs.mqtt]\nhost = "127.0.0.1"\nport = %d\ngroup_id = "%s"\nedge_node_id = "%s"\n'
                 'keepalive_s = %d\nbdseq_file = "%s"\n' % (PORT, GROUP, EDGE, KEEPALIVE, ws.path("mqtt.bdseq")))
        extra += "[outputs.mqtt.metrics]\n" + "".join(
            '%s = [%s]\n' % (d, ", ".join('"%s"' % m for m in ms)) for d, ms in METRIC_SETS.items())
        daemon = e2e.Daemon(args.daemon, e2e.write_config(ws, [bus], devices, extra=extra), ws,
                            extra_args=("--plugin-dir", args.plugins))
        report.check(daemon.wait_socket(), "control socket up")
        names = [d[0] for d in DEVICES]
        _, took = daemon.wait_until(e2e.all_operational(names), 60, interval=0.1)
        if not report.check(took is not None, "three devices operational"):
            print(daemon.tail(60))
            return report.finish()
        births = check_births(report, sub, 0)
        if births is None:
            print(daemon.tail(60))
            return report.finish()
        bd_seq, aliases = births
        n_data = len(sub.all())
        time.sleep(3.0)
        time.sleep(0.5)  # the truth file is flushed every 100 ms
        check_values(report, sub, aliases, read_truth(truth_path), n_data)
        check_death_and_return(report, sub, sim, "ifm", 103)
        check_rebirth(report, sub, pb, bd_seq)
        check_stats(report, daemon)
        check_seq(report, sub.all())
        counts = {}
        for _, t, _p in sub.all():
            k = "/".join(t.split("/")[2:3] + t.split("/")[4:])
            counts[k] = counts.get(k, 0) + 1
        print("info messages by type and device: %s" % sorted(counts.items()), flush=True)

        n0 = len(sub.all())
        t_kill = time.time()
        daemon.proc.send_signal(signal.SIGKILL)
        daemon.proc.wait()
        i = sub.wait_for(lambda t, p: t == topic("NDEATH"), KEEPALIVE * 1.5 + 2, n0)
        took = (sub.all()[i][0] - t_kill) if i is not None else None
        report.check_bound(took is not None and took <= KEEPALIVE * 1.5,
                           "NDEATH (the will) within 1.5 x keepalive (%.1f s) of SIGKILL" % (KEEPALIVE * 1.5),
                           "%.2f s" % took if took is not None else "none")
        if i is not None:
            nd = sub.all()[i][2]
            report.check(nd is not None and metric(nd, "bdSeq") is not None and metric(nd, "bdSeq").long_value == bd_seq
                         and not nd.HasField("seq"), "NDEATH carries the NBIRTH's bdSeq and no seq")
        check_password_file(report, args, ws, bus, devices)
        if report.failed:
            print(daemon.tail(40))
    finally:
        sub.close()
        e2e.shut_down(ws, daemon, sim, broker)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
