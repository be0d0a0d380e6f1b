"""Issue 26, "commissioning at scale": N factory-fresh multiturn encoders
(cobridge-sim MC1-2800 at node-ID FFh, `node=unconfigured`) on one vcan at
250 kbit/s, each named in the configuration by serial and node-ID (revision
unknown), default bus settings otherwise. CiA 305 Fastscan + switch state
selective + configure node-ID + store; CiA 301 boot-up.

Asserts:
 * every device operational (none left behind: a failed LSS step is tried
   again, CommissionRetries);
 * each device's identity in status exactly as the simulator has it (vendor
   0x182, product 0x0BB8, revision 0x00010003, its serial) at its node-ID:
   a Fastscan result is verified before it is used;
 * no device commissioned twice (one "moved from non-configured" line each).
Prints the figures (FIGURE): daemon start -> all operational, the LSS
exchanges, timeouts and restarts of the Fastscans per device, the failed
tries; then a second start with every device remembered.

--count N: how many devices (8, and the issue's 32).
--lose-configure: every 4th device loses its first LSS configure node-ID
request (cobridge-sim `lose_configure=1`, issue 26's fault): each still ends
operational, its status counts the failed try (commission_failures >= 1) and
the log names it ("commissioning failed (try 1)").
"""
import sys
import time

import e2e

VENDOR = 0x182
PRODUCT = 0x0BB8      # MC1-2800 (E§4.1), what cobridge-sim reports
REVISION = 0x00010003
FIRST_SERIAL = 9001
FIRST_NODE = 20


def devices(count):
    return [("enc-%02d" % i, FIRST_SERIAL + i, FIRST_NODE + i) for i in range(count)]


def names_of(devs):
    return [d[0] for d in devs]


def config_for(ws, devs):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250}
    conf = [{"name": n, "bus": "line1", "serial": s, "model": "MC1-2800", "node_id": node, "heartbeat_ms": 100,
             "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 100}}
            for (n, s, node) in devs]
    return e2e.write_config(ws, [bus], conf)


def fastscan_steps(seen_steps):
    return [x for x in seen_steps.values() if x["step"].startswith("fastscan") and x["device"]]


def run_daemon(args, ws, config, names, limit, log_name, seen_steps=None):
    """Starts the daemon and polls its status until every device is
    operational. The status keeps the last 64 steps only: `seen_steps`
    collects every step seen on the way (keyed by step, device, at)."""
    daemon = e2e.Daemon(args.daemon, config, ws, log_name=log_name)
    daemon.wait_socket()
    done = e2e.all_operational(names)
    st, took = None, None
    end = time.time() + limit
    while time.time() < end and daemon.proc.poll() is None:
        try:
            st = daemon.status()
        except Exception:  # noqa: BLE001 (the socket between two polls)
            st = None
        if st is not None and seen_steps is not None:
            for x in (x for b in st["buses"] for x in b["steps"]):
                seen_steps[(x["step"], x["device"], x.get("at"))] = x
        if st is not None and done(st):
            took = time.time() - daemon.started
            break
        time.sleep(0.05)
    return daemon, st, took


def check_identities(report, st, devs):
    by_name = {d["name"]: d for b in st["buses"] for d in b["devices"]}
    wrong = []
    for (n, serial, node) in devs:
        d = by_name.get(n)
        want = {"vendor": VENDOR, "product": PRODUCT, "revision": REVISION, "serial": serial}
        if d is None or d["identity"] != want or d["node_id"] != node:
            wrong.append("%s: %s at %s" % (n, d["identity"] if d else None, d["node_id"] if d else None))
    report.check(not wrong, "every identity as the simulator has it, at its node-ID", "; ".join(wrong[:5]))


def check_once(report, daemon, devs):
    log = open(daemon.log_path).read()
    twice = [n for (n, _, _) in devs if log.count(" %s moved from non-configured" % n) != 1]
    report.check(not twice, "no device commissioned twice", "not once: " + ", ".join(twice[:8]))


def check_retried(report, st, daemon, lossy):
    """Issue 26, nobody left behind: the lost configure node-ID was tried again."""
    by_name = {d["name"]: d for b in st["buses"] for d in b["devices"]}
    log = open(daemon.log_path).read()
    missing = [n for (n, _, _) in lossy
               if by_name[n].get("commission_failures", 0) < 1 or "%s: commissioning failed (try 1)" % n not in log]
    report.check(not missing, "%d devices that lost a configure node-ID: tried again, counted in status and log"
                 % len(lossy), "not so: " + ", ".join(missing))
    # Operational now: no problem line says otherwise.
    stale = [p for b in st["buses"] for p in b["problems"] for (n, _, _) in lossy if n in p]
    report.check(not stale, "no stale problem line once they are operational", "; ".join(stale[:3]))


def figures(report, st, seen_steps, devs, took):
    steps = fastscan_steps(seen_steps)
    per = {}
    for x in steps:
        e = per.setdefault(x["device"], [0, 0, 0])
        e[0] += x.get("exchanges", 0)
        e[1] += x.get("timeouts", 0)
        e[2] += x.get("restarts", 0)
    ex = sorted(v[0] for v in per.values()) or [0]
    failures = sum(d.get("commission_failures", 0) for b in st["buses"] for d in b["devices"])
    print("FIGURE %d factory-fresh at FFh: start -> all operational %.2f s" % (len(devs), took))
    print("FIGURE Fastscan exchanges per device: min %d, median %d, max %d, total %d; timeouts %d; restarts %d"
          % (ex[0], ex[len(ex) // 2], ex[-1], sum(ex), sum(v[1] for v in per.values()),
             sum(v[2] for v in per.values())))
    lss = {}
    for x in seen_steps.values():
        if x["device"] in names_of(devs) and "exchanges" in x:
            lss[x["device"]] = lss.get(x["device"], 0) + x["exchanges"]
    tot = sorted(lss.values()) or [0]
    print("FIGURE LSS exchanges per device, every step (Fastscan, configure node-ID, store): median %d, max %d"
          % (tot[len(tot) // 2], tot[-1]))
    kinds = {}
    for x in seen_steps.values():
        k = x["step"].split(" ")[0]
        n, ms = kinds.get(k, (0, 0.0))
        kinds[k] = (n + 1, ms + x["ms"])
    print("FIGURE where the time goes: " + "; ".join("%s n=%d %.0f ms" % (k, n, ms)
                                                     for k, (n, ms) in sorted(kinds.items())))
    print("FIGURE failed commissioning tries (retried): %d" % failures)
    report.check(len(per) == len(devs), "every device found by a Fastscan of its own (status steps)",
                 "%d of %d" % (len(per), len(devs)))
    # Before issue 26: 16-22 of 32 Fastscans began again (a burst of answers
    # spilling into the next step); now none on a quiet machine, but a loaded
    # one (other builds beside UML) still makes answers late: 3-5 of 8 seen
    # on 2026-11-27. A figure, not a check: the checks above are what late
    # answers must never break.
    restarts = sum(v[2] for v in per.values())
    for x in sorted(steps, key=lambda x: x.get("at") or ""):
        if x.get("restarts", 0) or x.get("exchanges", 0) > 40:
            print("FIGURE long Fastscan: %s %s at %s: %d exchanges, %d timeouts, %d restarts, %.0f ms" % (
                x["step"], x["device"], x.get("at"), x["exchanges"], x.get("timeouts", 0), x.get("restarts", 0),
                x["ms"]))
    print("FIGURE Fastscans begun again after late answers: %d" % restarts)


def main():
    count = 8
    if "--count" in sys.argv:
        i = sys.argv.index("--count")
        count = int(sys.argv[i + 1])
        del sys.argv[i:i + 2]
    lose = "--lose-configure" in sys.argv
    if lose:
        sys.argv.remove("--lose-configure")
    args = e2e.parse_args()
    report = e2e.Report("test_commissioning_scale_%d" % count)
    ws = e2e.Workspace("commissioning-scale", args.keep)
    devs = devices(count)
    names = [d[0] for d in devs]
    lossy = [d for (i, d) in enumerate(devs) if lose and i % 4 == 0]
    specs = ["MC1-2800:serial=%d,node=unconfigured%s" % (s, ",lose_configure=1" if (n, s, node) in lossy else "")
             for (n, s, node) in devs]
    sim = e2e.Simulator(args.sim, ws, {"vcan0": specs})
    daemon = None
    try:
        config = config_for(ws, devs)
        seen_steps = {}
        daemon, st, took = run_daemon(args, ws, config, names, 60 + 4 * count, "daemon-1.log", seen_steps)
        report.check(took is not None, "%d factory-fresh devices operational" % count,
                     "%.2f s after start" % took if took else "never")
        if st is not None:
            check_identities(report, st, devs)
            check_once(report, daemon, devs)
            if lossy:
                check_retried(report, st, daemon, lossy)
            if took is not None:
                figures(report, st, seen_steps, devs, took)
        if report.failed:
            print(daemon.tail(80))
        e2e.check_clean_exit(report, daemon, "first start: SIGTERM -> exit 0 within 1 s")
        daemon = None
        daemon, st, took = run_daemon(args, ws, config, names, 30, "daemon-2.log")
        report.check(took is not None, "second start: all %d operational" % count,
                     "FIGURE second start -> all operational %.2f s" % took if took else "never")
        e2e.check_clean_exit(report, daemon, "second start: SIGTERM -> exit 0 within 1 s")
        daemon = None
    finally:
        e2e.shut_down(ws, daemon, sim)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
