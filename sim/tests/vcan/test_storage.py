#!/usr/bin/python3
"""Non-volatile storage across a power cycle
(control command `power-cycle`, simulator state directory).

Novotechnik (E§11, E§7.1; same rules J§1.10, J§1.6.1):
  * configured through SDO, 'save' on 0x1010/1, power-cycled: stored values;
  * configured, not stored, power-cycled: defaults;
  * 'load' on 0x1011/1 reverts RAM to the last stored values (E§11 "will
    upload data from the non-volatile memory"; J§1.10, E§11);
  * 'kill' on 0x1010/1 erases the stored values: defaults, also after a cycle;
  * storing only in pre-operational: abort 0x08000022 otherwise (E§11);
  * node-ID 0x2000 stored with 'save' on 0x1010/4 comes back after a cycle.
ifm (F§6.3.2-6.3.5, F§7.3 0x1011):
  * 'save' + power cycle keeps the value;
  * 'load' restores the factory settings, active only after a reset; the
    EEPROM is not overwritten, so a power cycle without 'save' brings the
    stored values back; 'load' + 'save' makes the defaults permanent;
  * 0x2300 <- 0x55AAAA55 saves and resets by itself (boot-up).
"""

import simtest
from simtest import REPORT, Bus, Sim, check, nmt, sdo_abort_code, sdo_read, sdo_write, wait_boot_ups

SAVE, LOAD, KILL = 0x65766173, 0x64616F6C, 0x6C6C696B


def expect(bus, node, index, sub, want, label):
    v = sdo_read(bus, node, index, sub)
    if v != want:
        REPORT.fail("%s: %04X/%d = %d (%#x), expected %d (%#x)" % (label, index, sub, v, v, want, want))
    else:
        REPORT.ok(label, "%04X/%d = %d" % (index, sub, v))


def power_cycle(bus, sim, serial, node):
    bus.drain()
    sim.command("power-cycle %d" % serial)
    wait_boot_ups(bus, [node])


def novotechnik(args):
    bus = Bus(args.iface)
    state = args.tmp + "/state-e"
    sim = Sim(args.sim, ["--iface", args.iface, "--state-dir", state,
                         "--device", "MC1-2800:serial=11,node=1", "--device", "MC1-2800:serial=12,node=2"])
    wait_boot_ups(bus, [1, 2])
    default_timer = sdo_read(bus, 1, 0x1800, 5)
    default_op = sdo_read(bus, 1, 0x6000, 0)
    for node in (1, 2):
        sdo_write(bus, node, 0x1800, 5, 123, 2)     # communication parameter (E§11 /1, /2)
        sdo_write(bus, node, 0x6000, 0, 1, 1)       # application parameter: ccw (E§4.2 Unsigned8; E§11 /1, /3)
    # E§11: storing is refused outside pre-operational.
    nmt(bus, 0x01, 1)
    code = sdo_abort_code(bus, 1, bytes.fromhex("2310100173617665"))
    if code != 0x08000022:
        REPORT.fail("E§11 'save' while operational: abort %#010x, expected 0x08000022" % code)
    else:
        REPORT.ok("E§11 'save' while operational aborts 0x08000022")
    nmt(bus, 0x80, 1)
    sdo_write(bus, 1, 0x1010, 1, SAVE, 4)
    REPORT.ok("E§7.1 'save' on 0x1010/1 in pre-operational")

    power_cycle(bus, sim, 11, 1)
    power_cycle(bus, sim, 12, 2)
    expect(bus, 1, 0x1800, 5, 123, "E§11 stored event timer back after power cycle")
    expect(bus, 1, 0x6000, 0, 1, "E§11 stored operating parameter back after power cycle")
    expect(bus, 2, 0x1800, 5, default_timer, "E§11 not stored: event timer default after power cycle")
    expect(bus, 2, 0x6000, 0, default_op, "E§11 not stored: operating parameter default after power cycle")

    # 'load' reverts RAM to the stored image at once.
    sdo_write(bus, 1, 0x1800, 5, 77, 2)
    expect(bus, 1, 0x1800, 5, 77, "unsaved write is in RAM")
    sdo_write(bus, 1, 0x1011, 1, LOAD, 4)
    expect(bus, 1, 0x1800, 5, 123, "E§11 'load' on 0x1011/1 brings back the stored value")

    # 'kill' erases the non-volatile data and restores the defaults.
    sdo_write(bus, 1, 0x1010, 1, KILL, 4)
    expect(bus, 1, 0x1800, 5, default_timer, "E§11 'kill' restores the default at once")
    power_cycle(bus, sim, 11, 1)
    expect(bus, 1, 0x1800, 5, default_timer, "E§11 'kill' erased the stored value (after power cycle)")
    expect(bus, 1, 0x6000, 0, default_op, "E§11 'kill' erased the stored operating parameter")

    # E§7.1: node-ID via 0x2000, stored with 'save' on 0x1010/4.
    sdo_write(bus, 2, 0x2000, 0, 0x22, 1)
    sdo_write(bus, 2, 0x1010, 4, SAVE, 4)
    power_cycle(bus, sim, 12, 0x22)
    REPORT.ok("E§7.1 node-ID 0x22 stored with 0x1010/4 is active after power cycle", "boot-up 722: 00")
    sim.stop()

    # The whole simulator restarted on the same state directory: still stored.
    sim = Sim(args.sim, ["--iface", args.iface, "--state-dir", state,
                         "--device", "MC1-2800:serial=11,node=1", "--device", "MC1-2800:serial=12,node=2"])
    wait_boot_ups(bus, [1, 0x22])
    REPORT.ok("state directory survives a simulator restart", "boot-ups 701, 722")
    sim.stop()
    bus.close()


def ifm(args):
    bus = Bus(args.iface)
    state = args.tmp + "/state-f"
    sim = Sim(args.sim, ["--iface", args.iface, "--state-dir", state, "--device", "RM9000:serial=21,node=5"])
    wait_boot_ups(bus, [5])
    default_timer = sdo_read(bus, 5, 0x1800, 5)
    check(default_timer == 100, "F§7.3 0x1800/5 default %d, expected 0x64 = 100 (F§7.3, F§7.5 0x6200)" % default_timer)
    sdo_write(bus, 5, 0x1800, 5, 50, 4)
    sdo_write(bus, 5, 0x1010, 1, SAVE, 4)
    power_cycle(bus, sim, 21, 5)
    expect(bus, 5, 0x1800, 5, 50, "F§6.3.2 saved event timer back after power cycle")
    # F§7.3 0x1011: factory settings, active only after a reset or power-up.
    sdo_write(bus, 5, 0x1011, 1, LOAD, 4)
    expect(bus, 5, 0x1800, 5, 50, "F§7.3 'load' is not active before a reset")
    bus.drain()
    nmt(bus, 0x81, 5)
    wait_boot_ups(bus, [5])
    expect(bus, 5, 0x1800, 5, 100, "F§6.3.5 'load' + NMT reset node: factory setting active")
    power_cycle(bus, sim, 21, 5)
    expect(bus, 5, 0x1800, 5, 50, "F§6.3.5 EEPROM not overwritten by 'load': stored value after power cycle")
    sdo_write(bus, 5, 0x1011, 1, LOAD, 4)
    sdo_write(bus, 5, 0x1010, 1, SAVE, 4)
    power_cycle(bus, sim, 21, 5)
    expect(bus, 5, 0x1800, 5, 100, "F§6.3.5 'load' then 'save': factory settings permanent")
    # F§6.3.4: save with reset.
    sdo_write(bus, 5, 0x1800, 5, 40, 4)
    bus.drain()
    bus.send(0x605, bytes.fromhex("2300230055AAAA55"))
    wait_boot_ups(bus, [5])
    REPORT.ok("F§6.3.4 0x2300 <- 0x55AAAA55 saves and resets", "boot-up 705: 00")
    expect(bus, 5, 0x1800, 5, 40, "F§6.3.4 value saved by 0x2300")
    power_cycle(bus, sim, 21, 5)
    expect(bus, 5, 0x1800, 5, 40, "F§6.3.4 value saved by 0x2300 survives a power cycle")
    sim.stop()
    bus.close()


def run(args):
    novotechnik(args)
    ifm(args)


if __name__ == "__main__":
    simtest.main(run)
