"""A second start as fast as the bus allows.

Four encoders (the three families), DDS and Modbus outputs on, are commissioned and configured once; then
cobridged is stopped and started again RESTARTS times on the same state
directory, as `systemctl restart` does. Each restart is timed from just
before exec to every device operational, two ways in the same run:

  * as an operator sees it: the status through the control socket, polled
    every 5 ms (from exec);
  * by the daemon's own log stamps: its first line ("starting"), the first
    bus serving, the plugins running (they start while the buses come up),
    and the last "operational" line.

Prints FIGURE lines for scripts/bench; runs inside UML (real SocketCAN):
  tests/vcan/run-in-vcan --ifaces 1 -- /usr/bin/python3 tests/bench/restart_in_uml.py \
      --daemon build/daemon/cobridged --cli build/daemon/cli/cobridge --sim build/sim/app/cobridge-sim \
      --plugins build/lib/cobridge/plugins
Exits non-zero when a restart does not reach operational or writes anything.
"""
import datetime
import os
import re
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "vcan", "daemon"))
import e2e  # noqa: E402

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10),
           ("mt-a", "MC1-2800", "MC1-2800", 2001, 20),
           ("mt-b", "MZ1-2200", "MZ1-2200", 2002, 21),
           ("ifm-a", "RM9", "RM9000", 3001, 30)]
NAMES = [d[0] for d in DEVICES]
STAMP = re.compile(r"^\[(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3})\]")


def stamp(line):
    m = STAMP.match(line)
    if not m:
        return None
    return datetime.datetime.strptime(m.group(1), "%Y-%m-%d %H:%M:%S.%f").timestamp()


def log_marks(path):
    """(first line, plugins running, first bus serving, last device operational) stamps."""
    first = plugins = serving = last_op = None
    with open(path) as f:
        for line in f:
            t = stamp(line)
            if t is None:
                continue
            first = first if first is not None else t
            if plugins is None and "outputs:" in line and "running" in line:
                plugins = t
            if serving is None and re.search(r"bus \S+: serving", line):
                serving = t
            if re.search(r"device \S+ operational at node", line):
                last_op = t
    return first, plugins, serving, last_op


def writes_in(path):
    """Sum of the 'N writes' of the operational lines of one start."""
    with open(path) as f:
        return sum(int(m.group(1)) for m in re.finditer(r"operational at node \d+ \([^)]*?(\d+) writes", f.read()))


def median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2]


def restart_once(args, config, ws, k):
    daemon = e2e.Daemon(args.daemon, config, ws, log_name="daemon-%d.log" % k,
                        extra_args=["--plugin-dir", args.plugins] if args.plugins else [], stamp_exec=True)
    t_exec = daemon.exec_time
    t_wait = time.time()
    _, took = daemon.wait_until(e2e.all_operational(NAMES), 30, interval=0.005)
    took = None if took is None else t_wait + took - t_exec
    rc, _ = daemon.stop()
    first, plugins, serving, last_op = log_marks(daemon.log_path)
    return t_exec, took, first, plugins, last_op, writes_in(daemon.log_path), rc, serving


def main():
    args = e2e.parse_args(lambda p: p.add_argument("--restarts", type=int, default=5))
    report = e2e.Report("restart_in_uml")
    # On UML's tmpfs: a write to the host's file system (hostfs) holds the whole virtual machine
    # for the host's write, which the journal and page cache of a real machine never do.
    ws = e2e.Workspace("restart", args.keep, base="/run")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d%s" % (
        sm, s, n, ",bitrate=250" if sm.startswith("RM") else "") for (_, _, sm, s, n) in DEVICES]})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 3600}
    devices = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 10}}
               for (name, m, _, s, n) in DEVICES]
    # The outputs a plant runs: DDS (on lo inside UML) and Modbus TCP.
    os.environ["CYCLONEDDS_URI"] = '<General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General>'
    config = e2e.write_config(ws, [bus], devices, extra='[outputs.dds]\n[outputs.modbus]\nbind = "127.0.0.1"\nport = 1502\n')
    try:
        first = restart_once(args, config, ws, 0)
        report.check(first[1] is not None, "first start: all four configured and operational")
        runs = [restart_once(args, config, ws, k) for k in range(1, args.restarts + 1)]
        exec_s = [r[1] for r in runs if r[1] is not None]
        report.check(len(exec_s) == len(runs), "every restart operational", "%d of %d" % (len(exec_s), len(runs)))
        report.check(all(r[5] == 0 for r in runs), "no restart wrote to a device", str([r[5] for r in runs]))
        report.check(all(r[6] == 0 for r in runs), "every daemon exited 0", str([r[6] for r in runs]))
        logged = [r[4] - r[0] for r in runs if r[4] is not None]
        to_plugins = [r[3] - r[2] for r in runs if r[3] is not None and r[2] is not None]
        exec_to_log = [r[2] - r[0] for r in runs if r[2] is not None]
        to_serving = [r[7] - r[2] for r in runs if r[7] is not None and r[2] is not None]
        serving_to_op = [r[4] - r[7] for r in runs if r[7] is not None and r[4] is not None]
        if exec_s:
            print("FIGURE restart_operational_from_exec_s median=%.3f max=%.3f (n=%d, status polled)" % (
                median(exec_s), max(exec_s), len(exec_s)))
        if logged:
            print("FIGURE restart_operational_logged_s median=%.3f max=%.3f (n=%d, exec to the last 'operational' "
                  "log stamp)" % (median(logged), max(logged), len(logged)))
        if to_plugins and exec_to_log:
            print("FIGURE restart_phases_s exec_to_first_log=%.3f first_log_to_plugins=%.3f (medians)" % (
                median(exec_to_log), median(to_plugins)), flush=True)
        if to_serving and serving_to_op:
            print("FIGURE restart_bus_phases_s first_log_to_serving=%.3f serving_to_operational=%.3f (medians)" % (
                median(to_serving), median(serving_to_op)), flush=True)
    finally:
        e2e.shut_down(ws, None, sim)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
