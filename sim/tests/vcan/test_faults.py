#!/usr/bin/python3
"""Every fault injected through the control channel
produces the EMCY telegram and the position error value of the manual.

E§9.1 (multiturn): EMCY bytes 0-1 code, byte 2 as tabled, byte 3 sub-code;
  measurement error 0x5051/1/0 -> position 0x7FFFFFFC; out of range (+)
  0x5051/1/1 -> 0x7FFFFFF8, (-) 0x5051/1/2 -> 0x80000008, both latched until
  Position Error Reset 0x2100 (E§4.3), then EMCY 0x0000; hardware fault
  0x5000/1/0 -> 0x7FFFFFFC; temperature 0x4210/1/1, /1/2; supply voltage
  0x3100/1/1, /1/2 (warnings, position unchanged).
J§1.8, J§1.8.1 (rotary): sensor error EMCY 0x5000, reg 1, bytes 3-4 = 1,
  bytes 5-6 = 1, byte 7 = 0; position 0x7FF0 and speed 0; EMCY 0x0000 when the
  error bit returns to 0. J§1.9.2: 2-channel disagreement = 0x6503 bit 0.
"""

import time

import simtest
from simtest import REPORT, Bus, Sim, check, hexs, nmt, sdo_read, sdo_write, wait_boot_ups


MEASURE_SETTLE = 0.02


def expect_emcy(bus, sim, node, command, want_hex, label):
    bus.drain()
    sim.command(command)
    f = bus.wait_for(lambda fr: fr.can_id == 0x80 + node)
    want = bytes.fromhex(want_hex.replace(" ", ""))
    if f is None:
        REPORT.fail("%s: no EMCY on %03X after '%s'" % (label, 0x80 + node, command))
        return False
    if f.data != want:
        REPORT.fail("%s: EMCY %03X: %s, expected %s" % (label, f.can_id, hexs(f.data), want_hex))
        return False
    REPORT.ok(label, "%s -> %03X: %s" % (command, f.can_id, hexs(f.data)))
    return True


def expect_value(bus, node, index, sub, want, label, bits=32):
    # The process value follows the fault within one measuring cycle (1 ms,
    # J§1.2.4, E§3.3); the EMCY goes out at once. Read after a few cycles.
    time.sleep(MEASURE_SETTLE)
    v = sdo_read(bus, node, index, sub)
    if v != want:
        REPORT.fail("%s: %04X/%d = %#x, expected %#x" % (label, index, sub, v, want))
    else:
        REPORT.ok(label, "%04X/%d = %#0*x" % (index, sub, 2 + bits // 4, v))
    return v


def multiturn(args):
    node = 3
    bus = Bus(args.iface)
    sim = Sim(args.sim, ["--iface", args.iface, "--device", "MC1-2800:serial=31,node=%d" % node])
    wait_boot_ups(bus, [node])
    normal = sdo_read(bus, node, 0x6004, 0)
    check(normal not in (0x7FFFFFFC, 0x7FFFFFF8, 0x80000008), "position before any fault is a sentinel")

    expect_emcy(bus, sim, node, "fault 31 measurement-error", "51 50 01 00 00 00 00 00",
                "E§9.1 measurement error EMCY 0x5051/1/0")
    expect_value(bus, node, 0x6004, 0, 0x7FFFFFFC, "E§9.1 measurement error position")
    expect_emcy(bus, sim, node, "fault 31 clear", "00 00 00 00 00 00 00 00", "E§9.1 error reset EMCY 0x0000")
    expect_value(bus, node, 0x6004, 0, normal, "E§9.1 valid position after the reset")

    expect_emcy(bus, sim, node, "fault 31 over-range", "51 50 01 01 00 00 00 00",
                "E§9.1 position overflow error EMCY 0x5051/1/1")
    expect_value(bus, node, 0x6004, 0, 0x7FFFFFF8, "E§9.1 overflow position")
    sim.command("fault 31 clear")
    expect_value(bus, node, 0x6004, 0, 0x7FFFFFF8, "E§9.1 overflow stays latched until 0x2100")
    time.sleep(MEASURE_SETTLE)
    bus.drain()
    bus.send(0x600 + node, bytes.fromhex("2F00210001000000"))
    seen = bus.collect(lambda fr: fr.can_id in (0x80 + node, 0x580 + node), 0.5)
    conf = [fr for fr in seen if fr.can_id == 0x580 + node]
    emcy = [fr for fr in seen if fr.can_id == 0x80 + node]
    if not conf or conf[0].data != bytes.fromhex("6000210000000000"):
        REPORT.fail("E§4.3 0x2100 write: confirmation %r" % conf)
    elif [fr.data for fr in emcy] != [bytes(8)]:
        REPORT.fail("E§4.3 0x2100 Position Error Reset: expected one EMCY 00 00 00 00 00 00 00 00, got %r" % emcy)
    else:
        REPORT.ok("E§4.3 0x2100 Position Error Reset sends EMCY 0x0000", hexs(emcy[0].data))
    expect_value(bus, node, 0x6004, 0, normal, "E§4.3 valid position after 0x2100")

    expect_emcy(bus, sim, node, "fault 31 under-range", "51 50 01 02 00 00 00 00",
                "E§9.1 position underflow error EMCY 0x5051/1/2")
    expect_value(bus, node, 0x6004, 0, 0x80000008, "E§9.1 underflow position")
    sim.command("fault 31 clear")
    time.sleep(MEASURE_SETTLE)
    sdo_write(bus, node, 0x2100, 0, 1, 1)
    expect_value(bus, node, 0x6004, 0, normal, "E§4.3 valid position after 0x2100 (underflow)")

    expect_emcy(bus, sim, node, "fault 31 hardware-fault", "00 50 01 00 00 00 00 00",
                "E§9.1 device hardware fault EMCY 0x5000/1/0")
    expect_value(bus, node, 0x6004, 0, 0x7FFFFFFC, "E§9.1 hardware fault position")
    sim.command("fault 31 clear")

    for kind, code in (("temperature-high", "10 42 01 01"), ("temperature-low", "10 42 01 02"),
                       ("voltage-high", "00 31 01 01"), ("voltage-low", "00 31 01 02")):
        expect_emcy(bus, sim, node, "fault 31 " + kind, code + " 00 00 00 00", "E§9.1 %s EMCY" % kind)
        sim.command("fault 31 clear")
    sim.stop()
    bus.close()


def rotary(args):
    node = 4
    bus = Bus(args.iface)
    sim = Sim(args.sim, ["--iface", args.iface, "--device", "RFC-4800:serial=41,node=%d,channels=2" % node])
    wait_boot_ups(bus, [node])
    normal = sdo_read(bus, node, 0x6020, 1)
    check(normal != 0x7FF0, "position before any fault is the error value")
    expect_emcy(bus, sim, node, "fault 41 measurement-error", "00 50 01 01 00 01 00 00",
                "J§1.8.1 sensor error EMCY 0x5000 (reg 1, b3-4 = 1, b5-6 = 1, b7 = 0)")
    expect_value(bus, node, 0x6020, 1, 0x7FF0, "J§1.8 position error value ch1")
    expect_value(bus, node, 0x6030, 1, 0, "J§1.8 speed 0 on a sensor error", bits=16)
    # The TPDO carries the error value too (J§1.8, by inference).
    sdo_write(bus, node, 0x1800, 5, 10, 2)
    bus.drain()
    nmt(bus, 0x01, node)
    f = bus.wait_for(lambda fr: fr.can_id == 0x180 + node)
    if f is None or f.data[0:4] != bytes.fromhex("F07F0000"):
        REPORT.fail("J§1.8 TPDO1 position during the sensor error: %r, expected F0 7F 00 00 ..." % f)
    else:
        REPORT.ok("J§1.8 TPDO1 carries 0x7FF0", hexs(f.data))
    nmt(bus, 0x80, node)
    expect_emcy(bus, sim, node, "fault 41 clear", "00 00 00 00 00 00 00 00",
                "J§1.8.1 EMCY 0x0000 when the error bit returns to 0")
    expect_value(bus, node, 0x6020, 1, normal, "J§1.8 valid position after the error")

    expect_emcy(bus, sim, node, "fault 41 hardware-fault", "00 50 01 01 00 01 00 00",
                "J§1.8.1 sensor error (hardware) EMCY 0x5000")
    expect_value(bus, node, 0x6020, 1, 0x7FF0, "J§1.8 hardware fault position")
    sim.command("fault 41 clear")

    sim.command("fault 41 channel-disagreement")
    alarms = sdo_read(bus, node, 0x6503, 0)
    if alarms & 1 != 1:
        REPORT.fail("J§1.9.2 channel disagreement: 0x6503 = %#06x, bit 0 not set" % alarms)
    else:
        REPORT.ok("J§1.9.2 2-channel disagreement sets 0x6503 bit 0", "0x6503 = %#06x" % alarms)
    sim.command("fault 41 clear")
    sim.stop()
    bus.close()


def run(args):
    multiturn(args)
    rotary(args)


if __name__ == "__main__":
    simtest.main(run)
