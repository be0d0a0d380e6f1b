"""The real daemon (the default build) under Valgrind inside User-Mode Linux,
where ASan and TSan cannot run (docs/reliability.md).

One scenario at a rate Valgrind follows (two encoders, TPDO1 every 100 ms):
control-socket reads (status, SDO reads), the CiA 309-3 gateway (reads, a
write read back), Modbus TCP reads from the Modbus plugin, the web status
API, DDS samples at a subscriber (the DDS plugin), a power cycle of one
device (boot-up -> configured again), a reload that changes a device's
setting, then SIGTERM. Each step's behaviour is checked, and then
Valgrind's verdict: no error (memcheck: invalid read or write, use of an
uninitialised value, bad free, definitely lost block), exit status 0, not
Valgrind's error status.

--tool drd|helgrind runs the same scenario under a race detector; that is
not a CI check (they take every C++ atomic for a plain access:
docs/reliability.md). Suppressions (valgrind.supp beside this file) cover
system libraries only, each with its reason.
"""
import http.client
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import e2e

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10),
           ("mt-a", "MC1-2800", "MC1-2800", 2001, 20)]
NAMES = [d[0] for d in DEVICES]
MODBUS_PORT = 1502
WEB_PORT = 8088
ERROR_EXIT = 99
SUPPRESSIONS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "valgrind.supp")
TOOL_ARGS = {
    "memcheck": ["--leak-check=full", "--show-leak-kinds=definite", "--errors-for-leak-kinds=definite"],
    "drd": [],
    "helgrind": [],
}


def valgrind_executable(name):
    exe = shutil.which(name)
    if exe is None:
        raise SystemExit("test_valgrind: FAIL: valgrind not found (%s; Debian package valgrind: scripts/setup-deps)"
                         % name)
    return exe


def config(ws, devices, gateway_socket):
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30}
    extra = ('[outputs.dds]\n\n[outputs.modbus]\nbind = "127.0.0.1"\nport = %d\n\n[outputs.jsontap]\npath = %s\n\n'
             '[ascii_gateway]\nsocket = %s\nwrites_enabled = true\nwrite_group = "root"\n\n[web]\nport = %d\n'
             % (MODBUS_PORT, e2e.toml_value(ws.path("tap.jsonl")), e2e.toml_value(gateway_socket), WEB_PORT))
    return e2e.write_config(ws, [bus], devices, extra=extra)


def device_entries(event_timer_ms):
    # Node 20 keeps a client's value of a configured object (the 309-3 write
    # below reads its 150 ms back; the default "restore" would write 200 again).
    return [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 200,
             "on_config_drift": "keep" if n == 20 else "restore",
             "tpdo1": {"mapping": ["position"], "transmission": "event", "event_timer_ms": event_timer_ms}}
            for (name, m, _, s, n) in DEVICES]


def control_reads(report, daemon):
    for _ in range(5):
        st = daemon.status()
        report.check(len(st["buses"]) == 1, "control socket: status")
    for (name, _, _, serial, node) in DEVICES:
        reply = daemon.request("sdo-read line1 %d 1018 4 2000" % node, timeout=20)
        report.check(reply.get("ok") and reply.get("value") == serial, "control socket: sdo-read %s 0x1018:4" % name,
                     json.dumps(reply))


def gateway_reads(report, path):
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "control"))
    from test_ascii_gateway import Client  # noqa: E402  the test's own CiA 309-3 client
    c = Client(path, timeout=30)
    try:
        for i, (name, _, model, serial, node) in enumerate(DEVICES):
            got = c.ask("[%d] 1 %d r 0x1018 4 u32" % (i + 1, node))
            report.check(got == "[%d] %d" % (i + 1, serial), "309-3: read %s serial" % name, got)
        got = c.ask("[3] 1 10 r 0x1008 0 vs")
        report.check(got == '[3] "RFC-4800"', "309-3: segmented upload", got)
        got = c.ask("[4] 1 20 w 0x1017 0 u16 150")
        report.check(got == "[4] OK", "309-3: write heartbeat time 200 -> 150 ms", got)
        got = c.ask("[5] 1 20 r 0x1017 0 u16")
        report.check(got == "[5] 150", "309-3: read back the written value", got)
        got = c.ask("[6] 1 20 w 0x1017 0 u16 200")
        report.check(got == "[6] OK", "309-3: heartbeat time back to 200 ms", got)
        got = c.ask("[7] 1 10 jump")
        report.check(got == "[7] ERROR: 100", "309-3: unknown command answered 100", got)
    finally:
        c.close()


def modbus_reads(report):
    from pymodbus.client import ModbusTcpClient
    mb = ModbusTcpClient("127.0.0.1", port=MODBUS_PORT, timeout=10)
    report.check(mb.connect(), "Modbus client connected")
    try:
        for slot, (name, *_rest) in enumerate(DEVICES):
            r = mb.read_input_registers(256 + 32 * slot, 12, slave=1)
            ok = not r.isError() and r.registers[9] == 1
            report.check(ok, "Modbus: %s online in its slot" % name, str(r if r.isError() else r.registers))
    finally:
        mb.close()


def dds_samples(report, cli):
    """The DDS plugin's samples of every device reach a DDS reader (the CLI's
    `watch`, a Cyclone DDS subscriber in its own process)."""
    watch = subprocess.Popen([cli, "watch", "--json", "--gateway", "e2e"], stdout=subprocess.PIPE,
                             stderr=subprocess.DEVNULL, text=True)
    seen = set()
    end = time.time() + 60
    try:
        while time.time() < end and len(seen) < len(DEVICES):
            line = watch.stdout.readline()
            if not line:
                break
            if '"EncoderSample"' in line:
                seen.add(json.loads(line).get("node_id"))
    finally:
        watch.send_signal(signal.SIGINT)
        try:
            watch.wait(10)
        except subprocess.TimeoutExpired:
            watch.kill()
            watch.wait()
    report.check(seen >= {n for (*_, n) in DEVICES}, "DDS: samples of every device reach a subscriber", str(sorted(seen)))


def web_reads(report):
    conn = http.client.HTTPConnection("127.0.0.1", WEB_PORT, timeout=30)
    try:
        conn.request("GET", "/api/v1/status")
        resp = conn.getresponse()
        body = resp.read()
        names = [d["name"] for b in json.loads(body)["buses"] for d in b["devices"]] if resp.status == 200 else []
        report.check(sorted(names) == sorted(NAMES), "web: /api/v1/status lists the devices", "HTTP %d" % resp.status)
        conn.request("GET", "/metrics")
        resp = conn.getresponse()
        text = resp.read().decode(errors="replace")
        report.check(resp.status == 200 and "cobridge_" in text, "web: /metrics", "HTTP %d" % resp.status)
    finally:
        conn.close()


def power_cycle(report, daemon, sim, listener):
    name, _, _, serial, node = DEVICES[0]
    before = daemon.devices()[name].get("boot_ups", 0)
    t0 = time.time()
    sim.command("power-cycle %d" % serial)
    boot = listener.wait_for(lambda i, d: i == 0x700 + node and d == b"\x00", 10, since=t0)
    report.check(boot is not None, "power cycle: %s's boot-up on the bus" % name)
    st, took = daemon.wait_until(lambda s: any(
        d["name"] == name and d["state"] == "operational" and d["online"] and d.get("boot_ups", 0) > before
        for b in s["buses"] for d in b["devices"]), 60, interval=0.2)
    report.check(took is not None, "power cycle: %s configured and operational again" % name,
                 "%.2f s" % took if took is not None else daemon.tail(20))


def reload_changed(report, daemon, ws, gateway_socket):
    """A reload that changes a device's TPDO event timer: accepted, and the
    device is configured again with the new value (read back over SDO)."""
    config(ws, device_entries(200), gateway_socket)
    mark = daemon.log_size()
    os.kill(daemon.pid, signal.SIGHUP)
    report.check(daemon.wait_log("reloaded: %d devices" % len(DEVICES), since=mark, timeout=60),
                 "reload with a changed event timer accepted")
    node = DEVICES[1][4]
    value = None
    end = time.time() + 60
    while time.time() < end and value != 200:
        value = daemon.request("sdo-read line1 %d 1800 5 2000" % node, timeout=20).get("value")
        if value != 200:
            time.sleep(0.2)
    report.check(value == 200, "reload: the device's event timer is 200 ms (0x1800:5 read back)", str(value))
    _, took = daemon.wait_until(e2e.all_operational(NAMES), 60, interval=0.2)
    report.check(took is not None, "reload: every device operational")


def verdict(report, args, rc, log):
    text = open(log, errors="replace").read() if os.path.exists(log) else ""
    summary = re.findall(r"ERROR SUMMARY: (\d+) errors", text)
    errors = int(summary[-1]) if summary else None
    ok = rc == 0 and errors == 0
    report.check(ok, "%s: no error reported, exit 0" % args.tool,
                 "exit %s, %s" % (rc, "ERROR SUMMARY %s" % errors if summary else "no ERROR SUMMARY line"))
    if not ok:
        print(text[-20000:])


def main():
    args = e2e.parse_args(lambda p: (p.add_argument("--tool", choices=sorted(TOOL_ARGS), default="memcheck"),
                                     p.add_argument("--valgrind", default="valgrind")))
    report = e2e.Report("test_valgrind (%s)" % args.tool)
    exe = valgrind_executable(args.valgrind)
    ws = e2e.Workspace("valgrind-" + args.tool, args.keep)
    log = ws.path("valgrind.log")
    os.environ["CYCLONEDDS_URI"] = '<General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General>'
    prefix = [exe, "--tool=" + args.tool, "--error-exitcode=%d" % ERROR_EXIT, "--num-callers=30",
              "--suppressions=" + SUPPRESSIONS, "--log-file=" + log] + TOOL_ARGS[args.tool]
    gateway_socket = os.path.join(ws.run, "ascii.sock")
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d" % (sm, s, n) for (_, _, sm, s, n) in DEVICES]})
    path = config(ws, device_entries(100), gateway_socket)
    daemon = e2e.Daemon(args.daemon, path, ws, extra_args=["--plugin-dir", args.plugins], run_as=prefix)
    t_start = time.time()
    try:
        report.check(daemon.wait_socket(120), "control socket up under %s" % args.tool)
        _, took = daemon.wait_until(e2e.all_operational(NAMES), 120, interval=0.2)
        if not report.check(took is not None, "devices operational", "%.1f s" % took if took else daemon.tail(40)):
            return report.finish()
        control_reads(report, daemon)
        gateway_reads(report, gateway_socket)
        modbus_reads(report)
        web_reads(report)
        dds_samples(report, args.cli)
        power_cycle(report, daemon, sim, listener)
        reload_changed(report, daemon, ws, gateway_socket)
        rc, took = daemon.stop(timeout=120)
        daemon = None
        print("info scenario and shutdown under %s: %.1f s (exit after SIGTERM %.1f s)"
              % (args.tool, time.time() - t_start, took), flush=True)
        verdict(report, args, rc, log)
    finally:
        e2e.shut_down(ws, daemon, sim, listener)
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
