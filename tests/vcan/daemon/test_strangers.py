"""Devices nobody configured must not stall the bus.

Two configured rotary encoders clash at their factory node-ID 127 (J§1.2.2)
and one device at FFh (unconfigured, CiA 305) has a serial the configuration
does not name. Twice: the stranger is a multiturn of a configured model, then
another vendor's LSS slave that refuses node-ID assignment (CiA 305 configure
node-ID answered with error 1). Each time:
 * both configured encoders are commissioned, configured and operational
   within the target (3 s + 1 s);
 * the stranger is found once (one Fastscan that finds it), reported in the
   status with its identity, and not scanned again in a loop;
 * nothing is written to the stranger's node-ID.
"""
import sys
import time

import e2e

# The target is 3 s + 1 s with a stranger on the bus: the figure is
# printed (FIGURE) and recorded in docs/performance.md. The check is a looser
# bound that a stalled bus fails (configured encoders 15 s late, or never up).
TARGET = 4.0
BOUND = 10.0
# The bus's discovery period. A search begun again at a periodic round sends
# its first Fastscan frame as soon as the non-configured check that follows
# the round is answered (the check waits lss_timeout_ms, 100 ms, at most):
# that no search begins is an absence, watched over SEARCH_WINDOW after the
# check.
PERIOD_S = 5
SEARCH_WINDOW = 1.0
CONFIGURED = [("rot-a", "RFC-4800", 1001, 10), ("rot-b", "RFC-4800", 1002, 11)]
STRANGERS = [("multiturn of a configured model", "MC1-2800:serial=9999,node=unconfigured", 9999, "ignore"),
             ("another vendor's device refusing node-IDs",
              "MC1-2800:serial=777,node=unconfigured,vendor=0x4711,product=0x22,revision=1,assign=refuse", 777,
              "ignore"),
             ("another vendor's device, policy assign",
              "MC1-2800:serial=888,node=unconfigured,vendor=0x4711,product=0x22,revision=1", 888, "assign")]


def begins_fastscan(can_id, data):
    """The first request of a Fastscan (CiA 305: BitChecked 80h)."""
    return can_id == 0x7E5 and data[0] == 0x51 and data[5] == 0x80


def periodic_round(st):
    """The status step of the first periodic discovery round, or None. The
    daemon logs no line for a round at info; its status lists each full
    round as a "probe" step: the start-up's own first (after "probe-expected":
    the configured devices have node-IDs), then one per period."""
    probes = [x for b in st["buses"] for x in b["steps"] if x["step"] == "probe"]
    return probes[1] if len(probes) > 1 else None


def scenario(args, report, label, stranger, stranger_serial, policy):
    ws = e2e.Workspace("strangers", args.keep)
    listener = e2e.CanListener("vcan0")
    devs = ["RFC-4800:serial=%d" % s for (_, _, s, _) in CONFIGURED] + [stranger]
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": node, "heartbeat_ms": 100}
               for (n, m, s, node) in CONFIGURED]
    if "MC1-2800:serial=9999" in stranger:
        # Its model is configured, and the configured one is present: no place to take.
        devs.append("MC1-2800:serial=5555,node=20")
        devices.append({"name": "mt-a", "bus": "line1", "serial": 5555, "model": "MC1-2800", "node_id": 20,
                        "heartbeat_ms": 100})
    sim = e2e.Simulator(args.sim, ws, {"vcan0": devs})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": PERIOD_S,
           "node_pool": "40-60", "unknown_devices": policy}
    daemon = e2e.Daemon(args.daemon, e2e.write_config(ws, [bus], devices), ws)
    names = [c[0] for c in CONFIGURED]
    try:
        report.check(daemon.wait_socket(), "%s: control socket up" % label)
        st, took = daemon.wait_until(e2e.all_operational(names), 30, interval=0.05)
        took_total = time.time() - daemon.started
        report.check(took is not None and took_total <= BOUND,
                     "%s: configured encoders operational <= %.0f s after start (FIGURE, target %.0f s)" % (
                         label, BOUND, TARGET),
                     "%.2f s" % took_total if took is not None else "never; %s" % (
                         st and [(d["name"], d["state"]) for b in st["buses"] for d in b["devices"]]))
        # Past a periodic discovery round and the non-configured check after
        # it, where a search of the stranger would begin again.
        st, _ = daemon.wait_until(lambda s: periodic_round(s) is not None, PERIOD_S + 20, interval=0.05)
        last = st and periodic_round(st)
        report.check(bool(last), "%s: a periodic discovery round ran" % label)
        round_start = e2e.iso_to_epoch(last["at"]) - last["ms"] / 1000.0 if last else time.time()
        check = listener.wait_for(lambda i, d: i == 0x7E5 and d[0] == 0x4C, 5, since=round_start)
        report.check(check is not None, "%s: the periodic round is followed by the non-configured check" % label)
        time.sleep(max(0.0, (check[0] if check else time.time()) + SEARCH_WINDOW - time.time()))
        again = [f for f in listener.snapshot(round_start) if begins_fastscan(f[1], f[2])]
        report.check(not again, "%s: the periodic round begins no search (no scan loop)" % label,
                     "%d Fastscans begun" % len(again))
        st = daemon.status()
        devs_st = [d for b in st["buses"] for d in b["devices"]]
        seen = [d for d in devs_st if d["identity"]["serial"] == stranger_serial]
        report.check(bool(seen), "%s: the stranger is in the status with its identity" % label,
                     "%r" % [(d["name"], d["state"], d["node_id"], d["identity"]) for d in seen])
        if policy == "assign":
            # unknown_devices = "assign": the first free node-ID of node_pool, stored in the device.
            report.check(bool(seen) and seen[0]["node_id"] == 40, "%s: the stranger got node 40 from the pool" % label,
                         "node %s" % (seen[0]["node_id"] if seen else None))
            answer = listener.wait_for(lambda i, d: i == 0x580 + 40, 0.1, since=daemon.started)
            hb = [f for f in listener.snapshot(daemon.started) if f[1] == 0x700 + 40 and f[2] == b"\x00"]
            report.check(bool(hb) or answer is not None, "%s: the stranger booted at node 40" % label)
        # Item 5: how each device was found: exchanges and timeouts of every LSS step.
        steps = [x for b in st["buses"] for x in b["steps"] if x["step"].startswith("fastscan")]
        # 134 exchanges a pass (1 probe + 4 x 33 + the verifying switch selective); a pass spoilt by late answers begins again (restarts).
        report.check(bool(steps) and all(0 < x.get("exchanges", 0) <= 170 * (1 + x.get("restarts", 0)) and
                                         0 <= x.get("timeouts", -1) <= x["exchanges"] for x in steps),
                     "%s: status shows each Fastscan's exchanges and timeouts" % label,
                     "; ".join("%s %s: %d exchanges, %d timeouts, %d restarts, %.0f ms" % (
                         x["step"], x["device"] or "-", x.get("exchanges", 0), x.get("timeouts", 0),
                         x.get("restarts", 0), x["ms"])
                         for x in steps[:4]))
        log = open(daemon.log_path).read()
        found_lines = [ln for ln in log.splitlines() if "fastscan" in ln.lower() and str(stranger_serial) in ln]
        fastscans = len([f for f in listener.snapshot(daemon.started) if begins_fastscan(f[1], f[2])])
        report.check(fastscans <= 3, "%s: Fastscan not repeated in a loop" % label, "%d Fastscan runs" % fastscans)
        # The stranger is scanned once (a search longer than a
        # probe and a few guesses, and the verification), not again at the next period.
        searches = [x for x in steps if x.get("exchanges", 0) > 6]
        report.check(len(searches) == 1, "%s: the stranger is searched once" % label,
                     "%d searches: %s" % (len(searches), "; ".join("%d exchanges" % x["exchanges"] for x in searches)))
        report.check(all(d["state"] == "operational" for d in devs_st if d["name"] in names),
                     "%s: configured encoders still operational" % label)
        if report.failed:
            print(daemon.tail(60))
            print("fastscan log lines: %s" % found_lines[:5])
        e2e.check_clean_exit(report, daemon, "%s: SIGTERM -> exit 0 within 1 s" % label)
        daemon = None
    finally:
        e2e.shut_down(ws, daemon, sim, listener)


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_strangers")
    for label, stranger, serial, policy in STRANGERS:
        scenario(args, report, label, stranger, serial, policy)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
