"""Three models, two devices each, all at their
factory node-IDs (the two Novotechnik devices of a series clash at 127, both
series share 127, the ifm pair clashes at 32): cobridged detects the clashes,
commissions the bus (J§1.9 / CiA 305 switch selective and Slowscan for the
rotary series, CiA 305 Fastscan for the multiturn series and ifm), assigns
node-IDs per the config by serial, configures, verifies, stores and starts
all six; `cobridge status` shows them online at their node-IDs. A second
daemon start finds them without Fastscan and without rewriting their
settings (fingerprint matched: no plan with writes, no 'save' to 0x1010).
"""
import sys
import time

import e2e

DEVICES = [
    # name, config model, sim model, serial, node-ID
    ("rot-a", "RFC-4800", "RFC-4800", 1001, 10),
    ("rot-b", "RFC-4800", "RFC-4800", 1002, 11),
    ("mt-a", "MC1-2800", "MC1-2800", 2001, 20),
    ("mt-b", "MC1-2800", "MC1-2800", 2002, 21),
    ("ifm-a", "RM9", "RM9000", 3001, 30),
    ("ifm-b", "RM9", "RM9000", 3002, 31),
]
NAMES = [d[0] for d in DEVICES]

LSS_MASTER = 0x7E5
LSS_FASTSCAN = 0x51


def config_for(ws):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery": True, "discovery_period_s": 30,
           "node_pool": "40-60", "commissioning": "automatic", "swap_policy": "same-model"}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": node, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 100}}
               for (n, m, _, s, node) in DEVICES]
    return e2e.write_config(ws, [bus], devices)


def sim_devices(serial_map=None):
    out = []
    for (_, _, sim_model, serial, _) in DEVICES:
        serial = (serial_map or {}).get(serial, serial)
        extra = ",bitrate=250" if sim_model.startswith("RM") else ""
        out.append("%s:serial=%d%s" % (sim_model, serial, extra))
    return out


def commission_all(args, ws, report, listener, timeout=180):
    """Starts the daemon on the six factory-fresh devices and waits until all
    are operational. Returns (daemon, seconds) or (daemon, None)."""
    config = config_for(ws)
    daemon = e2e.Daemon(args.daemon, config, ws, log_name="daemon-1.log")
    report.check(daemon.wait_socket(), "first start: control socket up")
    status, took = daemon.wait_until(e2e.all_operational(NAMES), timeout, interval=0.25)
    return daemon, status, took


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_commissioning")
    ws = e2e.Workspace("commissioning", args.keep)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": sim_devices()})
    daemon = None
    with e2e.shut_down_after(ws, lambda: (daemon, sim, listener)):
        t0 = time.time()
        daemon, status, took = commission_all(args, ws, report, listener)
        if not report.check(took is not None, "all six commissioned, configured and operational",
                            "%.1f s" % took if took else "timeout; last status: %s" % status):
            print(daemon.tail(80))

        # `cobridge status --json` through the CLI, as an operator would.
        rc, out, err = e2e.run_cli(args.cli, "status", "--control", ws.control, "--json")
        report.check(rc == 0, "cobridge status --json exits 0", err.strip())
        doc = None
        try:
            import json
            doc = json.loads(out)
        except ValueError as e:
            report.check(False, "cobridge status --json is JSON", str(e))
        if doc:
            devs = {d["name"]: d for b in doc["buses"] for d in b["devices"]}
            for (n, _, _, serial, node) in DEVICES:
                d = devs.get(n)
                ok = d is not None and d["node_id"] == node and d["state"] == "operational" and d["online"] and \
                    d["identity"]["serial"] == serial
                report.check(ok, "status: %s serial %d operational, online at node %d" % (n, serial, node),
                             "" if ok else repr(d))
            steps = [(s["step"], s["device"], s["ms"]) for b in doc["buses"] for s in b["steps"]]
            print("step timings (first start):")
            for s in steps:
                print("  %-28s %-10s %9.1f ms" % s)
            report.check(len(steps) > 0, "status reports the timed commissioning steps", "%d steps" % len(steps))
            # The timeline tells each device's way here: the LSS assignment (CiA 305), the
            # plan that configured it (values written and verified), the entry into operational.
            for (n, _, _, serial, node) in DEVICES:
                tl = (devs.get(n) or {}).get("timeline") or []
                kinds = [e["kind"] for e in tl]
                lss = [e for e in tl if e["kind"] == "lss" and str(node) in e["text"]]
                done = [e for e in tl if e["kind"] == "configured" and "written and verified" in e["text"]]
                up = [e for e in tl if e["kind"] == "state" and e["text"].endswith("-> operational: configured and started")]
                report.check(lss and done and up, "timeline of %s: its node-ID assignment, its configuration, operational"
                             % n, repr(kinds) if not (lss and done and up) else lss[-1]["text"])
            problems = [p for b in doc["buses"] for p in b["problems"]]
            print("problems reported: %s" % problems)

        rc, out, err = e2e.run_cli(args.cli, "status", "--control", ws.control)
        report.check(rc == 0 and all(n in out for n in NAMES), "cobridge status table names all six devices",
                     err.strip())
        print(out)

        fastscans_first = [f for f in listener.snapshot(t0) if f[1] == LSS_MASTER and f[2][:1] == bytes([LSS_FASTSCAN])]
        print("first start: %d LSS Fastscan frames" % len(fastscans_first))

        rc, took = daemon.stop()
        report.check(rc == 0, "first daemon: SIGTERM -> exit 0", "exit %s after %.3f s" % (rc, took))

        # Second start on the same state directory: no scan, no rewrite.
        t1 = time.time()
        daemon = e2e.Daemon(args.daemon, config_for(ws), ws, log_name="daemon-2.log")
        report.check(daemon.wait_socket(), "second start: control socket up")
        status, took2 = daemon.wait_until(e2e.all_operational(NAMES), 60, interval=0.1)
        if not report.check(took2 is not None, "second start: all six operational",
                            "%.2f s" % took2 if took2 else "timeout; last status: %s" % status):
            print(daemon.tail(80))
        time.sleep(1.0)  # let a late start-up scan show itself
        # The start-up window only: periodic discovery (every 30 s) is another matter.
        t_end = t1 + (took2 or 60) + 1.0
        frames = [f for f in listener.snapshot(t1) if f[0] <= t_end]
        fastscans = [f for f in frames if f[1] == LSS_MASTER and f[2][:1] == bytes([LSS_FASTSCAN])]
        lss_any = [f for f in frames if f[1] == LSS_MASTER]
        report.check(not fastscans, "second start: no LSS Fastscan (CiA 305 §8.3.4) on the bus",
                     "%d Fastscan frames, %d LSS frames" % (len(fastscans), len(lss_any)))
        # SDO initiate download requests (CiA 301 §7.2.4.3.3: ccs = 1) to the devices.
        downloads = [f for f in frames if 0x601 <= f[1] <= 0x67F and f[2] and (f[2][0] >> 5) == 1]
        stores = [f for f in downloads if len(f[2]) >= 4 and f[2][1] == 0x10 and f[2][2] == 0x10]
        report.check(not stores, "second start: no 'save' to 0x1010 (no flash write)", "%d store writes" % len(stores))
        # Every device remembered and configured as asked, so a
        # second start writes nothing at all (reads only, to verify).
        report.check(not downloads, "second start: 0 SDO download requests (nothing written)",
                     "%d downloads, first: %s" % (len(downloads), [(hex(f[1]), f[2].hex()) for f in downloads[:3]]))
        if status:
            devs = {d["name"]: d for b in status["buses"] for d in b["devices"]}
            for n in NAMES:
                d = devs.get(n, {})
                report.check(d.get("configurations") == 0,
                             "second start: %s not rewritten (0 configurations with writes, fingerprint %s)" %
                             (n, d.get("fingerprint") or "-"), "configurations=%s" % d.get("configurations"))
            steps = [(s["step"], s["device"], s["ms"]) for b in status["buses"] for s in b["steps"]]
            print("step timings (second start):")
            for s in steps:
                print("  %-28s %-10s %9.1f ms" % s)
        e2e.check_clean_exit(report, daemon, "second daemon: SIGTERM -> exit 0 within 1 s")
        daemon = None
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
