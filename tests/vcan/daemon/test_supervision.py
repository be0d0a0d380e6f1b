"""One device of each family at its configured
node-ID with heartbeat 100 ms:
 * power-cycled by the simulator, each is back online and configured within
   1 s of its boot-up message (CiA 301 §7.2.8.3.3 boot-up 0x700+id 00 ->
   configuration -> NMT start, §7.2.8.3.1);
 * silenced (cable pulled), each is reported offline within its heartbeat
   consumer time (CiA 301 §7.2.8.3.2.2; cobridged's consumer time is
   1.5 x producer + 50 ms = 200 ms) of its last heartbeat, and online again
   when it speaks.
Times are the daemon's own (`since` of the state) against the frames seen on
vcan0 by a raw socket, on the one clock of the UML machine.
"""
import sys
import time

import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10),
           ("mt-a", "MC1-2800", "MC1-2800", 2001, 20),
           ("ifm-a", "RM9", "RM9000", 3001, 30)]
CONSUMER_TIME = 0.200
TOLERANCE = 0.100  # the control thread's wake-up and the listener's read


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_supervision")
    ws = e2e.Workspace("supervision", args.keep)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d%s" % (sm, s, n, ",bitrate=250" if sm.startswith("RM") else "")
                                                 for (_, _, sm, s, n) in DEVICES]})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30, "node_pool": "40-60"}
    devices = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 100}}
               for (name, m, _, s, n) in DEVICES]
    daemon = e2e.Daemon(args.daemon, e2e.write_config(ws, [bus], devices), ws)
    names = [d[0] for d in DEVICES]
    with e2e.shut_down_after(ws, lambda: (daemon, sim, listener)):
        report.check(daemon.wait_socket(), "control socket up")
        _, took = daemon.wait_until(e2e.all_operational(names), 60, interval=0.1)
        if not report.check(took is not None, "three devices operational at their node-IDs",
                            "%.2f s" % took if took else ""):
            print(daemon.tail(60))
        time.sleep(0.5)

        # Power cycle -> boot-up -> configured and started within 1 s.
        for (name, _, _, serial, node) in DEVICES:
            before = daemon.devices()[name]
            t0 = time.time()
            sim.command("power-cycle %d" % serial)
            boot = listener.wait_for(lambda i, d: i == 0x700 + node and d == b"\x00", 3, since=t0)
            if not report.check(boot is not None, "%s: boot-up seen after power-cycle" % name):
                continue
            start = listener.wait_for(lambda i, d: i == 0 and len(d) == 2 and d[0] == 0x01 and d[1] in (0, node), 3,
                                      since=boot[0])
            st, _ = daemon.wait_until(
                lambda s: any(d["name"] == name and d["state"] == "operational" and d["online"] and d["since"] and
                              e2e.iso_to_epoch(d["since"]) >= boot[0] - 0.005 for b in s["buses"] for d in b["devices"]),
                3, interval=0.02)
            dev = {d["name"]: d for b in (st or {"buses": []})["buses"] for d in b["devices"]}.get(name)
            t_oper = e2e.iso_to_epoch(dev["since"]) if dev and dev["since"] else None
            ok = start is not None and t_oper is not None and start[0] - boot[0] < 1.0 and t_oper - boot[0] < 1.0
            report.check(ok, "%s: configured and started within 1 s of its boot-up" % name,
                         "NMT start %s, operational %s after the boot-up; boot_ups %s -> %s" % (
                             "%.3f s" % (start[0] - boot[0]) if start else "never",
                             "%.3f s" % (t_oper - boot[0]) if t_oper else "never",
                             before.get("boot_ups"), dev.get("boot_ups") if dev else "?"))
            time.sleep(0.5)

        # Silence -> offline within the consumer time -> online again.
        for (name, _, _, serial, node) in DEVICES:
            hb = lambda i, d: i == 0x700 + node and len(d) == 1 and d[0] in (0x05, 0x7F, 0x04)
            t0 = time.time()
            sim.command("silence %d on" % serial)
            t_cmd = time.time()
            st, _ = daemon.wait_until(
                lambda s: any(d["name"] == name and not d["online"] for b in s["buses"] for d in b["devices"]),
                3, interval=0.02)
            heartbeats = [f for f in listener.snapshot(t0 - 1.0) if hb(f[1], f[2]) and f[0] <= t_cmd]
            dev = {d["name"]: d for b in (st or {"buses": []})["buses"] for d in b["devices"]}.get(name)
            if dev is None or not heartbeats:
                report.check(False, "%s: offline after silence" % name, "status %r" % dev)
                sim.command("silence %d off" % serial)
                continue
            last_hb = heartbeats[-1][0]
            t_off = e2e.iso_to_epoch(dev["since"])
            report.check(t_off - last_hb <= CONSUMER_TIME + TOLERANCE,
                         "%s: offline within the heartbeat consumer time" % name,
                         "%.3f s after the last heartbeat (consumer time %.3f s); state %s, reason %r" % (
                             t_off - last_hb, CONSUMER_TIME, dev["state"], dev["last_error"]))
            time.sleep(0.5)
            t1 = time.time()
            sim.command("silence %d off" % serial)
            first = listener.wait_for(hb, 3, since=t1)
            st, _ = daemon.wait_until(
                lambda s: any(d["name"] == name and d["online"] and d["state"] == "operational"
                              for b in s["buses"] for d in b["devices"]), 3, interval=0.02)
            dev = {d["name"]: d for b in (st or {"buses": []})["buses"] for d in b["devices"]}.get(name)
            ok = first is not None and dev is not None and dev["online"]
            report.check(ok, "%s: online again when it speaks" % name,
                         "operational %.3f s after its first heartbeat" % (e2e.iso_to_epoch(dev["since"]) - first[0])
                         if ok else "status %r" % dev)
            time.sleep(0.3)
        e2e.check_clean_exit(report, daemon)
        daemon = None
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
