"""CAN adapters come and go (USB adapters are plugged after
boot, and unplugged). Two buses; vcan1 (line2) does not exist when the
daemon starts:
 * the daemon serves line1 anyway (its device operational), reports line2 as
   not open, and keeps running;
 * vcan1 appears and its device boots: configured and operational <= 2 s
   after the interface is there;
 * vcan1 is deleted (unplugged): the status says offline / not open;
 * vcan1 is created again and the device restarts meanwhile with its
   factory settings (store = "never": no heartbeat, its boot-up sent before
   the daemon re-opened the interface, so unseen): the device is probed and
   configured again, operational <= 2 s after the interface is back.
"""
import subprocess
import sys
import time

import e2e

BOUND = 2.0


def ip(*args):
    return subprocess.run(["ip"] + list(args), capture_output=True, text=True).returncode


def bus_status(daemon, name):
    try:
        for b in daemon.status()["buses"]:
            if b["name"] == name:
                return b
    except (OSError, ValueError):
        pass
    return None


def wait_operational_since(daemon, name, after, timeout):
    end = time.time() + timeout
    d = None
    while time.time() < end:
        d = daemon.devices().get(name)
        if d and d["state"] == "operational" and d["online"] and e2e.iso_to_epoch(d["since"]) >= after - 0.005:
            return e2e.iso_to_epoch(d["since"]) - after, d
        time.sleep(0.02)
    return None, d


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_adapter_hotplug")
    ws = e2e.Workspace("hotplug", args.keep)
    ip("link", "del", "vcan1")
    sim0 = e2e.Simulator(args.sim, ws, {"vcan0": ["RFC-4800:serial=1001,node=10"]}, log_name="sim0.log")
    sim1 = None
    buses = [{"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30},
             {"name": "line2", "interface": "vcan1", "bitrate": 250, "discovery_period_s": 30}]
    tpdo = {"mapping": ["position"], "transmission": "event", "event_timer_ms": 50}
    devices = [{"name": "rot-a", "bus": "line1", "serial": 1001, "model": "RFC-4800", "node_id": 10,
                "heartbeat_ms": 100, "tpdo1": tpdo},
               {"name": "mt-a", "bus": "line2", "serial": 2001, "model": "MC1-2800", "node_id": 20,
                "heartbeat_ms": 100, "store": "never", "tpdo1": tpdo}]
    daemon = e2e.Daemon(args.daemon, e2e.write_config(ws, buses, devices), ws)
    try:
        report.check(daemon.wait_socket(), "daemon runs with vcan1 missing")
        _, took = daemon.wait_until(e2e.all_operational(["rot-a"]), 30, interval=0.1)
        report.check(took is not None, "line1 served: rot-a operational", "%.2f s" % took if took else "")
        b2 = bus_status(daemon, "line2")
        report.check(b2 is not None and not b2["open"], "status: line2 not open while vcan1 is missing",
                     "%r" % (b2["open"] if b2 else None,))
        time.sleep(1.0)
        report.check(daemon.proc.poll() is None, "still running 1 s later")

        # Plugged in after start.
        ip("link", "add", "dev", "vcan1", "type", "vcan")
        ip("link", "set", "vcan1", "up")
        t_plug = time.time()
        sim1 = e2e.Simulator(args.sim, ws, {"vcan1": ["MC1-2800:serial=2001,node=20"]}, log_name="sim1.log",
                             control=ws.sim_control + ".1")
        took, d = wait_operational_since(daemon, "mt-a", t_plug, BOUND + 5)
        report.check(took is not None and took <= BOUND, "mt-a operational <= 2 s after vcan1 appeared",
                     "%.3f s" % took if took is not None else "%r" % ((d["state"], d["last_error"]) if d else None,))
        b2 = bus_status(daemon, "line2")
        report.check(b2 is not None and b2["open"], "status: line2 open")

        # Unplugged.
        ip("link", "del", "vcan1")
        st, took = daemon.wait_until(lambda s: any(d["name"] == "mt-a" and not d["online"] and
                                                   d["state"] != "operational"
                                                   for b in s["buses"] for d in b["devices"]), 3)
        report.check(took is not None, "unplugged: mt-a reported offline", "%.3f s" % took if took else "")
        b2 = bus_status(daemon, "line2")
        report.check(b2 is not None and not b2["open"], "unplugged: line2 not open")
        time.sleep(0.5)

        # Plugged back; the device restarts meanwhile with its factory settings.
        ip("link", "add", "dev", "vcan1", "type", "vcan")
        ip("link", "set", "vcan1", "up")
        t_back = time.time()
        sim1.command("power-cycle 2001")
        took, d = wait_operational_since(daemon, "mt-a", t_back, BOUND + 5)
        report.check(took is not None and took <= BOUND,
                     "re-plugged, device restarted unseen: operational <= 2 s after the interface is back",
                     "%.3f s" % took if took is not None else "%r" % ((d["state"], d["last_error"]) if d else None,))
        listener = e2e.CanListener("vcan1")
        f = listener.wait_for(lambda i, data: i == 0x180 + 20, 2, since=time.time())
        listener.close()
        report.check(f is not None, "mt-a values flow again")
        rot = daemon.devices().get("rot-a")
        report.check(rot is not None and rot["state"] == "operational", "line1 undisturbed throughout")
        if report.failed:
            print(daemon.tail(60))
        e2e.check_clean_exit(report, daemon)
        daemon = None
    finally:
        others = [sim0] + ([sim1] if sim1 else [])
        e2e.shut_down(ws, daemon, *others)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
