"""One device replaced by a new one of the same model
(new serial, factory node-ID 127, E§4.1) takes the old one's place under the
bus's swap policy "same-model": the new serial is identified by SDO
(CiA 301 0x1018), moved to the old device's node-ID by LSS (CiA 305 switch
selective / configure node-ID / store), configured and started, and the
status shows it under the old device's name.

cobridge-sim cannot add a device at run time, so the swap is done the way a
technician does it with the power off: the simulator is stopped and started
again with the new serial in place of the old one, on the same non-volatile
state directory (the other devices keep their stored node-IDs). The daemon
keeps running throughout.
"""
import sys
import time

import e2e

BEFORE = ["MC1-2800:serial=2001,node=20", "MC1-2800:serial=2002,node=21", "RM9000:serial=3001,node=30,bitrate=250"]
AFTER = ["MC1-2800:serial=2001,node=20", "MC1-2800:serial=2099", "RM9000:serial=3001,node=30,bitrate=250"]
NAMES = ["mt-a", "mt-b", "ifm-a"]


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_swap")
    ws = e2e.Workspace("swap", args.keep)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": BEFORE})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 5, "node_pool": "40-60",
           "commissioning": "automatic", "swap_policy": "same-model"}
    devices = [{"name": "mt-a", "bus": "line1", "serial": 2001, "model": "MC1-2800", "node_id": 20, "heartbeat_ms": 100},
               {"name": "mt-b", "bus": "line1", "serial": 2002, "model": "MC1-2800", "node_id": 21, "heartbeat_ms": 100},
               {"name": "ifm-a", "bus": "line1", "serial": 3001, "model": "RM9", "node_id": 30, "heartbeat_ms": 100}]
    daemon = e2e.Daemon(args.daemon, e2e.write_config(ws, [bus], devices), ws)
    with e2e.shut_down_after(ws, lambda: (daemon, sim, listener)):
        report.check(daemon.wait_socket(), "control socket up")
        _, took = daemon.wait_until(e2e.all_operational(NAMES), 60, interval=0.1)
        if not report.check(took is not None, "three devices operational before the swap",
                            "%.2f s" % took if took else ""):
            print(daemon.tail(60))

        sim.stop()
        time.sleep(0.5)
        t0 = time.time()
        sim = e2e.Simulator(args.sim, ws, {"vcan0": AFTER}, log_name="sim-2.log")
        st, took = daemon.wait_until(
            lambda s: any(d["name"] == "mt-b" and d["identity"]["serial"] == 2099 and d["node_id"] == 21 and
                          d["state"] == "operational" and d["online"] for b in s["buses"] for d in b["devices"]),
            120, interval=0.1)
        if not report.check(took is not None, "new serial 2099 took mt-b's place at node 21, operational",
                            "%.2f s after the simulator restart" % took if took else "timeout; status %s" % st):
            print(daemon.tail(60))
        moved = listener.wait_for(lambda i, d: i == 0x715 and d == b"\x00", 0.1, since=t0)
        report.check(moved is not None, "the new device booted at node 21 (0x715 boot-up)")
        st = daemon.status()
        devs = {d["name"]: d for b in st["buses"] for d in b["devices"]}
        report.check(all(devs[n]["state"] == "operational" for n in ("mt-a", "ifm-a")),
                     "the other devices are operational again")
        problems = [p for b in st["buses"] for p in b["problems"]]
        print("problems reported: %s" % problems)
        for b in st["buses"]:
            for s in b["steps"][-8:]:
                print("  step %-28s %-8s %9.1f ms" % (s["step"], s["device"], s["ms"]))
        e2e.check_clean_exit(report, daemon)
        daemon = None
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
