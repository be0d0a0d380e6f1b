"""Bus health from the controller (docs/operations.md "CAN controller
health"; Linux can.rst "Network Problem Notifications" and "Netlink
interface"): the daemon turns the bus's CAN error frames into the
controller's fault confinement state, its error counters and its restarts,
in `cobridge status` (JSON and text), /metrics and the Modbus registers
(docs/modbus.md bus block +3, controller block; plugin ABI 5 on_bus), and
logs each change of state once. vcan's driver gives no IFLA_CAN data over
netlink: the status says so and shows the state unknown, not invented,
until error frames arrive.

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
MODBUS_PORT = 1504
BUS_BLOCK = 16           # bus 0's block; +3 controller_state (docs/modbus.md)
CONTROLLER_BLOCK = 144   # bus 0's controller block: tx_errors, rx_errors, restarts (u32)
MODBUS_STATE = {"unknown": 0, "error-active": 1, "error-warning": 2, "error-passive": 3, "bus-off": 4}


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


def modbus_controller(client):
    """(controller_state, tx_errors, rx_errors, restarts) of bus 0, or None."""
    try:
        bus = client.read_input_registers(BUS_BLOCK, 8, slave=1)
        ctl = client.read_input_registers(CONTROLLER_BLOCK, 4, slave=1)
        if bus.isError() or ctl.isError():
            return None
        r = ctl.registers
        return (bus.registers[3], r[0], r[1], (r[2] << 16) | r[3])
    except Exception:  # noqa: BLE001 (the server not up yet)
        return None


def wait_modbus(client, want, timeout=5):
    end = time.time() + timeout
    got = None
    while time.time() < end:
        got = modbus_controller(client)
        if got is not None and all(w is None or g == w for g, w in zip(got, want)):
            return True, got
        time.sleep(0.05)
    return False, got


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
    extra = ('[web]\nbind = "127.0.0.1"\nport = %d\n' % WEB_PORT +
             '[outputs.modbus]\nbind = "127.0.0.1"\nport = %d\n' % MODBUS_PORT)
    cfg = e2e.write_config(ws, [bus], devices, extra=extra)
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d" % (sm, s, n) for (_, _, sm, s, n) in DEVICES]})
    daemon = e2e.Daemon(args.daemon, cfg, ws, extra_args=["--plugin-dir", args.plugins])
    from pymodbus.client import ModbusTcpClient
    mb = ModbusTcpClient("127.0.0.1", port=MODBUS_PORT, timeout=2)
    try:
        report.check(daemon.wait_socket(), "daemon up")
        # The netlink poll runs at the bus thread's first turn: vcan answers without IFLA_CAN data.
        end, c = time.time() + 3, None
        while time.time() < end:
            c = controller(daemon)
            if c and c.get("driver_reports_state") is not None:
                break
            time.sleep(0.05)
        report.check(c is not None and c["driver_reports_state"] is False and c["state"] == "unknown" and
                     c["source"] == "none" and c["tx_errors"] is None,
                     "vcan over netlink: the driver reports no controller state; state unknown, source none, "
                     "no counters invented", str(c))
        ok, got = wait_modbus(mb, (0, 65535, 65535, 0))
        report.check(ok, "Modbus before any error frame: controller_state 0 (unknown), counters 65535 "
                     "(not reported)", str(got))
        steps = [("error-warning", "error-warning", 96), ("error-passive", "error-passive", 128),
                 ("bus-off", "bus-off", None), ("restarted", "error-active", None)]
        for kind, state, tx in steps:
            reply = sim.command("bus-error vcan0 %s" % kind)
            c = wait_state(daemon, state)
            ok = c is not None and c["state"] == state and (tx is None or c["tx_errors"] == tx) and \
                c["source"] == "error frames"
            report.check(ok, "error frame %s -> status controller %s%s, source error frames" % (
                kind, state, "" if tx is None else ", tx errors %d" % tx), "%s / sim: %s" % (c, reply))
            ok, got = wait_modbus(mb, (MODBUS_STATE[state], tx, None, 1 if kind == "restarted" else None))
            report.check(ok, "Modbus bus block +3 = %d (%s)%s" % (
                MODBUS_STATE[state], state, "" if tx is None else ", controller block tx_errors %d" % tx) +
                (", restarts 1" if kind == "restarted" else ""), str(got))
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
        report.check(rc == 0 and "CAN controller error-passive (tx errors 128" in out and "from error frames)" in out,
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
        mb.close()
        daemon.stop()
        sim.stop()
        ws.cleanup()
    return report.finish()


if __name__ == "__main__":
    raise SystemExit(main())
