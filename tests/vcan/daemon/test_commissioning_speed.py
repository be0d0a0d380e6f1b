"""Commissioning at wire speed: the real daemon and cobridge-sim on
vcan (UML). Prints the figures of its targets and asserts the LSS
exchange and silent-step counts (CiA 305 Fastscan), not the times.

 1. Six factory-fresh devices of the three families: two rotary encoders
    clashing at 127 (J§1.2.2), two ifm at 32 (F§7.1), two multiturn at FFh
    (CiA 305 non-configured, E§6). Each multiturn is found by a Fastscan
    guided by the configuration: vendor, product and serial confirmed whole
    (BitChecked 0), only the revision searched (one field unknown).
    Figure: daemon start -> all six operational (target 3 s).
 2. Second start, same bus: no Fastscan at all; all operational (target 0.5 s).
 3. The two multiturns factory-fresh again at FFh, their whole identity
    remembered (state file: product, revision): each is confirmed in 5
    exchanges with no silent step (target <= 50 ms per device).
"""
import sys
import time

import e2e

DEVICES = [
    # name, config model, sim device, serial, node-ID
    ("rot-a", "RFC-4800", "RFC-4800:serial=1001", 1001, 10),
    ("rot-b", "RFC-4800", "RFC-4800:serial=1002", 1002, 11),
    ("mt-a", "MC1-2800", "MC1-2800:serial=2001,node=unconfigured", 2001, 20),
    ("mt-b", "MC1-2800", "MC1-2800:serial=2002,node=unconfigured", 2002, 21),
    ("ifm-a", "RM9", "RM9000:serial=3001,bitrate=250", 3001, 30),
    ("ifm-b", "RM9", "RM9000:serial=3002,bitrate=250", 3002, 31),
]
MT_REVISION = 0x00010003  # E§4.1, what cobridge-sim reports
LSS_MASTER = 0x7E5
LSS_FASTSCAN = 0x51


def config_for(ws, names, lss_floor_ms=None):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30, "node_pool": "40-60"}
    if lss_floor_ms is not None:
        bus["lss_timeout_min_ms"] = lss_floor_ms
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": node, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 100}}
               for (n, m, _, s, node) in DEVICES if n in names]
    return e2e.write_config(ws, [bus], devices)


def fastscans(status):
    return [x for b in status["buses"] for x in b["steps"] if x["step"].startswith("fastscan") and x["device"]]


def describe(steps):
    return "; ".join("%s %s: %d exchanges, %d timeouts, %d restarts, %.1f ms" % (
        x["step"], x["device"], x.get("exchanges", 0), x.get("timeouts", 0), x.get("restarts", 0), x["ms"])
        for x in steps)


def fastscan_runs(listener, since):
    return len([f for f in listener.snapshot(since) if f[1] == LSS_MASTER and f[2][0] == LSS_FASTSCAN
                and f[2][5] == 0x80])


def fastscan_fields_searched(listener, since):
    """LSSSub of every Fastscan the master sent with a bit to check
    (BitChecked 1..31: a bit search step; 0 ends a field, 80h resets),
    CiA 305 clause 8.3.4."""
    return {f[2][6] for f in listener.snapshot(since) if f[1] == LSS_MASTER and f[2][0] == LSS_FASTSCAN
            and 0 < f[2][5] < 0x80}


def start(args, ws, config, report, label, names, log_name):
    daemon = e2e.Daemon(args.daemon, config, ws, log_name=log_name)
    report.check(daemon.wait_socket(), "%s: control socket up" % label)
    st, _ = daemon.wait_until(e2e.all_operational(names), 60, interval=0.02)
    took = time.time() - daemon.started if st is not None and e2e.all_operational(names)(st) else None
    return daemon, daemon.status() if daemon.proc.poll() is None else None, took


def six_fresh(args, ws, report, listener):
    names = [d[0] for d in DEVICES]
    config = config_for(ws, names)
    since = time.time()
    daemon, st, took = start(args, ws, config, report, "six fresh", names, "daemon-1.log")
    report.check(took is not None, "six factory-fresh devices operational",
                 "FIGURE six-fresh start -> all operational %.2f s (target 3 s)" % took if took else "never")
    steps = [x for x in fastscans(st) if x["device"] in ("mt-a", "mt-b")] if st else []
    # Guided (CiA 305 Fastscan with what the configuration knows): vendor
    # and product confirmed whole (BitChecked 0), never searched bit by bit;
    # the revision, the one field unknown, searched. The bus shows it, so
    # the verdict does not hang on how many answers a loaded host took for
    # late (each late one costs a wrong guess, a field search or a restart;
    # the exchange counts are printed as the figure). Unguided: 133.
    fields = fastscan_fields_searched(listener, since)
    report.check(len(steps) >= 2 and 0 not in fields and 1 not in fields and 2 in fields,
                 "each multiturn at FFh found by a guided Fastscan (vendor, product confirmed whole; revision searched)",
                 "fields searched bit by bit: %s; FIGURE one field unknown: %s" % (sorted(fields), describe(steps)))
    if report.failed:
        print(daemon.tail(60))
    e2e.check_clean_exit(report, daemon, "six fresh: SIGTERM -> exit 0 within 1 s")
    return names, config


def second_start(args, ws, report, listener, names, config):
    since = time.time()
    daemon, st, took = start(args, ws, config, report, "second start", names, "daemon-2.log")
    report.check(took is not None, "second start: all six operational",
                 "FIGURE second start -> all operational %.2f s (target 0.5 s)" % took if took else "never")
    runs = fastscan_runs(listener, since)
    report.check(runs == 0, "second start: no Fastscan (identities remembered)", "%d Fastscan runs" % runs)
    e2e.check_clean_exit(report, daemon, "second start: SIGTERM -> exit 0 within 1 s")


def whole_identity_known(args, ws, report, listener):
    names = ["mt-a", "mt-b"]
    sim_ws = e2e.Workspace("speed-sim-2", args.keep)
    sim = e2e.Simulator(args.sim, sim_ws, {"vcan0": [d[2] for d in DEVICES if d[0] in names]})
    daemon = None
    try:
        # A confirmed identity waits out no silence when every answer comes in
        # time, so the floor of the learnt waits does not change the figure;
        # raised from 10 to 50 ms it keeps one answer the guest's scheduler
        # held back 10-50 ms (a CI run on UML: 17 timeouts and a restart
        # after one) from being taken for silence. The default floor's cost
        # of such an answer is what six_fresh's figures show.
        config = config_for(ws, names, lss_floor_ms=50)
        daemon, st, took = start(args, ws, config, report, "known at FFh", names, "daemon-3.log")
        report.check(took is not None, "factory-fresh multiturns with remembered identities operational",
                     "%.2f s after start" % took if took else "never")
        steps = [x for x in fastscans(st) if x["device"] in names] if st else []
        # 5 exchanges confirm it, a 6th (switch selective) verifies it.
        report.check(len(steps) >= 2 and all(x["exchanges"] == 6 and x["timeouts"] == 0 for x in steps),
                     "whole identity known: confirmed and verified in 6 exchanges, no timeout",
                     "FIGURE whole identity at FFh: " + describe(steps) + " (target 50 ms)")
        if report.failed:
            print(daemon.tail(60))
        e2e.check_clean_exit(report, daemon, "known at FFh: SIGTERM -> exit 0 within 1 s")
        daemon = None
    finally:
        e2e.shut_down(sim_ws, daemon, sim)


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_commissioning_speed")
    ws = e2e.Workspace("commissioning-speed", args.keep)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": [d[2] for d in DEVICES]})
    try:
        names, config = six_fresh(args, ws, report, listener)
        second_start(args, ws, report, listener, names, config)
        sim.stop()
        whole_identity_known(args, ws, report, listener)
    finally:
        e2e.shut_down(ws, None, sim, listener)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
