"""Files that survive bad disks and bad actors, end to end:
the daemon, the CLI and cobridge-sim on vcan0.

The state file (docs/operations.md, "A state file that cannot be read"):
 * assignments.state replaced by 2 KiB of binary garbage while the daemon is
   stopped; after the start its bytes are still on disk, set aside as
   assignments.state.bad-<UTC time>, and nothing writes a new state file;
 * the log names the file and where its bytes are; `cobridge status` shows
   the hold as a problem of the bus; `cobridge commission` is refused;
 * no node-ID is assigned: a factory-fresh device (FFh) the configuration
   gives node 20 hears no LSS request (CiA 305: no 7E5 frame on the bus at
   all), while the device at the node-ID its configuration gives is
   configured and operational as ever;
 * a restart does not take the missing file for a fresh start: still held;
 * the operator's decision, an empty state file and a reload (SIGHUP),
   releases the hold: the factory-fresh device is commissioned to node 20,
   the state file is written again, the set-aside copy is still there.
The captures folder and the timeline journal (docs/security.md): a symbolic
link planted under a capture's name (to a file the daemon must not read) is
never listed, served or followed, and the log names it; one planted as the
bus's timeline journal is refused, and the file it names is untouched.
"""
import glob
import os
import random
import signal
import sys
import time

import e2e

ROT_SERIAL, ROT_NODE = 1001, 10
MT_SERIAL, MT_NODE = 2001, 20
LSS_MASTER = 0x7E5
PLANTED = "line1-20250101T000000.000Z-emcy.log"


def files_of(ws):
    """The state directory's files (not the sub-directories)."""
    return sorted(n for n in os.listdir(ws.state) if os.path.isfile(os.path.join(ws.state, n)))


def set_aside(ws):
    return sorted(glob.glob(os.path.join(ws.state, "assignments.state.bad-*")))


def bus_problems(daemon):
    try:
        return daemon.status()["buses"][0]["problems"]
    except (OSError, ValueError, KeyError, IndexError):
        return []


def lss_frames(listener, since):
    return [d.hex() for t, cid, d in listener.snapshot(since) if cid == LSS_MASTER]


def plant(ws):
    """2 KiB of garbage as the state file; symbolic links as a capture and as the journal."""
    os.makedirs(os.path.join(ws.state, "captures"))
    os.makedirs(os.path.join(ws.state, "timelines"))
    garbage = bytes(random.Random(38).getrandbits(8) for _ in range(2048))
    with open(os.path.join(ws.state, "assignments.state"), "wb") as f:
        f.write(garbage)
    for name in ("victim-capture", "victim-journal"):
        with open(ws.path(name), "w") as f:
            f.write("not the daemon's\n")
    os.symlink(ws.path("victim-capture"), os.path.join(ws.state, "captures", PLANTED))
    os.symlink(ws.path("victim-journal"), os.path.join(ws.state, "timelines", "line1.timeline"))
    return garbage


def check_held(report, args, ws, daemon, listener, garbage, t0, what):
    """The hold after a start: bytes kept, log and status say so, nothing assigned."""
    _, took = daemon.wait_until(e2e.all_operational(["rot-a"]), 30, interval=0.1)
    report.check(took is not None, what + ": the device at its configured node-ID is operational", daemon.tail(20))
    aside = set_aside(ws)
    kept = len(aside) == 1 and open(aside[0], "rb").read() == garbage
    report.check(kept and "assignments.state" not in files_of(ws),
                 what + ": the garbage is on disk, set aside, and no new state file is written", "%r" % files_of(ws))
    problems = bus_problems(daemon)
    held = [p for p in problems if "could not be read" in p or "is missing and" in p]
    report.check(len(held) == 1 and "no node-ID is assigned until an operator decides" in held[0] and
                 os.path.basename(aside[0] if aside else "?") in held[0],
                 what + ": the status names the hold and the set-aside copy", "%r" % problems)
    code, out, err = e2e.run_cli(args.cli, "status", "--control", ws.control)
    report.check(code == 0 and "problems on line1:" in out and "no node-ID is assigned" in out,
                 what + ": cobridge status shows it under the bus's problems", out[-600:] + err)
    code, out, err = e2e.run_cli(args.cli, "commission", "--control", ws.control)
    report.check(code == 5 and "commissioning refused" in out + err,
                 what + ": cobridge commission is refused (exit 5)", "exit %d: %s" % (code, out + err))
    time.sleep(5.0)  # the full probe and the FFh search take about 2 s when allowed
    lss = lss_frames(listener, t0)
    devs = daemon.devices()
    report.check(not lss and devs.get("mt-b", {}).get("state") != "operational",
                 what + ": no node-ID assigned (no LSS request on the bus, mt-b not commissioned)",
                 "LSS: %r; mt-b %r" % (lss[:4], devs.get("mt-b", {}).get("state")))


def check_links(report, args, ws, daemon):
    """Symbolic links in the captures folder and as the journal: never followed."""
    code, out, err = e2e.run_cli(args.cli, "capture", "list", "--control", ws.control)
    report.check(code == 0 and PLANTED not in out, "a link in the captures folder is not listed", out + err)
    code, out, err = e2e.run_cli(args.cli, "capture", "get", PLANTED, "--control", ws.control)
    report.check(code != 0 and "not the daemon's" not in out, "nor served", "exit %d: %s" % (code, out + err))
    with open(daemon.log_path, errors="replace") as f:
        log = f.read()
    report.check(PLANTED in log and "a symbolic link; not listed, served or deleted" in log,
                 "the log names the link in the captures folder", log[-800:])
    report.check("line1.timeline" in log and "symbolic link; refused (never followed)" in log,
                 "the log names the link planted as the journal", log[-800:])
    code, out, err = e2e.run_cli(args.cli, "capture", "now", "line1", "--control", ws.control)
    end = time.time() + 10  # capture_after_s (2 s) and the writer's turn, on a loaded machine
    while time.time() < end and not glob.glob(os.path.join(ws.state, "captures", "line1-*-operator.log")):
        time.sleep(0.05)
    report.check(code == 0 and glob.glob(os.path.join(ws.state, "captures", "line1-*-operator.log")),
                 "a capture is still written beside the link", out + err)
    victims = [open(ws.path(n)).read() for n in ("victim-capture", "victim-journal")]
    report.check(victims == ["not the daemon's\n"] * 2 and
                 os.path.islink(os.path.join(ws.state, "captures", PLANTED)),
                 "the files the links name are untouched, the link kept", "%r" % victims)


def check_released(report, ws, daemon, listener):
    """The operator's decision: an empty state file and a reload."""
    open(os.path.join(ws.state, "assignments.state"), "w").close()
    t0 = time.time()
    daemon.proc.send_signal(signal.SIGHUP)
    # mt-b alone: on a loaded machine rot-a's 100 ms heartbeat may be missed meanwhile.
    _, took = daemon.wait_until(e2e.all_operational(["mt-b"]), 60, interval=0.1)
    report.check(took is not None and daemon.devices()["mt-b"]["node_id"] == MT_NODE,
                 "after an empty state file and a reload: the FFh device is commissioned to its node-ID",
                 "%.2f s" % took if took is not None else daemon.tail(30))
    report.check(bool(lss_frames(listener, t0)), "with LSS on the bus again")
    report.check(not any("could not be read" in p or "is missing and" in p for p in bus_problems(daemon)),
                 "the status no longer names the hold", "%r" % bus_problems(daemon))
    path = os.path.join(ws.state, "assignments.state")
    end = time.time() + 10
    while time.time() < end and "serial=0x7D1" not in open(path).read():
        time.sleep(0.05)
    state = open(path).read()
    report.check("serial=0x7D1" in state and len(set_aside(ws)) == 1,
                 "the state file is written again, the set-aside copy still there", state[:300])


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_state_file")
    ws = e2e.Workspace("state-file", args.keep)
    garbage = plant(ws)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["RFC-4800:serial=%d,node=%d" % (ROT_SERIAL, ROT_NODE),
                                                 "MC1-2800:serial=%d,node=unconfigured" % MT_SERIAL]})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30, "node_pool": "40-60"}
    tpdo = {"mapping": ["position"], "transmission": "event", "event_timer_ms": 100}
    devices = [{"name": "rot-a", "bus": "line1", "serial": ROT_SERIAL, "model": "RFC-4800", "node_id": ROT_NODE,
                "heartbeat_ms": 100, "tpdo1": tpdo},
               {"name": "mt-b", "bus": "line1", "serial": MT_SERIAL, "model": "MC1-2800", "node_id": MT_NODE,
                "heartbeat_ms": 100, "tpdo1": tpdo}]
    config = e2e.write_config(ws, [bus], devices, extra="[control]\nwrites_enabled = true\nwrite_group = \"\"\n")
    t0 = time.time()
    daemon = e2e.Daemon(args.daemon, config, ws)
    with e2e.shut_down_after(ws, lambda: (daemon, sim, listener)):
        report.check(daemon.wait_socket(), "control socket up")
        aside = set_aside(ws)
        report.check(daemon.wait_log("state file %s" % os.path.join(ws.state, "assignments.state")) and
                     bool(aside) and daemon.wait_log("set aside as " + aside[0]),
                     "the log names the state file and where its bytes are now", daemon.tail(10))
        check_held(report, args, ws, daemon, listener, garbage, t0, "first start")
        check_links(report, args, ws, daemon)
        e2e.check_clean_exit(report, daemon, tail=40)
        t0 = time.time()
        daemon = e2e.Daemon(args.daemon, config, ws, log_name="daemon-2.log")
        report.check(daemon.wait_socket(), "restarted: control socket up")
        check_held(report, args, ws, daemon, listener, garbage, t0, "after a restart")
        check_released(report, ws, daemon, listener)
        e2e.check_clean_exit(report, daemon, tail=40)
        daemon = None
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
