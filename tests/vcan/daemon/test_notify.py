"""The sd_notify exchange (sd_notify(3)) against a
notify socket the test holds, as systemd would with Type=notify,
NotifyAccess=main and WatchdogSec=: READY=1 once the known devices are
configured, STATUS= with device counts (and the buses waiting for their
interface), WATCHDOG=1 every WATCHDOG_USEC/2
while every bus thread runs (a down interface does not stop it), RELOADING=1 then READY=1 on SIGHUP (also
when the new file is bad: rejected, the old configuration kept), STOPPING=1
on SIGTERM and exit 0 within 1 s. Devices sit at their configured node-IDs,
so nothing needs commissioning.
"""
import os
import signal
import subprocess
import sys
import time

import e2e

WATCHDOG_USEC = 1000000  # pings expected every 0.5 s


def write(ws, bad=False):
    buses = [{"name": "line1", "interface": "vcan0", "discovery_period_s": 30, "node_pool": "40-60"},
             {"name": "line2", "interface": "vcan1", "discovery_period_s": 30, "node_pool": "40-60"}]
    devices = [{"name": "rot-a", "bus": "line1", "serial": 1001, "model": "RFC-4800", "node_id": 10,
                "heartbeat_ms": 100},
               {"name": "mt-a", "bus": "line2", "serial": 2001, "model": "MC1-2800", "node_id": 20,
                "heartbeat_ms": 100}]
    if bad:
        devices[0]["node_id"] = 200  # CiA 301 §7.5.2: node-IDs are 1..127
    return e2e.write_config(ws, buses, devices)


def deep_sighup(report, daemon, notify, ws):
    path = write(ws)
    with open(path, "a") as f:
        f.write("\n" + ".".join(["a"] * 100000) + " = 1\n")
    n = len(notify.all())
    daemon.proc.send_signal(signal.SIGHUP)
    rejected = notify.wait_for(lambda m: m.startswith("STATUS=") and "reload rejected" in m, 5, after_index=n)
    rdy = notify.wait_for(lambda m: "READY=1" in m.split("\n"), 5, after_index=n)
    time.sleep(0.3)
    alive = daemon.proc.poll() is None
    report.check(alive and rejected is not None and rdy is not None,
                 "deep dotted key on SIGHUP: the daemon runs on, READY=1, STATUS= says rejected",
                 "exit %s; %s" % (daemon.proc.poll(), rejected[2] if rejected else notify.all()[n:]))
    if alive:
        devs = {d["name"]: d for b in daemon.status()["buses"] for d in b["devices"]}
        report.check(devs.get("rot-a", {}).get("node_id") == 10 and devs.get("mt-a", {}).get("state") == "operational",
                     "deep dotted key on SIGHUP: still running the old configuration")
    with open(daemon.log_path) as f:
        log = f.read()
    report.check("%s:" % path in log and "key nested more than 32 levels deep" in log,
                 "deep dotted key on SIGHUP: the error is logged with file:line:col and the limit",
                 "; ".join(l for l in log.splitlines() if "nested" in l)[-300:])


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_notify")
    ws = e2e.Workspace("notify", args.keep)
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["RFC-4800:serial=1001,node=10"],
                                       "vcan1": ["MC1-2800:serial=2001,node=20"]})
    notify = e2e.NotifySocket(ws)
    config = write(ws)
    daemon = e2e.Daemon(args.daemon, config, ws, notify=notify, watchdog_usec=WATCHDOG_USEC)
    try:
        t0 = time.time()
        ready = notify.wait_for(lambda m: "READY=1" in m.split("\n"), 60)
        if not report.check(ready is not None, "READY=1", "%.2f s after start" % (ready[1] - t0) if ready else
                            "none; got %s" % notify.all()):
            print(daemon.tail())
        st = daemon.status()
        ops = sum(1 for b in st["buses"] for d in b["devices"] if d["state"] == "operational")
        report.check(ops == 2 or not ready, "READY=1 came once the known devices were configured",
                     "%d/2 operational at READY" % ops)
        status_msg = notify.wait_for(lambda m: m.startswith("STATUS=") and "2/2 devices operational" in m, 10)
        report.check(status_msg is not None, "STATUS= with device counts",
                     status_msg[2] if status_msg else "got %s" % [m for _, m in notify.all() if "STATUS" in m])

        # Watchdog: pings at half of WATCHDOG_USEC, from the daemon's own PID.
        time.sleep(2.2)
        pings = [t for t, m in notify.all() if m == "WATCHDOG=1" and t > t0]
        gaps = [b - a for a, b in zip(pings, pings[1:])]
        report.check(len(pings) >= 4 and all(g < 0.75 for g in gaps[-4:]), "WATCHDOG=1 every WATCHDOG_USEC/2",
                     "%d pings, last gaps %s s" % (len(pings), ["%.2f" % g for g in gaps[-4:]]))

        # A bus whose interface is down is reported, not a reason to be restarted: the
        # pings go on (the other bus is served) and STATUS= names it.
        subprocess.run(["ip", "link", "set", "vcan1", "down"], check=True)
        time.sleep(0.6)  # the daemon notices the interface going down
        t_down = time.time()
        time.sleep(1.5)
        during = [t for t, m in notify.all() if m == "WATCHDOG=1" and t > t_down]
        waiting = [m for t, m in notify.all() if m.startswith("STATUS=") and "waiting for" in m and "vcan1" in m]
        # Counted before the link comes up: the daemon may tell STATUS= (once,
        # on the change) before this script runs its next line.
        before_up = len(notify.all())
        subprocess.run(["ip", "link", "set", "vcan1", "up"], check=True)
        t_up = time.time()
        report.check(len(during) >= 2, "WATCHDOG=1 goes on while vcan1 is down (vcan0 still served)",
                     "%d pings" % len(during))
        report.check(bool(waiting), "STATUS= names the bus waiting for its interface",
                     waiting[-1] if waiting else "none")
        back = notify.wait_for(lambda m: m.startswith("STATUS=") and "waiting" not in m, 10,
                               after_index=before_up)
        report.check(back is not None, "STATUS= without the waiting bus once vcan1 is back",
                     "%.2f s after ip link up" % (back[1] - t_up) if back else "none")

        # SIGHUP with a good file: RELOADING=1 then READY=1, buses kept open.
        n = len(notify.all())
        rx_before = daemon.status()["buses"][0]["counters"]["reopens"]
        daemon.proc.send_signal(signal.SIGHUP)
        rel = notify.wait_for(lambda m: m.startswith("RELOADING=1"), 5, after_index=n)
        report.check(rel is not None and "MONOTONIC_USEC=" in rel[2], "SIGHUP -> RELOADING=1 (with MONOTONIC_USEC)",
                     repr(rel[2]) if rel else "none")
        rdy = notify.wait_for(lambda m: "READY=1" in m.split("\n"), 5, after_index=(rel[0] + 1) if rel else n)
        report.check(rdy is not None, "after the reload: READY=1",
                     "%.3f s after RELOADING" % (rdy[1] - rel[1]) if rdy and rel else "none")
        st = daemon.status()
        report.check(st["buses"][0]["counters"]["reopens"] == rx_before and st["buses"][0]["open"],
                     "the reload did not close the bus")

        # SIGHUP with a bad file: rejected, the old configuration kept.
        write(ws, bad=True)
        n = len(notify.all())
        daemon.proc.send_signal(signal.SIGHUP)
        rel = notify.wait_for(lambda m: m.startswith("RELOADING=1"), 5, after_index=n)
        rdy = notify.wait_for(lambda m: "READY=1" in m.split("\n"), 5, after_index=(rel[0] + 1) if rel else n)
        rejected = notify.wait_for(lambda m: m.startswith("STATUS=") and "reload rejected" in m, 5, after_index=n)
        report.check(rel is not None and rdy is not None and rejected is not None,
                     "bad file on SIGHUP: RELOADING=1, READY=1, STATUS= says rejected",
                     rejected[2] if rejected else "%s" % notify.all()[n:])
        time.sleep(0.3)
        st = daemon.status()
        devs = {d["name"]: d for b in st["buses"] for d in b["devices"]}
        report.check(daemon.proc.poll() is None and devs.get("rot-a", {}).get("node_id") == 10,
                     "bad file on SIGHUP: daemon still running the old configuration")
        with open(daemon.log_path) as f:
            log = f.read()
        report.check("node_id 200 is out of range" in log, "bad file on SIGHUP: the error is logged with its place")

        # A file with a dotted key 100 000 levels deep swapped in must not
        # crash the daemon on SIGHUP (toml++ recurses per segment). Rejected
        # like any bad file: the old configuration kept, the error logged.
        deep_sighup(report, daemon, notify, ws)
        write(ws)

        # SIGTERM: STOPPING=1 and exit 0 within 1 s.
        n = len(notify.all())
        rc, took = daemon.stop(signal.SIGTERM)
        stop = notify.wait_for(lambda m: m == "STOPPING=1", 1, after_index=n)
        report.check(stop is not None, "SIGTERM -> STOPPING=1")
        report.check(rc == 0 and took < 1.0, "SIGTERM -> exit 0 within 1 s", "exit %s after %.3f s" % (rc, took))
        report.check(not os.path.exists(ws.control), "control socket removed on exit")
        daemon = None
    finally:
        e2e.shut_down(ws, daemon, notify, sim)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
