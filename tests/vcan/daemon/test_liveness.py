"""Devices must always come back: faults an operator's plant
produces, injected on real SocketCAN (UML) against the real daemon and
cobridge-sim; each check asserts the device is back, its values flow, and
what the status said in between.

 1. reboot in the middle of a configuration SDO (cobridge-sim reboot-on-sdo),
    also while a rogue node answers on the devices' SDO COB-IDs: the boot-up
    restarts the configuration cleanly, operational <= 2 s after it
    (CiA 301 §7.2.8.3.3 boot-up; §7.2.4 SDO);
 2. a foreign NMT "stop all nodes" / "stop node n" (CiA 301 §7.2.8.2.1):
    the status follows the heartbeat state byte (0x04 stopped, §7.2.8.3.2.2);
    policy restart (default) starts them again and logs it, policy respect
    leaves it stopped and says so;
 3. interface down/up during configuration: operational <= 2 s after up;
15. an EMCY storm (4 500 EMCY in 3 s): the log is rate-limited with a count
    of what was left out, and every EMCY reaches the JSON tap.
Times: frames as read by a raw socket in UML, state changes from `since`.
"""
import json
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time

import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10),
           ("mt-a", "MC1-2800", "MC1-2800", 2001, 20),
           ("mt-b", "MC1-2800", "MC1-2800", 2002, 21),
           ("ifm-a", "RM9", "RM9000", 3001, 30)]
NAMES = [d[0] for d in DEVICES]
BOUND = 2.0  # seconds: back after the boot-up / after the interface is back


def can_socket(iface="vcan0"):
    s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    s.bind((iface,))
    return s


def send(sock, can_id, data):
    sock.send(struct.pack("=IB3x8s", can_id, len(data), bytes(data).ljust(8, b"\0")))


class RogueNode:
    """Answers every SDO request to `nodes` on their response COB-IDs with a
    wrong upload value / a bogus abort, as a misconfigured node would."""

    def __init__(self, nodes):
        self.nodes = set(nodes)
        self.sock = can_socket()
        self.sock.settimeout(0.05)
        self.stop_flag = False
        self.answers = 0
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.stop_flag:
            try:
                data = self.sock.recv(16)
            except socket.timeout:
                continue
            can_id, dlc = struct.unpack("=IB3x", data[:8])
            node = (can_id & 0x7FF) - 0x600
            if node not in self.nodes or dlc != 8:
                continue
            mux = data[9:12]
            if mux[0:2] == b"\x18\x10":
                continue  # identity stays truthful: the rogue corrupts configuration, not discovery
            if self.answers % 2 == 0:
                reply = bytes([0x43]) + mux + struct.pack("<I", 0xDEAD0000 + self.answers)
            else:
                reply = bytes([0x80]) + mux + struct.pack("<I", 0x08000000)
            send(self.sock, 0x580 + node, reply)
            self.answers += 1

    def stop(self):
        self.stop_flag = True
        self.thread.join()
        self.sock.close()


def tap_samples(path):
    """The sample lines of the JSON tap file, parsed (a line cut by the
    daemon's last write is skipped)."""
    with open(path) as f:
        for ln in f:
            try:
                j = json.loads(ln)
            except ValueError:
                continue
            if j.get("type") == "sample":
                yield j


def device(daemon, name):
    try:
        return daemon.devices().get(name)
    except (OSError, ValueError):
        return None


def wait_back(daemon, name, after, timeout):
    """Waits until `name` is operational and online with `since` >= after;
    returns (seconds from `after` to `since`, device) or (None, last)."""
    end = time.time() + timeout
    d = None
    while time.time() < end:
        d = device(daemon, name)
        if d and d["state"] == "operational" and d["online"] and d["since"] and \
                e2e.iso_to_epoch(d["since"]) >= after - 0.005:
            return e2e.iso_to_epoch(d["since"]) - after, d
        time.sleep(0.02)
    return None, d


def tpdo_after(listener, node, t, timeout=2.0):
    return listener.wait_for(lambda i, d: i == 0x180 + node, timeout, since=t)


def last_boot_up(listener, node, since):
    ups = [f for f in listener.snapshot(since) if f[1] == 0x700 + node and f[2] == b"\x00"]
    return ups


def scenario_reboot_mid_sdo(report, daemon, sim, listener, rogue_nodes=()):
    tag = " (rogue answering)" if rogue_nodes else ""
    t0 = time.time()
    rogue = RogueNode(rogue_nodes) if rogue_nodes else None
    try:
        for (_, _, _, serial, _) in DEVICES:
            sim.command("reboot-on-sdo %d 3" % serial)
        for (_, _, _, serial, _) in DEVICES:
            sim.command("power-cycle %d" % serial)
        if rogue:
            time.sleep(1.5)
    finally:
        if rogue:
            rogue.stop()
            report.check(rogue.answers > 0, "rogue node answered SDO requests", "%d answers" % rogue.answers)
    if rogue:
        # Whatever state the rogue left them in, a boot-up restarts them cleanly.
        time.sleep(0.3)
        t0 = time.time()
        for (_, _, _, serial, _) in DEVICES:
            sim.command("reboot-on-sdo %d 0" % serial)
            sim.command("power-cycle %d" % serial)
    for (name, _, _, serial, node) in DEVICES:
        expect_ups = 1 if rogue else 2
        took = None
        d = None
        # The boot-ups may still be on their way (a loaded host delays the
        # simulator and the listener): wait for them, not only for the state.
        deadline = time.time() + 6
        ups = []
        while time.time() < deadline:
            ups = last_boot_up(listener, node, t0)
            if not ups:
                time.sleep(0.02)
                continue
            took, d = wait_back(daemon, name, ups[-1][0], 0.3)
            if took is not None and len(ups) >= expect_ups:
                break
        report.check(len(ups) >= expect_ups, "%s: %d boot-ups seen%s" % (name, expect_ups, tag),
                     "%d seen" % len(ups))
        ok = took is not None and took <= BOUND
        report.check_bound(ok, "%s: operational <= %.0f s after its last boot-up%s" % (name, BOUND, tag),
                     "%.3f s" % took if took is not None else "state %r" % ((d["state"], d["last_error"]) if d else None,))
        if ok:
            f = tpdo_after(listener, node, e2e.iso_to_epoch(d["since"]))
            report.check(f is not None, "%s: values flow again%s" % (name, tag))


def scenario_foreign_stop(report, daemon, listener, ws, config_path):
    ctl = can_socket()
    # Policy restart (default): stop all -> started again by the gateway, and logged.
    t0 = time.time()
    send(ctl, 0x000, [0x02, 0x00])
    for (name, _, _, _, node) in DEVICES:
        stopped = listener.wait_for(lambda i, d: i == 0x700 + node and d == b"\x04", 2, since=t0)
        report.check(stopped is not None, "%s: heartbeat says stopped after a foreign 'stop all'" % name)
        if stopped is None:
            continue
        again = listener.wait_for(lambda i, d: i == 0x700 + node and d == b"\x05", 2, since=stopped[0])
        f = tpdo_after(listener, node, again[0] if again else t0, 2)
        report.check(again is not None and f is not None,
                     "%s: started again by the gateway (policy restart), values flow" % name)
        report.check_bound(again is not None and again[0] - stopped[0] < 1.0,
                           "%s: started again within 1 s" % name,
                           "operational heartbeat %.3f s after the stopped one" % (again[0] - stopped[0]) if again else "")
    time.sleep(0.3)
    log = open(daemon.log_path).read()
    n = log.count("was stopped by another NMT master; starting it again")
    report.check(n >= len(DEVICES), "the log names each foreign stop", "%d lines" % n)
    report.check(all(d["state"] == "operational" for d in daemon.devices().values() if d["name"] in NAMES),
                 "all operational after the foreign stop")

    # Policy respect (SIGHUP): stop node 20 -> status stopped, left so; started by the other master -> operational.
    text = open(config_path).read().replace('name = "line1"', 'name = "line1"\nforeign_nmt = "respect"')
    open(config_path, "w").write(text)
    mark = daemon.log_size()
    os.kill(daemon.pid, signal.SIGHUP)
    report.check(daemon.wait_log("bus line1: new configuration applied", mark, 30),
                 "SIGHUP: the bus runs with the new policy (logged by its thread)")
    t1 = time.time()
    send(ctl, 0x000, [0x02, 20])
    st, took = daemon.wait_until(lambda s: any(d["name"] == "mt-a" and d["state"] == "stopped" and
                                               d["nmt"] == "stopped" for b in s["buses"] for d in b["devices"]), 2)
    report.check(took is not None, "mt-a: status says stopped (policy respect)",
                 "%.3f s after 'stop node 20'" % (time.time() - t1) if took is not None else "")
    time.sleep(1.0)
    d = device(daemon, "mt-a")
    late = [f for f in listener.snapshot(time.time() - 0.6) if f[1] == 0x180 + 20]
    report.check(d is not None and d["state"] == "stopped" and not late,
                 "mt-a: left stopped, no values, status unchanged 1 s later",
                 "state %s, %d TPDOs" % (d and d["state"], len(late)))
    t2 = time.time()
    send(ctl, 0x000, [0x01, 20])
    took, d = wait_back(daemon, "mt-a", t2, 2)
    report.check(took is not None and tpdo_after(listener, 20, t2) is not None,
                 "mt-a: operational again when the other master starts it")
    ctl.close()


def scenario_link_down_during_configuration(report, daemon, sim, listener):
    """Returns the listener to use from now on (the old one's socket saw ENETDOWN)."""
    for (_, _, _, serial, _) in DEVICES:
        sim.command("power-cycle %d" % serial)
    # The configurations are under way (first SDO requests seen), then the link goes.
    listener.wait_for(lambda i, d: 0x601 <= i <= 0x67F, 2, since=time.time() - 0.5)
    time.sleep(0.05)
    subprocess.run(["ip", "link", "set", "vcan0", "down"], check=True)
    time.sleep(1.5)
    t_up = time.time()
    subprocess.run(["ip", "link", "set", "vcan0", "up"], check=True)
    listener.close()
    listener = e2e.CanListener("vcan0")
    for (name, _, _, _, node) in DEVICES:
        took, d = wait_back(daemon, name, t_up, BOUND + 3)
        report.check_bound(took is not None and took <= BOUND, "%s: operational <= %.0f s after the interface is back" %
                     (name, BOUND), "%.3f s" % took if took is not None else "state %r" % (d["state"] if d else None,))
        if took is not None:
            report.check(tpdo_after(listener, node, t_up + took) is not None,
                         "%s: values flow after the link came back" % name)
    return listener


def emcy_log_counts(daemon, before):
    """rot-a's EMCY log lines since `before`, its summary lines, and the EMCY they say were left out."""
    log = open(daemon.log_path).read()
    lines = log.count("device rot-a (node 10): ") - before
    summary = [ln for ln in log.splitlines() if "more EMCY not logged" in ln and "rot-a" in ln]
    return lines, summary, sum(int(ln.split("): ")[1].split(" more")[0]) for ln in summary)


CONTROL_DROPS = re.compile(r"the kernel dropped (\d+) frames at the control thread's full receive queue")


def control_drops_logged(daemon):
    """Frames the log says the control thread's socket lost (its receive queue full)."""
    return sum(int(m.group(1)) for m in CONTROL_DROPS.finditer(open(daemon.log_path).read()))


def scenario_emcy_storm(report, daemon, tap_path):
    node = 10
    ctl = can_socket()
    before = open(daemon.log_path).read().count("device rot-a (node 10): ")
    drops_before = control_drops_logged(daemon)
    sent = 0
    t0 = time.time()
    while time.time() - t0 < 3.0:
        for _ in range(15):
            code = 0x1000 + (sent % 0x100)
            send(ctl, 0x080 + node, [code & 0xFF, code >> 8, 0x01, sent & 0xFF, 0, 0, 0, 0])
            sent += 1
        time.sleep(0.01)
    ctl.close()
    # The log budget's window ends (10 s after its first line): its summary follows. Waited for
    # until the log accounts for every EMCY sent, at most 60 s (a slow daemon spreads the storm's
    # handling over more than one window). EMCY the control thread never read (its socket's
    # receive queue full on a loaded host) count only where the log declares that loss.
    end = time.time() + 60
    while True:
        lines, summary, suppressed = emcy_log_counts(daemon, before)
        drops = control_drops_logged(daemon) - drops_before
        if suppressed + lines - len(summary) + drops >= sent or time.time() > end:
            break
        time.sleep(0.2)
    report.check(lines <= 2 * 5 + len(summary) + 2, "EMCY storm: log rate-limited",
                 "%d EMCY sent, %d log lines" % (sent, lines))
    # A sanitizer build's control thread falls behind the storm and its socket's receive queue
    # overflows (the hot path's own socket keeps up: the tap check below): the log then accounts
    # for what that thread read, so the count is a bound there, and the summary is still judged.
    report.check(bool(summary), "EMCY storm: the log summarises what it left out", "%d summarised" % suppressed)
    report.check_bound(suppressed + lines - len(summary) + drops >= sent, "EMCY storm: the log counts what it left out",
                       "%d sent: %d logged, %d summarised, %d frames declared lost at the control socket" %
                       (sent, lines - len(summary), suppressed, drops))
    got = sum(1 for j in tap_samples(tap_path)
              if j.get("kind") == "emcy" and j.get("node_id") == node and 0x1000 <= j.get("emcy_code", 0) < 0x1100)
    report.check(got == sent, "EMCY storm: every EMCY reached the JSON tap", "%d of %d" % (got, sent))


def scenario_unknown_node(report, daemon, tap_path):
    """Item 4: frames of a node nobody knows are counted, never published
    under another device's index (Modbus slot / DDS instance)."""
    ctl = can_socket()
    before = daemon.status()["buses"][0]["counters"]["unknown_node_frames"]
    for i in range(20):
        send(ctl, 0x700 + 99, [0x05])
        send(ctl, 0x080 + 99, [0x00, 0x10, 0x01, i, 0, 0, 0, 0])
        send(ctl, 0x180 + 99, [1, 2, 3, 4])
    ctl.close()
    time.sleep(0.5)
    after = daemon.status()["buses"][0]["counters"]["unknown_node_frames"]
    report.check(after - before >= 60, "frames of an unknown node are counted",
                 "%d counted (60 sent)" % (after - before))
    nodes_of = {}
    wrong = 0
    for j in tap_samples(tap_path):
        if j.get("node_id") == 99:
            wrong += 1
        nodes_of.setdefault(j.get("device_index"), set()).add(j.get("node_id"))
    mixed = {k: sorted(v) for k, v in nodes_of.items() if len(v) > 1}
    report.check(wrong == 0 and not mixed, "no sample of an unknown node, one node per device index",
                 "%d samples of node 99; indices with several nodes: %s" % (wrong, mixed))


def scenario_reload_reorder(report, daemon, ws, devices, bus, extra):
    """Item 6: a reload applies to every layer or is refused with a reason:
    reordering devices would move them to other Modbus slots / DDS
    instances, so it is refused and the running configuration stays."""
    path = e2e.write_config(ws, [dict(bus, foreign_nmt="respect")], list(reversed(devices)), extra=extra)
    os.kill(daemon.pid, signal.SIGHUP)
    # A wait for the verdict, not a bound: an -O0 sanitizer daemon on the QEMU
    # bed took longer than 10 s to log it once (CI run of 2026-11-29).
    end = time.time() + (60 if e2e.SANITIZER else 10)
    while time.time() < end and "reload rejected" not in open(daemon.log_path).read():
        time.sleep(0.1)
    log = open(daemon.log_path).read()
    report.check('would move from index' in log and "reload rejected" in log,
                 "reload reordering devices is refused with its reason",
                 "; ".join([ln for ln in log.splitlines() if "reload rejected" in ln][-1:]))
    report.check(daemon.proc.poll() is None and all(
        d["state"] == "operational" for d in daemon.devices().values() if d["name"] in NAMES),
                 "still running the previous configuration")
    return path


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_liveness")
    ws = e2e.Workspace("liveness", args.keep)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d%s" % (
        sm, s, n, ",bitrate=250" if sm.startswith("RM") else "") for (_, _, sm, s, n) in DEVICES]})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30, "node_pool": "40-60"}
    devices = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 50}}
               for (name, m, _, s, n) in DEVICES]
    tap = ws.path("tap.jsonl")
    extra = '[outputs.jsontap]\npath = "%s"\n' % tap
    config = e2e.write_config(ws, [bus], devices, extra=extra)
    daemon = e2e.Daemon(args.daemon, config, ws, extra_args=["--plugin-dir", args.plugins])
    with e2e.shut_down_after(ws, lambda: (daemon, sim, listener)):
        report.check(daemon.wait_socket(), "control socket up")
        _, took = daemon.wait_until(e2e.all_operational(NAMES), 60, interval=0.1)
        if not report.check(took is not None, "four devices operational", "%.2f s" % took if took else ""):
            print(daemon.tail(60))
        time.sleep(0.5)
        scenario_reboot_mid_sdo(report, daemon, sim, listener)
        time.sleep(0.5)
        scenario_reboot_mid_sdo(report, daemon, sim, listener, rogue_nodes=[n for (*_, n) in DEVICES])
        time.sleep(0.5)
        listener = scenario_link_down_during_configuration(report, daemon, sim, listener)
        time.sleep(0.5)
        scenario_emcy_storm(report, daemon, tap)
        scenario_foreign_stop(report, daemon, listener, ws, config)
        scenario_unknown_node(report, daemon, tap)
        scenario_reload_reorder(report, daemon, ws, devices, bus, extra)
        e2e.check_clean_exit(report, daemon, tail=80)
        daemon = None
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
