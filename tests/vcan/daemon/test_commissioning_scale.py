"""Commissioning at scale: N factory-fresh multiturn encoders
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

--count N: how many devices (8; 32 in vcan_daemon_commissioning_scale_32).
--lose-configure: every 4th device loses its first LSS configure node-ID
request (cobridge-sim `lose_configure=1`): each still ends
operational, its status counts the failed try (commission_failures >= 1) and
the log names it ("commissioning failed (try 1)").
--late-lss: every 4th device from the third on sends every 16th LSS answer
40 ms late (cobridge-sim `late_lss`, `late_lss_ms`; CiA 305 sets no answer
time, the master's timeout is its own): beside the lost configure node-IDs,
every device still ends operational, its identity exact, commissioned once,
and the simulator did send late answers (its `stats`: lss_late).
--latency PATH: cobridge-sim-latency (sim/tools) reads vcan0 beside the
daemon and the simulator with kernel receive times and pairs every LSS
answer (0x7E4, CiA 305 §8.3) and SDO answer (0x580+n, CiA 301 §7.2.4.3)
with its request; its p99 is printed beside the same run's floor (--echo)
and judged against the 1 ms target by the bench (scripts/bench --only
commissioning), not here: a timing bound in a test flakes with the host.
This test bounds it at 20 ms above the same run's floor p99 (the
smallest responder's: under 1 ms in UML, more on the QEMU bed, whose TCG
timer wake-ups jitter more), a guard against the simulator falling behind
again (before its answers were merged and it ran at real-time priority its
p99 was 39 ms in UML). The observer missed no frame. It also counts the SDO writes (initiate download requests)
of each start.
--echo PATH: cobridge-bus-echo answers pings (0x7F0 -> 0x7F1) beside the
simulator at the same priority while a pinger sends one every 5 ms: the
latency of the smallest responder in the same run, the floor the simulator's
figures are judged against.
Always: the simulator writes its truth file, and each device's node-ID in
status is the one the simulator's own frames carry at the end.
"""
import os
import signal
import subprocess
import sys
import time

import e2e

VENDOR = 0x182
PRODUCT = 0x0BB8      # MC1-2800 (E§4.1), what cobridge-sim reports
REVISION = 0x00010003
FIRST_SERIAL = 9001
FIRST_NODE = 20


LATENCY_P99_GUARD_US = 20000.0  # above the same-run floor: a regression guard; the 1 ms target is the bench's
SIM_RT_PRIORITY = "10"  # SCHED_FIFO: real encoders answer in microseconds whatever the master does
LATE_EVERY = 16     # every 16th LSS answer of a late device ...
LATE_MS = 40        # ... leaves 40 ms late


class LatencyObserver:
    """cobridge-sim-latency on vcan0, from before a start until it is done."""

    def __init__(self, path, iface="vcan0"):
        self.proc = subprocess.Popen([path, "--iface", iface], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        if line.strip() != "ready":
            raise RuntimeError("cobridge-sim-latency did not start: %r %s" % (line, self.proc.stderr.read()))

    def stop(self):
        """Its summary: {"lss": {...}, "sdo": {...}, "frames": N, "drops": N}."""
        self.proc.send_signal(signal.SIGTERM)
        out, err = self.proc.communicate(timeout=30)
        result = {}
        for line in out.splitlines():
            words = line.split()
            if words and words[0] in ("lss", "sdo", "echo"):
                result[words[0]] = {k: float(v) for k, v in (w.split("=") for w in words[1:])}
            elif words:
                result.update({k: int(v) for k, v in (w.split("=") for w in words)})
        if "lss" not in result or "drops" not in result:
            raise RuntimeError("cobridge-sim-latency: no summary: %r %r" % (out, err))
        return result


class EchoFloor:
    """cobridge-bus-echo: an answerer at the simulator's priority and a pinger."""

    def __init__(self, path):
        self.procs = []
        for args in (["--answer", "--rt-priority", SIM_RT_PRIORITY], ["--ping", "5"]):
            p = subprocess.Popen([path] + args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, text=True)
            self.procs.append(p)
            if p.stdout.readline().strip() != "ready":
                self.stop()
                raise RuntimeError("cobridge-bus-echo %s did not start" % " ".join(args))

    def stop(self):
        for p in reversed(self.procs):
            p.send_signal(signal.SIGTERM)
            p.wait(10)
        self.procs = []


def latency_figures(report, lat, what, count):
    for svc in ("lss", "sdo"):
        x = lat[svc]
        print("FIGURE %s: simulator %s answer latency (request -> answer on vcan0, kernel timestamps): "
              "n=%d p50 %.0f us, p99 %.0f us, max %.0f us; %d requests unanswered, %d answers late" % (
                  what, svc.upper(), x["answers"], x["p50_us"], x["p99_us"], x["max_us"], x["unanswered"],
                  x["mismatched"]))
    x = lat["echo"]
    if x["requests"]:
        print("FIGURE %s: same-run floor, cobridge-bus-echo answer latency: n=%d p50 %.0f us, p99 %.0f us, "
              "max %.0f us" % (what, x["answers"], x["p50_us"], x["p99_us"], x["max_us"]))
    print("FIGURE %s: SDO writes %d (%.1f per device); frames read %d, dropped %d" % (
        what, lat["sdo"]["downloads"], lat["sdo"]["downloads"] / count, lat["frames"], lat["drops"]))
    report.check(lat["drops"] == 0, "%s: the latency observer read every frame" % what,
                 "%d dropped by the kernel" % lat["drops"])


def check_latency(report, lat):
    """One LSS answer frame per request; the simulator's answers not behind (guard)."""
    x = lat["lss"]
    report.check(x["repeats"] == 0, "one LSS answer frame per request on the wire (CiA 305 §8.3.4: the slaves "
                 "a Fastscan step matches send the same frame at once, one frame on a bus)",
                 "%d answers to %d requests, %d of them a second answer" % (x["answers"], x["requests"],
                                                                             x["repeats"]))
    floor = lat["echo"]["p99_us"] if lat["echo"]["requests"] else None
    for svc in ("lss", "sdo"):
        x = lat[svc]
        report.check(x["answers"] > 0 and x["p99_us"] <= LATENCY_P99_GUARD_US + (floor or 0.0),
                     "simulator %s answers within %.0f ms of the request at p99 above the same-run floor (CiA %s; "
                     "the 1 ms target: bench)"
                     % (svc.upper(), LATENCY_P99_GUARD_US / 1000, "305 §8.3" if svc == "lss" else "301 §7.2.4.3"),
                     "n=%d p99 %.0f us; same-run floor p99 %s" % (
                         x["answers"], x["p99_us"], "%.0f us" % floor if floor is not None else "not measured"))


def truth_nodes(path):
    """serial -> the node-ID of that device's last frame in the truth file."""
    last = {}
    with open(path) as f:
        for line in f:
            w = line.split()
            if len(w) >= 5:
                last[int(w[2])] = int(w[3])
    return last


def check_truth(report, st, devs, truth_path):
    by_name = {d["name"]: d for b in st["buses"] for d in b["devices"]}
    nodes = truth_nodes(truth_path)
    wrong = ["%s: status %s, truth %s" % (n, by_name.get(n, {}).get("node_id"), nodes.get(s))
             for (n, s, node) in devs if nodes.get(s) != node or by_name.get(n, {}).get("node_id") != node]
    report.check(not wrong, "every device's node-ID in status is the one its own frames carry (truth file)",
                 "; ".join(wrong[:5]))


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
    """Nobody left behind: the lost configure node-ID was tried again."""
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
    # A Fastscan begins again when a burst of answers spills into the next
    # step: none on a quiet machine, but a loaded one (other builds beside
    # UML) makes answers late. A figure, not a check: the checks above are
    # what late answers must never break.
    restarts = sum(v[2] for v in per.values())
    for x in sorted(steps, key=lambda x: x.get("at") or ""):
        if x.get("restarts", 0) or x.get("exchanges", 0) > 40:
            print("FIGURE long Fastscan: %s %s at %s: %d exchanges, %d timeouts, %d restarts, %.0f ms" % (
                x["step"], x["device"], x.get("at"), x["exchanges"], x.get("timeouts", 0), x.get("restarts", 0),
                x["ms"]))
    print("FIGURE Fastscans begun again after late answers: %d" % restarts)


def extra_args(p):
    p.add_argument("--latency", help="cobridge-sim-latency: measure and bound the simulator's answer latency")
    p.add_argument("--echo", help="cobridge-bus-echo: the same run's floor beside the latency figures")


def start_observer(report, args):
    if not args.latency:
        return None
    for tool in (args.latency, args.echo):
        if tool and not os.access(tool, os.X_OK):
            report.check(False, "%s at %s" % (os.path.basename(tool), tool), "missing")
            return None
    return LatencyObserver(args.latency)


def main():
    count = 8
    if "--count" in sys.argv:
        i = sys.argv.index("--count")
        count = int(sys.argv[i + 1])
        del sys.argv[i:i + 2]
    lose = "--lose-configure" in sys.argv
    if lose:
        sys.argv.remove("--lose-configure")
    late = "--late-lss" in sys.argv
    if late:
        sys.argv.remove("--late-lss")
    args = e2e.parse_args(extra_args)
    report = e2e.Report("test_commissioning_scale_%d" % count)
    # Every file the daemon and the simulator write (state, the devices' memory, logs, the truth
    # file) lives on UML's tmpfs: a write to the host's file system (hostfs) holds the whole
    # virtual machine for the host's write, which a real machine's page cache never does, and
    # would show up as simulator answer latency.
    ws = e2e.Workspace("commissioning-scale", args.keep, base="/run")
    devs = devices(count)
    names = [d[0] for d in devs]
    lossy = [d for (i, d) in enumerate(devs) if lose and i % 4 == 0]
    slow = [d for (i, d) in enumerate(devs) if late and i % 4 == 2]
    specs = ["MC1-2800:serial=%d,node=unconfigured%s%s" % (
        s, ",lose_configure=1" if (n, s, node) in lossy else "",
        ",late_lss=%d,late_lss_ms=%d" % (LATE_EVERY, LATE_MS) if (n, s, node) in slow else "")
        for (n, s, node) in devs]
    truth = ws.path("truth.txt")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": specs}, extra_args=("--truth", truth, "--rt-priority", SIM_RT_PRIORITY))
    daemon = observer = echo = None
    try:
        config = config_for(ws, devs)
        seen_steps = {}
        observer = start_observer(report, args)
        echo = EchoFloor(args.echo) if observer and args.echo else None
        daemon, st, took = run_daemon(args, ws, config, names, 60 + 4 * count, "daemon-1.log", seen_steps)
        if echo:
            echo.stop()
            echo = None
        lat1 = observer.stop() if observer else None
        observer = None
        stats = sim.command("stats")
        print("FIGURE simulator loop (its own view of how late it woke): " + stats)
        wakes, late_wakes = (int(stats.split(k + "=")[1].split()[0]) for k in ("timed_wakes", "late_over_1ms"))
        print("FIGURE UML floor, same run: %.1f %% of the simulator's timed wake-ups more than 1 ms late (at "
              "SCHED_FIFO inside UML: the host or UML's own kernel kept it from running)"
              % (100.0 * late_wakes / max(wakes, 1)))
        turns, busy, max_busy = (int(stats.split(k + "=")[1].split()[0])
                                 for k in ("turns", "busy_over_1ms", "max_busy_us"))
        print("FIGURE simulator's own turns longer than 1 ms: %.2f %% (%d of %d, longest %d us; a request "
              "arriving meanwhile waits for the turn's end)" % (100.0 * busy / max(turns, 1), busy, turns, max_busy))
        if slow:
            sent_late = int(stats.split("lss_late=")[1].split(",")[0])
            report.check(sent_late > 0, "%d devices sent LSS answers %d ms late (cobridge-sim late_lss)"
                         % (len(slow), LATE_MS), "%d late answers" % sent_late)
        report.check(took is not None, "%d factory-fresh devices operational" % count,
                     "%.2f s after start" % took if took else "never")
        if st is not None:
            check_identities(report, st, devs)
            check_truth(report, st, devs, truth)
            check_once(report, daemon, devs)
            if lossy:
                check_retried(report, st, daemon, lossy)
            if took is not None:
                figures(report, st, seen_steps, devs, took)
        if lat1:
            latency_figures(report, lat1, "first start", count)
            check_latency(report, lat1)
        if report.failed:
            print(daemon.tail(80))
        e2e.check_clean_exit(report, daemon, "first start: SIGTERM -> exit 0 within 1 s")
        daemon = None
        observer = start_observer(report, args)
        daemon, st, took = run_daemon(args, ws, config, names, 30, "daemon-2.log")
        lat2 = observer.stop() if observer else None
        observer = None
        report.check(took is not None, "second start: all %d operational" % count,
                     "FIGURE second start -> all operational %.2f s" % took if took else "never")
        if lat2:
            latency_figures(report, lat2, "second start", count)
        e2e.check_clean_exit(report, daemon, "second start: SIGTERM -> exit 0 within 1 s")
        daemon = None
    finally:
        if echo:
            echo.stop()
        if observer:
            observer.proc.kill()
        e2e.shut_down(ws, daemon, sim)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
