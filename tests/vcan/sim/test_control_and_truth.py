#!/usr/bin/python3
"""cobridge-sim's own machinery end to end: the control channel (stdin and
the Unix socket), power and silence commands, the bus faults (Linux CAN error
frames, <linux/can/error.h>; flood; babbling node), two buses in one
process, SIGTERM, and the truth file (format of docs/devices.md, compared
with what was on the bus).
"""

import os
import re
import signal
import socket
import time

import simtest
from simtest import REPORT, Bus, Sim, check, hexs, sdo_read, wait_boot_ups

TRUTH_LINE = re.compile(
    r"^(\d+) (vcan\d) (\d+) (\d+) (tpdo1|tpdo2|emcy|heartbeat|boot-up|sdo|lss|guard) ([0-9A-F]{3}|[0-9A-F]{8}) "
    r"([0-8]) (-|(?:[0-9A-F]{2})+)( pos=-?\d+)?( speed=-?\d+)?( cam=\d+)?( area=\d+)?( emcy=[0-9A-F]{4})?$")


def socket_command(path, line):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(5)
    s.connect(path)
    s.sendall((line + "\n").encode())
    buf = b""
    while not buf.endswith(b"\n"):
        chunk = s.recv(4096)
        if not chunk:
            break
        buf += chunk
    s.close()
    return buf.decode().rstrip("\n")


def run(args):
    truth = args.tmp + "/truth.txt"
    control = args.tmp + "/control.sock"
    bus0 = Bus(args.iface, errors=True)
    bus1 = Bus(args.iface2)
    sim = Sim(args.sim, ["--iface", args.iface, "--device", "RFC-4800:serial=5,node=1",
                         "--device", "MC1-2800:serial=6,node=2",
                         "--iface", args.iface2, "--device", "RM9000:serial=7,node=3",
                         "--truth", truth, "--control", control])
    wait_boot_ups(bus0, [1, 2])
    wait_boot_ups(bus1, [3])
    REPORT.ok("two buses in one process: boot-ups 701, 702 on %s and 703 on %s" % (args.iface, args.iface2))

    want_list = "ok 3 5:RFC-4800:%s:1:pre-operational 6:MC1-2800:%s:2:pre-operational 7:RM9000:%s:3:pre-operational" % (
        args.iface, args.iface, args.iface2)
    got = sim.command("list")
    check(got == want_list, "list: %r, expected %r" % (got, want_list))
    REPORT.ok("list on stdin", got)
    got = socket_command(control, "list")
    check(got == want_list, "list on the control socket: %r" % got)
    REPORT.ok("list on the Unix control socket")
    for bad, expect in (("fault 999 clear", "error no device with serial 999"),
                        ("flood vcan9 10", "error no simulated bus on interface 'vcan9'"),
                        ("fault 5 melting", "error fault kind must be")):
        got = sim.command(bad, expect_ok=False)
        check(got.startswith(expect), "%r -> %r, expected %r..." % (bad, got, expect))
    REPORT.ok("errors are one 'error ...' line each")

    # Heartbeats (CiA 301 0x1017) to watch power and silence.
    for n in (1, 2):
        simtest.sdo_write(bus0, n, 0x1017, 0, 20, 2)
    beats = bus0.collect(lambda f: f.can_id in (0x701, 0x702), 0.5)
    check(sum(1 for f in beats if f.can_id == 0x701) >= 10, "no 20 ms heartbeat from node 1")

    sim.command("power-off 5")
    got = sim.command("list")
    check(" 5:RFC-4800:%s:1:off " % args.iface in got, "list after power-off: %r" % got)
    bus0.drain()
    beats = bus0.collect(lambda f: f.can_id in (0x701, 0x702), 0.5)
    check(not any(f.can_id == 0x701 for f in beats), "powered-off node 1 still sends")
    check(any(f.can_id == 0x702 for f in beats), "node 2 stopped sending with node 1")
    REPORT.ok("power-off: node 1 silent, node 2 goes on")
    bus0.drain()
    sim.command("power-on 5")
    wait_boot_ups(bus0, [1])
    REPORT.ok("power-on: boot-up 701: 00")

    sim.command("silence 6 on")
    got = sim.command("list")
    check("6:MC1-2800:%s:2:pre-operational,silent" % args.iface in got, "list after silence: %r" % got)
    f = simtest.exchange(bus0, 0x602, bytes.fromhex("4018100400000000"), 0x582, timeout=0.5)
    check(f is None, "silenced node 2 answered SDO: %r" % f)
    sim.command("silence 6 off")
    check(sdo_read(bus0, 2, 0x1018, 4) == 6, "node 2 serial after silence off")
    REPORT.ok("silence on/off: no answer while silent, state kept (serial 6 answers again)")

    # Linux CAN error frames on vcan0 (CAN_RAW_ERR_FILTER set on bus0).
    for kind, ident, d1 in (("error-passive", 0x04 | 0x200, 0x30), ("bus-off", 0x40, 0x00),
                            ("restarted", 0x100, 0x00), ("error-warning", 0x04 | 0x200, 0x0C),
                            ("error-active", 0x04 | 0x200, 0x40)):
        bus0.drain()
        sim.command("bus-error %s %s" % (args.iface, kind))
        f = bus0.wait_for(lambda fr: fr.is_error)
        check(f is not None, "no error frame for %s" % kind)
        check(f.can_id == ident and len(f.data) == 8 and f.data[1] == d1,
              "%s: error frame id %#x data %s, expected id %#x data[1] %#x" % (kind, f.can_id, hexs(f.data), ident, d1))
        REPORT.ok("bus-error %s: error frame" % kind, "class %#05x data %s" % (f.can_id, hexs(f.data)))

    # Flood: identifier 0 back to back; the simulated devices lose arbitration.
    bus0.drain()
    sim.command("flood %s 500" % args.iface)
    frames = bus0.collect(lambda fr: not fr.is_error, 1.5)
    # Judged by order on the bus (the socket keeps it), not by when Python
    # got round to reading: UML's receiver lags behind a flood.
    idx = [i for i, f in enumerate(frames) if f.can_id == 0 and len(f.data) == 0]
    check(len(idx) > 200, "flood: only %d frames" % len(idx))
    first, last = idx[0], idx[-1]
    hb = lambda f: f.can_id in (0x701, 0x702)
    during = [f for f in frames[first:last] if hb(f)]
    after = [f for f in frames[last:] if hb(f)]
    print("    flood: %d frames of id 000 (%.0f frames/s); heartbeats between them %d, after %d" % (
        len(idx), len(idx) / 0.5, len(during), len(after)), flush=True)
    check(not during, "heartbeats got through the flood: %r" % during[:3])
    check(after, "no heartbeat after the flood")
    REPORT.ok("flood: id 000 DLC 0 back to back, devices silent during it, heartbeats resume")

    bus1.drain()
    sim.command("babble %s 1A5 300" % args.iface2)
    frames = bus1.collect(lambda fr: fr.can_id == 0x1A5, 0.5)
    check(len(frames) > 100 and len({f.data for f in frames}) == len(frames),
          "babble: %d frames, %d distinct" % (len(frames), len({f.data for f in frames})))
    REPORT.ok("babble: id 1A5 back to back with changing data", "%d frames" % len(frames))

    stats = sim.command("stats")
    m = re.search(r"%s:sent=(\d+),refused=(\d+),received=(\d+),local=(\d+)" % args.iface, stats)
    check(m and int(m.group(4)) > 0, "stats: no in-process deliveries between the devices of %s: %r" % (args.iface,
                                                                                                        stats))
    check(int(m.group(2)) > 0, "stats: no device frames refused during the flood: %r" % stats)
    REPORT.ok("sibling devices get each other's frames in process", stats)

    # SIGTERM: clean exit, truth file flushed.
    bus0.drain()
    os.kill(sim.proc.pid, signal.SIGTERM)
    code = sim.proc.wait(10)
    check(code == 0, "exit code %d after SIGTERM" % code)
    REPORT.ok("SIGTERM: exit code 0")

    lines = open(truth).read().splitlines()
    check(lines, "empty truth file")
    bad = [ln for ln in lines if not TRUTH_LINE.match(ln)]
    check(not bad, "truth lines not in the documented format: %r" % bad[:3])
    boot = [ln.split()[1:8] for ln in lines if " boot-up " in ln]
    for want in (["vcan0", "5", "1", "boot-up", "701", "1", "00"], ["vcan0", "6", "2", "boot-up", "702", "1", "00"],
                 ["vcan1", "7", "3", "boot-up", "703", "1", "00"]):
        check(want in boot, "truth file lacks %s" % " ".join(want))
    hb = [ln for ln in lines if " heartbeat 701 " in ln]
    check(len(hb) >= 10, "truth file has %d heartbeats of node 1" % len(hb))
    sdo = [ln for ln in lines if ln.split()[2] == "6" and " sdo 582 8 4318100406000000" in ln]
    check(sdo, "truth file lacks node 2's SDO answer 43 18 10 04 06 00 00 00")
    REPORT.ok("truth file: %d lines, all in the documented format; boot-ups, heartbeats, SDO answers" % len(lines))


if __name__ == "__main__":
    simtest.main(run)
