"""Commissioning, the bus of the main job (scripts/main-job-in-vcan): a
mixed three-way clash at node-ID 127 (J§1.2.2 / E§3.1: every Novotechnik
ships at 127) of two rotary RFC-4800 (J, DSP-305 V1.1.2: switch selective and
identify remote slave, no Fastscan) and one multiturn MC1-2800 (E§6, CiA 305
V3), plus an ifm RM9000 alone at its factory node-ID 32 (F§5.3.1). The
config gives serial + model only (vendor/product come from the model, the
revision from the probe answers) and short timeouts (lss_timeout_ms = 30,
sdo_timeout_ms = 200). cobridged must move all four to their configured
node-IDs (CiA 305 switch selective / Slowscan / Fastscan, configure node-ID,
store) and bring them to operational; afterwards nobody may be left at 127
(a CiA 301 SDO upload of 0x1018 to node 127 gets no answer) and the log must
not call the clash resolved while devices still answer there.
"""
import socket
import struct
import sys
import time

import e2e

DEVICES = [
    # name, config model, sim model, serial, node-ID
    ("turntable", "RFC-4800", "RFC-4800", 1001, 10),
    ("swing-arm", "RFC-4800", "RFC-4800", 1002, 11),
    ("hoist", "MC1-2800", "MC1-2800", 2001, 20),
    ("conveyor", "RM9000", "RM9000", 3001, 30),
]
NAMES = [d[0] for d in DEVICES]


def config_for(ws):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "node_pool": "40-60",
           "commissioning": "automatic", "lss_timeout_ms": 30, "sdo_timeout_ms": 200}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": node, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position", "speed"], "transmission": "event", "event_timer_ms": 10}}
               for (n, m, _, s, node) in DEVICES]
    return e2e.write_config(ws, [bus], devices)


def sim_devices():
    out = []
    for (_, _, sim_model, serial, _) in DEVICES:
        extra = ",bitrate=250" if sim_model.startswith("RM") else ""
        out.append("%s:serial=%d%s" % (sim_model, serial, extra))
    return out


def answers_at(node, timeout=0.3):
    """CiA 301 §7.2.4.3.6 SDO upload of 0x1018/4 (serial) to `node`: the
    serials that answer within `timeout` (several = a clash)."""
    s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    s.bind(("vcan0",))
    s.settimeout(0.02)
    req = struct.pack("<IB3x8s", 0x600 + node, 8, bytes([0x40, 0x18, 0x10, 0x04, 0, 0, 0, 0]))
    s.send(req)
    seen = set()
    end = time.time() + timeout
    while time.time() < end:
        try:
            raw = s.recv(16)
        except socket.timeout:
            continue
        can_id, dlc, data = struct.unpack("<IB3x8s", raw)
        if can_id == 0x580 + node and data[0] == 0x43 and data[1:4] == bytes([0x18, 0x10, 0x04]):
            seen.add(struct.unpack("<I", data[4:8])[0])
    s.close()
    return seen


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_mixed_clash")
    ws = e2e.Workspace("mixed-clash", args.keep)
    sim = e2e.Simulator(args.sim, ws, {"vcan0": sim_devices()})
    daemon = None
    try:
        daemon = e2e.Daemon(args.daemon, config_for(ws), ws)
        report.check(daemon.wait_socket(), "control socket up")
        status, took = daemon.wait_until(e2e.all_operational(NAMES), 120, interval=0.25)
        if not report.check(took is not None, "all four commissioned, configured and operational",
                            "%.1f s" % took if took else "timeout; last status: %s" % status):
            print(daemon.tail(120))
        if status:
            devs = {d["name"]: d for b in status["buses"] for d in b["devices"]}
            for (n, _, _, serial, node) in DEVICES:
                d = devs.get(n)
                ok = d is not None and d["node_id"] == node and d["state"] == "operational" and d["online"] and \
                    d["identity"]["serial"] == serial
                report.check(ok, "status: %s serial %d operational, online at node %d" % (n, serial, node),
                             "" if ok else repr(d))
            steps = [(s["step"], s["device"], s["ms"]) for b in status["buses"] for s in b["steps"]]
            print("step timings:")
            for s in steps:
                print("  %-28s %-10s %9.1f ms" % s)
            problems = [p for b in status["buses"] for p in b["problems"]]
            print("problems reported: %s" % problems)
            report.check(not any("could not be resolved" in str(p) for p in problems),
                         "no 'clash could not be resolved' problem")
            # "Status tells the truth": a resolved clash leaves the problem list.
            report.check(not any("answer at node" in str(p) for p in problems),
                         "resolved clashes are no longer listed as problems", "%s" % problems)
        left = answers_at(127)
        report.check(not left, "nobody answers at node 127 any more (SDO upload 0x1018/4)",
                     "serials %s" % sorted(left) if left else "")
        left32 = answers_at(32)
        report.check(not left32, "nobody answers at node 32 any more", "serials %s" % sorted(left32) if left32 else "")
        with open(daemon.log_path) as f:
            log = f.read()
        print("daemon log, discovery lines:")
        for line in log.splitlines():
            if any(w in line for w in ("clash", "moved from", "answer at node", "problem", "resolved")):
                print("  " + line)
        report.check("3 devices answer at node 127" in log, "log: the three-way clash at 127 was detected")
        report.check("clash at node 127 resolved" in log, "log: the clash at 127 is reported resolved")
        # Resolved comes after every device left 127 (each `moved from node 127` line precedes it).
        i_resolved = log.find("clash at node 127 resolved")
        for n in ("turntable", "swing-arm", "hoist"):
            i = log.find("%s moved from node 127" % n)
            report.check(i >= 0 and (i_resolved < 0 or i < i_resolved),
                         "log: %s moved from node 127 before the clash is called resolved" % n)
        rc, took = daemon.stop()
        report.check(rc == 0, "SIGTERM -> exit 0", "exit %s after %.3f s" % (rc, took))
        daemon = None
    finally:
        if daemon is not None:
            print(daemon.tail(60))
            daemon.stop()
        sim.stop()
        ws.cleanup()
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
