"""Bus health from the controller (docs/operations.md "CAN controller
health"; Linux can.rst "Network Problem Notifications"): the daemon turns
the bus's CAN error frames into the controller's fault confinement state,
its error counters and its restarts, in `cobridge status` (JSON and text)
and /metrics, and logs each change of state once.

vcan has no controller; the simulator injects the error frames a real
adapter's driver sends (`bus-error vcan0 KIND`: CAN_ERR_CRTL with
CAN_ERR_CNT counters, CAN_ERR_BUSOFF, CAN_ERR_RESTARTED).
Runs inside UML:
  tests/vcan/run-in-vcan -- /usr/bin/python3 tests/vcan/daemon/test_bus_health.py --daemon ...
"""
import http.client
import subprocess
import time

import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10)]
WEB_PORT = 8093


def controller(daemon):
    try:
        return daemon.status()["buses"][0]["controller"]
    except (OSError, ValueError, KeyError):
        return None


def wait_state(daemon, state, timeout=5):
    end = time.time() + timeout
    c = None
    while time.time() < end:
        c = controller(daemon)
        if c and c["state"] == state:
            return c
        time.sleep(0.05)
    return c


def metrics():
    conn = http.client.HTTPConnection("127.0.0.1", WEB_PORT, timeout=5)
    conn.request("GET", "/metrics")
    text = conn.getresponse().read().decode()
    conn.close()
    return text


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_bus_health")
    ws = e2e.Workspace("bus-health", args.keep, base="/run")
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 3600}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": nid, "heartbeat_ms": 100}
               for (n, m, _, s, nid) in DEVICES]
    cfg = e2e.write_config(ws, [bus], devices, extra='[web]\nbind = "127.0.0.1"\nport = %d\n' % WEB_PORT)
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d" % (sm, s, n) for (_, _, sm, s, n) in DEVICES]})
    daemon = e2e.Daemon(args.daemon, cfg, ws)
    try:
        report.check(daemon.wait_socket(), "daemon up")
        c = controller(daemon)
        report.check(c is not None and c["state"] == "error-active" and c["tx_errors"] is None,
                     "before any error frame: error-active, counters unknown", str(c))
        steps = [("error-warning", "error-warning", 96), ("error-passive", "error-passive", 128),
                 ("bus-off", "bus-off", None), ("restarted", "error-active", None)]
        for kind, state, tx in steps:
            reply = sim.command("bus-error vcan0 %s" % kind)
            c = wait_state(daemon, state)
            ok = c is not None and c["state"] == state and (tx is None or c["tx_errors"] == tx)
            report.check(ok, "error frame %s -> status controller %s%s" % (
                kind, state, "" if tx is None else ", tx errors %d" % tx), "%s / sim: %s" % (c, reply))
        report.check(c is not None and c["restarts"] == 1, "the restart after bus-off is counted", str(c))
        log = open(daemon.log_path).read()
        changes = [l for l in log.splitlines() if "CAN controller " in l and " -> " in l]
        report.check(len(changes) == 4 and "error-passive -> bus-off" in " ".join(changes),
                     "each change of state logged once, from -> to", "\n".join(changes))
        rc, out, _ = e2e.run_cli(args.cli, "status", "--control", ws.control)
        report.check(rc == 0, "cobridge status (text) runs", out[:200])
        sim.command("bus-error vcan0 error-passive")
        wait_state(daemon, "error-passive")
        rc, out, _ = e2e.run_cli(args.cli, "status", "--control", ws.control)
        report.check(rc == 0 and "CAN controller error-passive (tx errors 128" in out,
                     "cobridge status (text) shows a controller that is not error-active", out[:300])
        time.sleep(0.5)  # the web service's snapshot
        m = metrics()
        r = subprocess.run(["promtool", "check", "metrics"], input=m.encode(), capture_output=True)
        report.check(r.returncode == 0, "/metrics passes promtool", (r.stdout + r.stderr).decode()[:200])
        report.check('cobridge_bus_controller_state{bus="line1",state="error-passive"} 1' in m and
                     'cobridge_bus_controller_errors{bus="line1",direction="tx"} 128' in m and
                     'cobridge_bus_controller_restarts_total{bus="line1"} 1' in m,
                     "/metrics: controller state, error counters and restarts",
                     "\n".join(l for l in m.splitlines() if "controller" in l or "error_counter" in l)[:400])
        _, up = daemon.wait_until(e2e.all_operational([d[0] for d in DEVICES]), 10, interval=0.05)
        report.check(up is not None, "the device stays operational (vcan: nothing was really lost)")
    finally:
        daemon.stop()
        sim.stop()
        ws.cleanup()
    return report.finish()


if __name__ == "__main__":
    raise SystemExit(main())
