#!/usr/bin/python3
"""Two devices at the factory node-ID 127 (J§1.2.2,
E§3.1) on one bus. An SDO read of 0x1018 sub 4 (40 18 10 04 00 00 00 00 to
0x67F) is answered by both, with two different serial numbers: the collision
a shared factory node-ID causes, which only LSS resolves (J§1.5, E§6).
"""

import simtest
from simtest import REPORT, Bus, Sim, check, hexs, wait_boot_ups


def run(args):
    bus = Bus(args.iface)
    sim = Sim(args.sim, ["--iface", args.iface, "--device", "RFC-4800:serial=1001",
                         "--device", "MC1-2800:serial=2002"])
    wait_boot_ups(bus, [127, 127])
    REPORT.ok("two boot-ups on 77F")
    bus.drain()
    bus.send(0x67F, bytes.fromhex("4018100400000000"))
    answers = bus.collect(lambda f: f.can_id == 0x5FF, 1.0)
    for a in answers:
        print("    5FF: %s" % hexs(a.data), flush=True)
    check(len(answers) == 2, "expected 2 answers on 5FF, got %d" % len(answers))
    serials = sorted(int.from_bytes(a.data[4:8], "little") for a in answers)
    for a in answers:
        check(a.data[:4] == bytes.fromhex("43181004"), "not an expedited 4-byte upload answer: %s" % hexs(a.data))
    check(serials == [1001, 2002], "serials %s, expected [1001, 2002]" % serials)
    check(answers[0].data != answers[1].data, "the two answers are identical")
    REPORT.ok("CiA 301, J§1.2.2: 0x1018/4 read at node 127 gets two different answers",
              "43 18 10 04 E9 03 00 00 and 43 18 10 04 D2 07 00 00")
    sim.stop()


if __name__ == "__main__":
    simtest.main(run)
