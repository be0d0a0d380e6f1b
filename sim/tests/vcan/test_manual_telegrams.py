#!/usr/bin/python3
"""Every SDO and LSS example telegram printed in the
three manuals, sent to a simulated device, gets the answer printed in the
manual, byte for byte. Where the manual's own telegram is wrong (errata of J,
F and E) the check says which bytes differ and why, and asserts what the
device does instead.

Sections: J§1.5, J§1.5.1-1.5.3, J§1.6.1, J§1.6.2, J§1.7.2 (rotary, RFC-4800);
E§6, E§6.1-6.3, E§7.1, E§7.2, E§8.2 (multiturn, MC1-2800); F§7.2.1 (ifm RM9000,
node 1 as printed: 601/581).
"""

import simtest
from simtest import (REPORT, Bus, Sim, expect_silence, expect_telegram, nmt, sdo_read, wait_boot_ups)

LSS_TX, LSS_RX = 0x7E5, 0x7E4


def mapping_sequence(bus, manual, node):
    """J§1.7.2, E§8.2 steps 1-5 around the two printed mapping telegrams."""
    req, resp = 0x600 + node, 0x580 + node
    cob = sdo_read(bus, node, 0x1800, 1)
    simtest.check(cob & 0x40000000, "%s: 0x1800/1 = %#x, expected bit 30 set (no RTR)" % (manual, cob))
    off = cob | 0x80000000
    on = cob & ~0x80000000
    expect_telegram(bus, manual + " step 1: disable TPDO1 (0x1800/1 MSB = 1)", req,
                    "23 00 18 01 " + simtest.hexs(off.to_bytes(4, "little")), resp, "60 00 18 01 00 00 00 00")
    expect_telegram(bus, manual + " step 2: clear mapping (0x1A00/0 = 0)", req, "2F 00 1A 00 00 00 00 00",
                    resp, "60 00 1A 00 00 00 00 00")
    expect_telegram(bus, manual + " step 3, mapping #1: 0x1A00/1 = 0x60200120 (position)", req,
                    "23 00 1A 01 20 01 20 60", resp, "60 00 1A 01 00 00 00 00",
                    note="answer not printed; CiA 301 download confirmation as in %s" %
                    ("J§1.6.1" if manual.startswith("J") else "E§7.1"))
    expect_telegram(bus, manual + " step 3, mapping #2: 0x1A00/2 = 0x60300110 (speed)", req,
                    "23 00 1A 02 10 01 30 60", resp, "60 00 1A 02 00 00 00 00")
    # Step 4 prints "e.g. 0x03" although two entries were mapped (A.9.18 /
    # C.9.18): the count written is 2.
    expect_telegram(bus, manual + " step 4: 0x1A00/0 = 2 (manual: 'e.g. 0x03', erratum A.9.18/C.9.18)", req,
                    "2F 00 1A 00 02 00 00 00", resp, "60 00 1A 00 00 00 00 00")
    expect_telegram(bus, manual + " step 5: enable TPDO1 (MSB = 0)", req,
                    "23 00 18 01 " + simtest.hexs(on.to_bytes(4, "little")), resp, "60 00 18 01 00 00 00 00")
    # The mapping is live: position (4 bytes) + speed (2 bytes) every 50 ms.
    expect_telegram(bus, manual + ": event timer 0x1800/5 = 50 ms", req, "2B 00 18 05 32 00 00 00", resp,
                    "60 00 18 05 00 00 00 00")
    bus.drain()
    nmt(bus, 0x01, node)
    f = bus.wait_for(lambda fr: fr.can_id == (on & 0x7FF))
    if f is None or len(f.data) != 6:
        REPORT.fail("%s: no 6-byte TPDO1 on %03X after mapping position+speed: %r" % (manual, on & 0x7FF, f))
    else:
        REPORT.ok(manual + ": TPDO1 carries the new mapping", "%03X: %s" % (f.can_id, simtest.hexs(f.data)))
    nmt(bus, 0x80, node)


def lss_switch_selective(bus, manual, product_hex, answer=True, note=None):
    for cs_hex in ("40 82 01 00 00 00 00 00", "41 %s 00 00 00 00 00" % product_hex, "42 03 00 01 00 00 00 00"):
        bus.send(LSS_TX, simtest.parse_hex(cs_hex))
    if answer:
        expect_telegram(bus, manual + " switch mode selective (40/41/42/43 -> 44)", LSS_TX, "43 78 56 34 12 00 00 00",
                        LSS_RX, "44 00 00 00 00 00 00 00", note)
    else:
        expect_silence(bus, manual + " switch mode selective as printed (41 %s)" % product_hex, LSS_TX,
                       "43 78 56 34 12 00 00 00", LSS_RX, note)


def rotary_j(args):
    print("J: RFC-4800, serial 0x12345678, revision 0x00010003, node 127 (J§1.2.1, J§1.2.2)", flush=True)
    bus = Bus(args.iface)
    sim = Sim(args.sim, ["--iface", args.iface, "--device", "RFC-4800:serial=0x12345678,bitrate=250"])
    wait_boot_ups(bus, [127])
    n = 127
    req, resp = 0x600 + n, 0x580 + n

    # J§1.6.1 SDO download examples.
    expect_telegram(bus, "J§1.6.1 store all parameters 0x1010/1 'save'", req, "23 10 10 01 73 61 76 65", resp,
                    "60 10 10 01 00 00 00 00")
    expect_telegram(bus, "J§1.6.1 restore all parameters 0x1011/1 'load'", req, "23 11 10 01 6C 6F 61 64", resp,
                    "60 11 10 01 00 00 00 00")
    # Erratum A.9.1: printed request 23 00 20 80 00 00 00 00 (sub 0x80, data 0,
    # 4-byte command) with the printed answer 60 00 20 01 ... (sub 0x01). 0x2000
    # is a plain UNSIGNED8 (sub 0 only): sub 0x80 does not exist, so the device
    # aborts with 0x06090011 (J§1.6.3) instead of the printed 60 00 20 01.
    expect_telegram(bus, "J§1.6.1 node-ID example as printed (erratum A.9.1)", req, "23 00 20 80 00 00 00 00", resp,
                    "80 00 20 80 11 00 09 06",
                    note="printed answer 60 00 20 01 00 00 00 00: bytes 0 and 3-7 differ, sub 0x80 does not exist")
    expect_telegram(bus, "J§1.6.1 node-ID 64, corrected as E§7.1 prints it", req, "2F 00 20 00 40 00 00 00", resp,
                    "60 00 20 00 00 00 00 00")

    # J§1.6.2 upload: the manual prints the frame layout only; J§1.2.1 gives
    # the values (vendor 0x182, product 0x0BE0, revision 0x00010003).
    expect_telegram(bus, "J§1.6.2 upload 0x1018/1 vendor (43 = 4 bytes)", req, "40 18 10 01 00 00 00 00", resp,
                    "43 18 10 01 82 01 00 00")
    expect_telegram(bus, "J§1.6.2 upload 0x1018/2 product RFC-4800", req, "40 18 10 02 00 00 00 00", resp,
                    "43 18 10 02 E0 0B 00 00")
    expect_telegram(bus, "J§1.6.2 upload 0x1018/3 revision", req, "40 18 10 03 00 00 00 00", resp,
                    "43 18 10 03 03 00 01 00")
    expect_telegram(bus, "J§1.6.2 upload 0x1018/4 serial", req, "40 18 10 04 00 00 00 00", resp,
                    "43 18 10 04 78 56 34 12")
    expect_telegram(bus, "J§1.6.2 upload 0x2000 (4F = 1 byte): 64 written, not yet active", req,
                    "40 00 20 00 00 00 00 00", resp, "4F 00 20 00 40 00 00 00")
    expect_telegram(bus, "J§1.6.2 upload 0x2001 (4B = 2 bytes): 250 kbit/s", req, "40 01 20 00 00 00 00 00", resp,
                    "4B 01 20 00 FA 00 00 00")
    # J§1.6.1: the new node-ID becomes effective after a communication restart.
    bus.drain()
    nmt(bus, 0x82, n)
    wait_boot_ups(bus, [64])
    REPORT.ok("J§1.6.1 node-ID 64 effective after NMT reset communication", "boot-up 740: 00")
    n = 64

    mapping_sequence(bus, "J§1.7.2", n)

    # J§1.5 LSS (device in pre-operational).
    # Erratum A.9.2: "NMT command to set the encoder to stopped" 7E5: 04 00 is
    # LSS switch state global -> waiting; it has no answer.
    expect_silence(bus, "J§1.5 '04 00' (switch state global waiting, erratum A.9.2)", LSS_TX,
                   "04 00 00 00 00 00 00 00", LSS_RX)
    lss_switch_selective(bus, "J§1.5", "E0 0B")
    expect_telegram(bus, "J§1.5.1 configure node-ID 5", LSS_TX, "11 05 00 00 00 00 00 00", LSS_RX,
                    "11 00 00 00 00 00 00 00")
    expect_telegram(bus, "J§1.5.1 configure node-ID 128: error 1 out of range", LSS_TX, "11 80 00 00 00 00 00 00",
                    LSS_RX, "11 01 00 00 00 00 00 00")
    # Erratum A.9.3: J prints the table index in byte 1 ("13 IDX 00"); CiA 305
    # and E§6.2 put the selector in byte 1 and the index in byte 2. The
    # rotary simulator reads both; 250 kbit/s = index 3.
    expect_telegram(bus, "J§1.5.2 bit timing as printed: 13 03 00 (index in byte 1, erratum A.9.3)", LSS_TX,
                    "13 03 00 00 00 00 00 00", LSS_RX, "13 00 00 00 00 00 00 00")
    expect_telegram(bus, "J§1.5.2 bit timing, CiA 305 form 13 00 03", LSS_TX, "13 00 03 00 00 00 00 00", LSS_RX,
                    "13 00 00 00 00 00 00 00")
    expect_telegram(bus, "J§1.5.2 bit timing 20 kbit/s (index 7): error 1 not supported", LSS_TX,
                    "13 00 07 00 00 00 00 00", LSS_RX, "13 01 00 00 00 00 00 00")
    expect_telegram(bus, "J§1.5.3 store configuration", LSS_TX, "17 00 00 00 00 00 00 00", LSS_RX,
                    "17 00 00 00 00 00 00 00")
    expect_silence(bus, "J§1.5 switch mode global 04 01 (no answer)", LSS_TX, "04 01 00 00 00 00 00 00", LSS_RX)
    expect_silence(bus, "J§1.5 back to waiting 04 00", LSS_TX, "04 00 00 00 00 00 00 00", LSS_RX)
    bus.drain()
    nmt(bus, 0x82, n)
    wait_boot_ups(bus, [5])
    REPORT.ok("J§1.5.1 LSS node-ID 5 active after reset communication", "boot-up 705: 00")
    sim.stop()
    bus.close()


def multiturn_e(args):
    print("E: MC1-2800, serial 0x12345678, node 127 (E§4.1, E§3.1)", flush=True)
    bus = Bus(args.iface)
    sim = Sim(args.sim, ["--iface", args.iface, "--device", "MC1-2800:serial=0x12345678,bitrate=250"])
    wait_boot_ups(bus, [127])
    n = 127
    req, resp = 0x600 + n, 0x580 + n
    expect_telegram(bus, "E§7.1 store all parameters 0x1010/1", req, "23 10 10 01 73 61 76 65", resp,
                    "60 10 10 01 00 00 00 00")
    expect_telegram(bus, "E§7.1 restore all parameters 0x1011/1", req, "23 11 10 01 6C 6F 61 64", resp,
                    "60 11 10 01 00 00 00 00")
    expect_telegram(bus, "E§7.1 set new node-ID 0x40", req, "2F 00 20 00 40 00 00 00", resp,
                    "60 00 20 00 00 00 00 00")
    expect_telegram(bus, "E§7.2 upload 0x1000 device type 0x00020196 (E§4.1)", req, "40 00 10 00 00 00 00 00", resp,
                    "43 00 10 00 96 01 02 00")
    expect_telegram(bus, "E§7.2 upload 0x1018/1 vendor", req, "40 18 10 01 00 00 00 00", resp,
                    "43 18 10 01 82 01 00 00")
    expect_telegram(bus, "E§7.2 upload 0x1018/2 product 0x0BB8 (E§4.1 V03)", req, "40 18 10 02 00 00 00 00", resp,
                    "43 18 10 02 B8 0B 00 00")
    bus.drain()
    nmt(bus, 0x82, n)
    wait_boot_ups(bus, [64])
    REPORT.ok("E§7.1 node-ID 0x40 effective after communication restart", "boot-up 740: 00")
    n = 64

    mapping_sequence(bus, "E§8.2", n)

    expect_silence(bus, "E§6 '04 00' (switch state global waiting, erratum C.9.6)", LSS_TX,
                   "04 00 00 00 00 00 00 00", LSS_RX)
    # Erratum C.9.5: the frame table sends product 0x0BE0 (RFC-4800) while the
    # text (and the device) says 0x0BB8: as printed, no multiturn device answers.
    lss_switch_selective(bus, "E§6", "E0 0B", answer=False,
                         note="printed product 0x0BE0 is the RFC-4800 code, erratum C.9.5")
    lss_switch_selective(bus, "E§6 (product 0x0BB8 as the text says)", "B8 0B",
                         note="byte 1-2 of the 0x41 frame B8 0B instead of the printed E0 0B")
    expect_telegram(bus, "E§6.1 configure node-ID 6", LSS_TX, "11 06 00 00 00 00 00 00", LSS_RX,
                    "11 00 00 00 00 00 00 00")
    expect_telegram(bus, "E§6.1 configure node-ID 0: error 1 out of range", LSS_TX, "11 00 00 00 00 00 00 00",
                    LSS_RX, "11 01 00 00 00 00 00 00")
    expect_telegram(bus, "E§6.2 configure bit rate 13 00 03 (250 kbit/s)", LSS_TX, "13 00 03 00 00 00 00 00", LSS_RX,
                    "13 00 00 00 00 00 00 00")
    expect_telegram(bus, "E§6.2 configure bit rate 20 kbit/s: error 1 not supported", LSS_TX,
                    "13 00 07 00 00 00 00 00", LSS_RX, "13 01 00 00 00 00 00 00")
    expect_telegram(bus, "E§6.3 store configuration", LSS_TX, "17 00 00 00 00 00 00 00", LSS_RX,
                    "17 00 00 00 00 00 00 00")
    expect_silence(bus, "E§6 switch mode global 04 01", LSS_TX, "04 01 00 00 00 00 00 00", LSS_RX)
    expect_silence(bus, "E§6 back to waiting 04 00", LSS_TX, "04 00 00 00 00 00 00 00", LSS_RX)
    bus.drain()
    nmt(bus, 0x82, n)
    wait_boot_ups(bus, [6])
    REPORT.ok("E§6.1 LSS node-ID 6 active after reset communication", "boot-up 706: 00")
    sim.stop()
    bus.close()


def ifm_f(args):
    print("F: RM9000 at node 1 (the F§7.2.1 examples address node 1: 601/581)", flush=True)
    bus = Bus(args.iface)
    sim = Sim(args.sim, ["--iface", args.iface, "--device", "RM9000:serial=0x00ABCDEF,node=1"])
    wait_boot_ups(bus, [1])
    # F§7.2.1: caption "value 1000", data 00 10 00 00 = 4096 (erratum B.9.1);
    # the telegram is what counts and is answered as printed.
    expect_telegram(bus, "F§7.2.1 set preset 0x6003 (data 0x00001000; caption says 1000, B.9.1)", 0x601,
                    "23 03 60 00 00 10 00 00", 0x581, "60 03 60 00 00 00 00 00")
    expect_telegram(bus, "F§7.2.1 read preset 0x6003", 0x601, "40 03 60 00 00 00 00 00", 0x581,
                    "43 03 60 00 00 10 00 00")
    # Erratum B.9.1: the printed answer to 'save' on 0x1010/1 echoes sub 00
    # (60 10 10 00 ...); CiA 301 echoes the request's sub-index: byte 3 = 01.
    expect_telegram(bus, "F§7.2.1 store 0x1010/1 'save' (printed answer sub 00, erratum B.9.1)", 0x601,
                    "23 10 10 01 73 61 76 65", 0x581, "60 10 10 01 00 00 00 00",
                    note="printed 60 10 10 00 00 00 00 00: byte 3 differs, the confirmation echoes sub 01")
    sim.stop()
    bus.close()


def run(args):
    rotary_j(args)
    multiturn_e(args)
    ifm_f(args)


if __name__ == "__main__":
    simtest.main(run)
