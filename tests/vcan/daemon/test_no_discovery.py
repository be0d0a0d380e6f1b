"""A bus with `discovery = false` still configures every
configured device at its configured node-ID, at start and after each
boot-up; the gateway reads the device's identity (0x1018, CiA 301
§7.5.2.24) first, so a device of another serial at that node-ID is reported
and never configured. No LSS and no probe of other node-IDs is sent.
"""
import sys
import time

import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10),
           ("mt-a", "MC1-2800", "MC1-2800", 2001, 20),
           ("ifm-a", "RM9", "RM9000", 3001, 30)]


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_no_discovery")
    ws = e2e.Workspace("nodisc", args.keep)
    listener = e2e.CanListener("vcan0")
    sims = ["%s:serial=%d,node=%d%s" % (sm, s, n, ",bitrate=250" if sm.startswith("RM") else "")
            for (_, _, sm, s, n) in DEVICES]
    sims.append("MC1-2800:serial=2999,node=40")  # at the node-ID of 'mt-wrong', with another serial
    sim = e2e.Simulator(args.sim, ws, {"vcan0": sims})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery": False, "discovery_period_s": 30}
    devices = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 50}}
               for (name, m, _, s, n) in DEVICES]
    devices.append({"name": "mt-wrong", "bus": "line1", "serial": 2500, "model": "MC1-2800", "node_id": 40,
                    "heartbeat_ms": 100})
    names = [d[0] for d in DEVICES]
    t_start = time.time()
    daemon = e2e.Daemon(args.daemon, e2e.write_config(ws, [bus], devices), ws)
    with e2e.shut_down_after(ws, lambda: (daemon, sim, listener)):
        report.check(daemon.wait_socket(), "control socket up")
        st, took = daemon.wait_until(e2e.all_operational(names), 20, interval=0.05)
        report.check(took is not None, "discovery off: the three configured devices operational",
                     "%.2f s" % took if took else "%s" % (st and [(d["name"], d["state"], d["last_error"])
                                                                 for b in st["buses"] for d in b["devices"]]))
        wrong = daemon.devices().get("mt-wrong")
        report.check(wrong is not None and wrong["state"] != "operational" and "serial 2999" in wrong["last_error"],
                     "a device of another serial at a configured node-ID is reported, not configured",
                     "%r" % ((wrong["state"], wrong["last_error"]) if wrong else None,))
        downloads_40 = [f for f in listener.snapshot(t_start) if f[1] == 0x600 + 40 and (f[2][0] & 0xE0) == 0x20]
        report.check(not downloads_40, "nothing written to the wrong device", "%d SDO downloads" % len(downloads_40))
        lss = [f for f in listener.snapshot(t_start) if f[1] == 0x7E5]
        probes = [f for f in listener.snapshot(t_start) if 0x600 < f[1] <= 0x67F and f[1] - 0x600 not in (10, 20, 30, 40)]
        report.check(not lss and not probes, "no LSS, no probe of other node-IDs",
                     "%d LSS, %d probes" % (len(lss), len(probes)))

        # After a boot-up: configured again.
        for (name, _, _, serial, node) in DEVICES:
            t0 = time.time()
            sim.command("power-cycle %d" % serial)
            boot = listener.wait_for(lambda i, d: i == 0x700 + node and d == b"\x00", 3, since=t0)
            _, took = daemon.wait_until(
                lambda s: any(d["name"] == name and d["state"] == "operational" and d["online"] and boot and
                              e2e.iso_to_epoch(d["since"]) >= boot[0] - 0.005
                              for b in s["buses"] for d in b["devices"]), 3)
            report.check(boot is not None and took is not None, "%s: configured again after its boot-up" % name,
                         "%.3f s" % took if took is not None else "")
        e2e.check_clean_exit(report, daemon)
        daemon = None
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
