"""The bus controller's CPU, this build against another one in the same run.

Runs inside the CAN test bed (tests/vcan/run-in-vcan, vcan0). For each
daemon given (--daemon LABEL=PATH[:DEVICE_DIR], in turn, --rounds times):
32 factory-fresh multiturns (cobridge-sim MC1-2800 at FFh, heartbeat and
TPDO every 100 ms) are commissioned by that daemon from a fresh state
directory, then run for --seconds with nothing asked of the daemon.

Printed per daemon, the least of its rounds (the run's noise only adds):
  FIGURE controller LABEL commission_cpu_s X     the daemon's CPU (user +
         system, every thread) from exec until all 32 are operational;
  FIGURE controller LABEL cpu_per_frame_us X     its CPU over the quiet
         window per frame on vcan0 (the kernel's rx_packets).
With outputs off, the threads that work are the bus's control thread (LSS,
SDO, NMT, heartbeat supervision) and its receive thread (the hot path's
decoding of the same frames). Between the builds compared by scripts/bench
(c455294 and now) the hot path's decoding did not change; can/ did a little
(the control socket's receive queue and kernel stamps), and counts in.
"""
import argparse
import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "vcan", "daemon"))
import e2e  # noqa: E402

COUNT = 32
TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid):
    """utime + stime of every thread of pid, in seconds (/proc/PID/stat, fields 14 and 15)."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def rx_frames(iface="vcan0"):
    with open("/sys/class/net/%s/statistics/rx_packets" % iface) as f:
        return int(f.read())


def write_config(ws, device_dir):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250}
    devices = [{"name": "mt%02d" % (i + 1), "bus": "line1", "serial": 5001 + i, "model": "MC1-2800",
                "node_id": i + 1, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 100}}
               for i in range(COUNT)]
    return e2e.write_config(ws, [bus], devices, level="warn", device_dir=device_dir)


def one_round(args, label, daemon_path, device_dir):
    ws = e2e.Workspace("controller-cpu", base="/run")
    specs = ["MC1-2800:serial=%d,node=unconfigured" % (5001 + i) for i in range(COUNT)]
    sim = e2e.Simulator(args.sim, ws, {"vcan0": specs})
    daemon = None
    try:
        daemon = e2e.Daemon(daemon_path, write_config(ws, device_dir), ws)
        names = ["mt%02d" % (i + 1) for i in range(COUNT)]
        _, took = daemon.wait_until(e2e.all_operational(names), 180, interval=0.2)
        if took is None:
            raise RuntimeError("%s: not all %d operational within 180 s:\n%s" % (label, COUNT, daemon.tail(20)))
        commission = cpu_s(daemon.pid)
        time.sleep(2.0)
        c0, f0 = cpu_s(daemon.pid), rx_frames()
        time.sleep(args.seconds)
        c1, f1 = cpu_s(daemon.pid), rx_frames()
        per_frame = (c1 - c0) / max(1, f1 - f0) * 1e6
        print("round %s: operational after %.2f s, commission CPU %.2f s; quiet %d s: %d frames, CPU %.2f s, "
              "%.2f us/frame" % (label, took, commission, args.seconds, f1 - f0, c1 - c0, per_frame), flush=True)
        return commission, per_frame
    finally:
        if daemon is not None:
            daemon.stop()
        sim.stop()
        shutil.rmtree(ws.dir, ignore_errors=True)
        shutil.rmtree(ws.run, ignore_errors=True)


def parse_daemon(text):
    label, _, rest = text.partition("=")
    path, _, device_dir = rest.partition(":")
    if not label or not os.access(path, os.X_OK):
        raise SystemExit("--daemon wants LABEL=PATH[:DEVICE_DIR] with an executable PATH, not %r" % text)
    return label, path, device_dir or e2e.DEVICES_DIR


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--daemon", action="append", required=True, type=parse_daemon)
    p.add_argument("--sim", required=True)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--seconds", type=int, default=20)
    args = p.parse_args()
    tempfile.tempdir = "/run"
    results = {label: [] for label, _, _ in args.daemon}
    for _ in range(args.rounds):
        for label, path, device_dir in args.daemon:  # alternating: drifts of the guest hit both
            results[label].append(one_round(args, label, path, device_dir))
    for label, runs in results.items():
        print("FIGURE controller %s commission_cpu_s %.3f" % (label, min(r[0] for r in runs)))
        print("FIGURE controller %s cpu_per_frame_us %.3f" % (label, min(r[1] for r in runs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
