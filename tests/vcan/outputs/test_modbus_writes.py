#!/usr/bin/python3
"""Modbus writes end to end, inside UML on vcan0 (run by
tests/vcan/run-in-vcan): an independent Modbus client (pymodbus) writes the
command registers (docs/modbus.md "Writes") of the real cobridged, which
runs the commands on simulated encoders (cobridge-sim) of the three
families, standing still (motion constant:0) so positions are exact:

 * preset (J§1.3.2 0x6010, E§4.2 / F§7.5 0x6003): command_status turns 2
   (done) and the position register then reads the preset value;
 * a preset outside the object's range (UNSIGNED32, -5) is refused: status 7,
   the position unchanged;
 * store (E§11 'save' to 0x1010) then power cycle: the preset survives; a
   preset without store does not (RAM only);
 * NMT reset node (CiA 301 §7.2.8.3.1.1): the boot-up is seen on the bus and
   the device is configured and online again;
 * a command to a device that does not answer (cable pulled): 0x0B.
"""
import os
import re
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
import e2e  # noqa: E402

# name, config model, simulator model, serial, node
DEVICES = [("rot", "RFC-4800", "RFC-4800", 1001, 10),
           ("mt", "MC1-2800", "MC1-2800", 2001, 20),
           ("ifm", "RM9", "RM9000", 3001, 30)]
SLOT = {name: i for i, (name, *_rest) in enumerate(DEVICES)}  # device_index = position in the configuration
BASE = 256
STRIDE = 32
PORT = 1502


def base(name):
    return BASE + STRIDE * SLOT[name]


def s32(hi, lo):
    v = (hi << 16) | lo
    return v - (1 << 32) if v & 0x80000000 else v


class Client:
    def __init__(self, source="127.0.0.1"):
        from pymodbus.client import ModbusTcpClient
        self.c = ModbusTcpClient("127.0.0.1", port=PORT, timeout=3, source_address=(source, 0))
        if not self.c.connect():
            raise RuntimeError("Modbus connect failed")

    def slot(self, name):
        r = self.c.read_holding_registers(base(name), 32, slave=1)
        return None if r.isError() else r.registers

    def command(self, name, code, value=0):
        v = value & 0xFFFFFFFF
        return self.c.write_registers(base(name) + 28, [v >> 16, v & 0xFFFF, code], slave=1)

    def wait(self, name, pred, timeout):
        end = time.time() + timeout
        regs = None
        while time.time() < end:
            regs = self.slot(name)
            if regs is not None and pred(regs):
                return regs, True
            time.sleep(0.02)
        return regs, False

    def close(self):
        self.c.close()


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_modbus_writes")
    ws = e2e.Workspace("modbus-writes", args.keep)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d%s,motion=constant:0" %
                                                 (sm, s, n, ",bitrate=250" if sm.startswith("RM") else "")
                                                 for (_, _, sm, s, n) in DEVICES]})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30, "node_pool": "40-60"}
    devices = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
                "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": 10}}
               for (name, m, _, s, n) in DEVICES]
    # Writes from 127.0.0.1 only (a second client from 127.0.0.2 reads, may not write).
    extra = "[outputs.modbus]\nbind = \"127.0.0.1\"\nport = %d\nwrites_enabled = true\nwrite_allow = [\"127.0.0.1/32\"]\n" % PORT
    daemon = e2e.Daemon(args.daemon, e2e.write_config(ws, [bus], devices, extra=extra), ws,
                        extra_args=("--plugin-dir", args.plugins))
    names = [d[0] for d in DEVICES]
    mb = None
    try:
        report.check(daemon.wait_socket(), "control socket up")
        _, took = daemon.wait_until(e2e.all_operational(names), 60, interval=0.1)
        if not report.check(took is not None, "three devices operational", "%.2f s" % took if took else ""):
            print(daemon.tail(60))
            return report.finish()
        mb = Client()
        for name in names:
            _, ok = mb.wait(name, lambda r: r[26] == 1 and r[9] == 1 and r[11] < 1000, 5)
            report.check(ok, "%s: Modbus slot %d present, online, with fresh data" % (name, SLOT[name]))

        # Preset on every family: done, then the position reads the value.
        presets = {"rot": 1234, "mt": 20007, "ifm": 3333}
        for name, value in presets.items():
            t0 = time.time()
            r = mb.command(name, 1, value)
            if not report.check(not r.isError(), "%s: preset %d accepted (0x10 at +28)" % (name, value), str(r)):
                continue
            regs, ok = mb.wait(name, lambda x: x[31] not in (0, 1), 5)
            report.check(ok and regs[31] == 2, "%s: command_status done" % name,
                         "status %s after %.0f ms" % (regs[31] if regs else None, (time.time() - t0) * 1e3))
            regs, ok = mb.wait(name, lambda x: s32(x[0], x[1]) == value, 2)
            report.check(ok, "%s: position reads the preset" % name,
                         "position %s" % (s32(regs[0], regs[1]) if regs else None))
            report.check(regs is not None and regs[30] == 1 and s32(regs[28], regs[29]) == value,
                         "%s: command registers read back (command 1, value %d)" % (name, value))

        # Out of range for UNSIGNED32 0x6003: status 7, nothing written.
        r = mb.command("mt", 1, -5)
        regs, ok = mb.wait("mt", lambda x: x[31] not in (1, 2), 5)
        report.check(ok and regs[31] == 7, "mt: preset -5 refused as out of range (status 7)",
                     "status %s" % (regs[31] if regs else None))
        time.sleep(0.1)
        regs = mb.slot("mt")
        report.check(regs is not None and s32(regs[0], regs[1]) == presets["mt"], "mt: position unchanged")

        # Store on mt (and not on rot), then power-cycle both.
        r = mb.command("mt", 3)
        regs, ok = mb.wait("mt", lambda x: x[31] not in (1,) and x[30] == 3, 5)
        report.check(ok and regs[31] == 2, "mt: store done", "status %s" % (regs[31] if regs else None))
        for name, serial in (("mt", 2001), ("rot", 1001)):
            t0 = time.time()
            sim.command("power-cycle %d" % serial)
            _, back = daemon.wait_until(
                lambda s: any(d["name"] == name and d["state"] == "operational" and d["online"] and d["since"] and
                              e2e.iso_to_epoch(d["since"]) >= t0 for b in s["buses"] for d in b["devices"]), 10)
            report.check(back is not None, "%s: operational again after power-cycle" % name)
            # Values sent after the boot-up (the last ones from before it may
            # still be younger than a reboot takes).
            time.sleep(0.3)
            regs, _ = mb.wait(name, lambda x: x[9] == 1 and x[11] < 100, 3)
            pos = s32(regs[0], regs[1]) if regs else None
            if name == "mt":
                report.check(pos == presets["mt"], "mt: stored preset survives the power cycle", "position %s" % pos)
            else:
                report.check(pos is not None and pos != presets["rot"],
                             "rot: preset without store is gone after the power cycle", "position %s" % pos)

        # NMT reset node on ifm: boot-up on the bus, back online and operational.
        t0 = time.time()
        r = mb.command("ifm", 2)
        report.check(not r.isError(), "ifm: NMT reset accepted")
        boot = listener.wait_for(lambda i, d: i == 0x700 + 30 and d == b"\x00", 3, since=t0)
        report.check(boot is not None, "ifm: boot-up (0x71E 00) after the reset command",
                     "%.0f ms" % ((boot[0] - t0) * 1e3) if boot else "")
        regs, ok = mb.wait("ifm", lambda x: x[31] != 1, 3)
        if not report.check(ok and regs[31] == 2, "ifm: command_status done",
                            "command %s, status %s" % (regs[30], regs[31]) if regs else ""):
            print(daemon.tail(40))
        _, back = daemon.wait_until(
            lambda s: any(d["name"] == "ifm" and d["state"] == "operational" and d["online"] and d["since"] and
                          e2e.iso_to_epoch(d["since"]) >= t0 for b in s["buses"] for d in b["devices"]), 10)
        report.check(back is not None, "ifm: configured and operational again after the reset")
        regs, ok = mb.wait("ifm", lambda x: x[9] == 1 and x[8] == 5 and x[11] < 200, 5)
        report.check(ok, "ifm: Modbus shows it online, operational, fresh")

        # A device that does not answer: 0x0B, nothing submitted.
        sim.command("silence 1001 on")
        regs, ok = mb.wait("rot", lambda x: x[9] == 0, 3)
        report.check(ok, "rot: offline in Modbus after the cable is pulled")
        r = mb.command("rot", 2)
        report.check(r.isError() and getattr(r, "exception_code", None) == 0x0B,
                     "rot: command to the offline device answers 0x0B", str(r))
        sim.command("silence 1001 off")

        # A client outside write_allow reads, and its write is refused (0x01) and logged with its address.
        other = Client("127.0.0.2")
        try:
            regs = other.slot("mt")
            report.check(regs is not None, "a client outside write_allow (127.0.0.2) reads the map")
            r = other.command("mt", 1, 4242)
            report.check(r.isError() and getattr(r, "exception_code", None) == 0x01,
                         "its preset is refused with exception 0x01", str(r))
        finally:
            other.close()
        # The daemon logged each command and its outcome, and every write with its client
        # (the refused one last: waited for, the log is written by the server thread).
        end = time.time() + 5
        while True:
            with open(daemon.log_path) as f:
                log = f.read()
            if "127.0.0.2" in log or time.time() > end:
                break
            time.sleep(0.05)
        report.check(re.search(r"\[modbus\] \[info\] write by 127\.0\.0\.1:\d+ \(unit 1\): registers \d+\.\.\d+ = .*: applied",
                               log) is not None, "every Modbus write logged at info with the client's address and port")
        report.check(re.search(r"write by 127\.0\.0\.2:\d+ \(unit 1\): registers .*: refused, exception 0x01", log)
                     is not None, "the refused write logged with its client too")
        report.check("device mt: preset to 20007 requested by an output" in log and "device mt: store done" in log,
                     "daemon log names the commands and their outcome")
    finally:
        if mb is not None:
            mb.close()
        e2e.shut_down(ws, daemon, sim, listener)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
