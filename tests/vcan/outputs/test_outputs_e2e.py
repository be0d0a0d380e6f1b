#!/usr/bin/python3
"""The outputs end to end, inside UML on vcan0 (run by tests/vcan/run-in-vcan).

cobridge-sim (four encoders of three families, TPDO1 every 1 ms, --truth)
-> cobridged (hot path, DDS reliable, Modbus TCP, JSON tap)
-> a DDS subscriber (`cobridge watch --json --reliable`), the JSON tap file,
   and an independent Modbus client (pymodbus).

Asserts:
* the JSON tap has every TPDO from the first one after the NMT start (the
  soak's loss criterion);
* every TPDO value the simulator put on the bus in the measured window
  reaches the DDS subscriber and the JSON tap, with the same value, in
  order, none lost (CiA 301 PDO payloads compared byte for byte for the tap,
  positions for DDS);
* Modbus reads return a value the device really sent, with a data age
  consistent with 1 ms updates;
* a silenced device shows offline on the DDS DeviceStatus topic and in
  Modbus within its supervision time, and its values are flagged stale.
"""
import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

FAIL = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        FAIL.append(what)


# A sanitizer build (tests/vcan/sanitizer-reports): its time bounds are printed, not judged
# (tests/vcan/daemon/e2e.py, Report.check_bound).
SANITIZER = os.environ.get("COBRIDGE_SANITIZER", "")


def check_bound(cond, what):
    if cond or not SANITIZER:
        check(cond, what)
    else:
        print("BOUND %s (not judged: %s build)" % (what, SANITIZER), flush=True)


def now_ns():
    return time.clock_gettime_ns(time.CLOCK_REALTIME)


DEVICES = [  # name, model, serial, node, mapping, motion
    ("rot-a", "RFC-4800", 101, 10, ["position", "speed"], "constant:0.3"),
    ("rot-b", "RSA-3200", 102, 11, ["position", "speed"], "constant:-0.2"),
    ("mt", "MC1-2800", 103, 12, ["position", "speed"], "constant:0.5"),
    ("ifm", "RM9000", 104, 13, ["position"], "constant:1"),
]


def config_text(work, repo):
    out = [
        "[gateway]", 'id = "e2e"', f'state_dir = "{work}/state"', f'control_socket = "{work}/control.sock"',
        f'device_dirs = ["{repo}/config/devices"]',
        "[logging]", 'level = "warn"', 'target = "console"',
        "[[bus]]", 'name = "line1"', 'interface = "vcan0"', "lss_timeout_ms = 30", "sdo_timeout_ms = 200",
    ]
    for name, model, serial, node, mapping, _ in DEVICES:
        out += ["[[device]]", f'name = "{name}"', 'bus = "line1"', f"serial = {serial}", f'model = "{model}"',
                f"node_id = {node}", "heartbeat_ms = 100", "[device.tpdo1]",
                "mapping = [" + ", ".join(f'"{m}"' for m in mapping) + "]", "transmission = 254", "event_timer_ms = 1"]
    out += ["[outputs.dds]", 'sample_reliability = "reliable"', "sample_depth = 10000",
            "[outputs.modbus]", 'bind = "127.0.0.1"', "port = 1502", "offline_exception = false",
            "[outputs.jsontap]", f'path = "{work}/tap.jsonl"']
    return "\n".join(out) + "\n"


def match_from(expected, got, start):
    """(missing, gaps) of `expected` matched in order in `got` from `start`."""
    missing = gaps = 0
    j = start
    for e in expected:
        k = j
        while k < len(got) and k < j + 64 and got[k] != e:
            k += 1
        if k < len(got) and got[k] == e:
            gaps += k - j
            j = k + 1
        else:
            missing += 1
    return missing, gaps


def match_in_order(expected, got):
    """Finds `expected` as a run inside `got`: returns (missing, gaps, start).
    missing: expected items not found in order; gaps: extra items between
    matched ones (another value slipped in, or order broken). Payloads and
    positions repeat (a rotary position wraps), so the run may begin at any
    place holding expected[0]: the best match of all such places counts (CI
    once anchored at an earlier wrap of the same value: 266 of 4466)."""
    if not expected:
        return 0, 0, None
    best = None
    for start in (i for i, g in enumerate(got) if g == expected[0]):
        missing, gaps = match_from(expected, got, start)
        if best is None or (missing, gaps) < best[:2]:
            best = (missing, gaps, start)
        if missing == 0 and gaps == 0:
            break
    return best if best is not None else (len(expected), 0, None)


def status(cli, work):
    try:
        r = subprocess.run([cli, "status", "--control", f"{work}/control.sock", "--json"], capture_output=True,
                           text=True, timeout=5)
        # Until the daemon listens, --json prints the error object and exits non-zero.
        return json.loads(r.stdout) if r.returncode == 0 else None
    except Exception:
        return None


def sim_command(work, line):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.connect(f"{work}/sim.sock")
    s.sendall((line + "\n").encode())
    reply = s.recv(4096).decode()
    s.close()
    return reply.strip()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--daemon", required=True)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--plugins", required=True)
    ap.add_argument("--repo", required=True)
    ap.add_argument("--seconds", type=float, default=10.0)
    a = ap.parse_args()
    # Loopback only; and room in the writer's history cache so that a reliable
    # writer does not block at Cyclone's 500 kB default high-water mark while
    # UML's slow reader acknowledges (docs/dds.md).
    os.environ["CYCLONEDDS_URI"] = ('<General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General>'
                                    '<Internal><Watermarks><WhcHigh>64MB</WhcHigh></Watermarks></Internal>')
    work = tempfile.mkdtemp(prefix="cobridge-e2e-outputs-")
    rc = 1
    try:
        rc = run(a, work)
    finally:
        if rc == 0:
            shutil.rmtree(work, ignore_errors=True)  # 60 MB of logs and taps per run
        else:
            print(f"work directory kept for inspection: {work}")
    return rc


def run(a, work):
    with open(f"{work}/e2e.toml", "w") as f:
        f.write(config_text(work, a.repo))
    sim_args = [a.sim, "--iface", "vcan0", "--truth", f"{work}/truth.txt", "--control", f"{work}/sim.sock",
                "--state-dir", f"{work}/nv"]
    for name, model, serial, node, _, motion in DEVICES:
        sim_args += ["--device", f"{model}:serial={serial},node={node},motion={motion}"]
    sim = subprocess.Popen(sim_args, stdout=subprocess.DEVNULL, stderr=open(f"{work}/sim.log", "w"))
    daemon = subprocess.Popen([a.daemon, "--foreground", "--config", f"{work}/e2e.toml", "--plugin-dir", a.plugins],
                              stdout=subprocess.DEVNULL, stderr=open(f"{work}/daemon.log", "w"))
    watch = None
    try:
        t_start = time.time()
        ops = 0
        while time.time() - t_start < 60:
            st = status(a.cli, work)
            if st:
                ops = sum(1 for b in st["buses"] for d in b["devices"] if d["state"] == "operational")
                if ops == len(DEVICES):
                    break
            time.sleep(0.5)
        check(ops == len(DEVICES), f"all {len(DEVICES)} devices operational ({ops}) after {time.time() - t_start:.1f} s")
        if ops != len(DEVICES):
            print(open(f"{work}/daemon.log").read()[-3000:])
            return 1
        watch = subprocess.Popen([a.cli, "watch", "--json", "--reliable", "--gateway", "e2e"],
                                 stdout=open(f"{work}/watch.jsonl", "w"), stderr=subprocess.DEVNULL)
        # DDS discovery and matching: done once the subscriber prints a sample (about 2 s in UML;
        # longer for a sanitizer build on the QEMU bed).
        t_match = time.time()
        while time.time() - t_match < 60 and b'"position"' not in open(f"{work}/watch.jsonl", "rb").read(65536):
            time.sleep(0.2)
        print(f"info DDS subscriber matched after {time.time() - t_match:.1f} s", flush=True)
        t0 = now_ns()
        time.sleep(a.seconds)
        t1 = now_ns()
        time.sleep(2.0)  # let the reliable DDS backlog of the window drain
        from pymodbus.client import ModbusTcpClient
        mb = ModbusTcpClient("127.0.0.1", port=1502)
        check(mb.connect(), "Modbus client connected")
        # Silence the ifm device: DDS status offline, Modbus online=0, stale.
        check(sim_command(work, "silence 104 on").startswith("ok"), "simulator: silence 104")
        t_silence = now_ns()
        offline_after = None
        while now_ns() - t_silence < 3e9:
            r = mb.read_input_registers(256 + 32 * 3, 12, slave=1)
            if not r.isError() and r.registers[9] == 0:
                offline_after = (now_ns() - t_silence) / 1e6
                stale_flag = r.registers[10]
                break
            time.sleep(0.02)
        check(offline_after is not None and offline_after <= 1000,
              f"Modbus shows the silenced device offline after {offline_after} ms (consumer time 200 ms; UML slack to 1 s)")
        if offline_after is not None:
            check(stale_flag == 1, "Modbus stale flag set for the silenced device")
        time.sleep(1.0)  # the DDS DeviceStatus change reaches the subscriber
        check(sim_command(work, "silence 104 off").startswith("ok"), "simulator: silence 104 off")
        t_unsilence = now_ns()
        time.sleep(1.5)
        # The DDS plugin writes from its own queue (so DDS never delays Modbus);
        # in UML a reliable subscriber acknowledges slowly and the writer lags:
        # wait until the subscriber's output stops growing (at most 90 s).
        # The plugin's queue is FIFO and the reader reliable: once a sample
        # received after the silence ended has arrived, the window and the
        # offline status before it are complete.
        t_dds = time.time()
        caught_up = False
        while time.time() - t_dds < 90 and not caught_up:
            with open(f"{work}/watch.jsonl", "rb") as wf:
                wf.seek(max(0, os.path.getsize(f"{work}/watch.jsonl") - 65536))
                for line in wf.read().decode(errors="replace").splitlines():
                    if '"rx_timestamp_ns":' in line and '"EncoderSample"' in line:
                        try:
                            if json.loads(line)["rx_timestamp_ns"] > t_unsilence:
                                caught_up = True
                        except ValueError:
                            pass
            time.sleep(0.5)
        print(f"info DDS subscriber past the end of the silence {time.time() - t_dds:.1f} s later", flush=True)
        # Phase 2: the DDS subscriber (JSON to a file, 4 000 lines/s) costs UML's
        # one CPU more than the gateway does, so freshness is measured with it
        # stopped; completeness above was measured with it running.
        watch.send_signal(signal.SIGINT)
        watch.wait(timeout=10)
        # A reliable DDS writer whose reader just left may block the shared
        # dispatcher for a while (max_blocking_time per write, docs/dds.md);
        # judge freshness in the steady state: wait (at most 20 s) until the
        # backlog has drained, and report how long that took.
        t_drain = now_ns()
        while now_ns() - t_drain < 20e9:
            r = mb.read_input_registers(256, 12, slave=1)
            if not r.isError() and r.registers[11] < 20:
                break
            time.sleep(0.1)
        print(f"info backlog after the reliable subscriber left drained in {(now_ns() - t_drain) / 1e6:.0f} ms", flush=True)
        time.sleep(0.5)
        mb.close()  # the server closes idle connections (idle_timeout_s); start afresh
        mb = ModbusTcpClient("127.0.0.1", port=1502)
        check(mb.connect(), "Modbus client reconnected for the freshness phase")
        # 12 s of reads (about 110 a device on QEMU): the bounds below are a
        # median and a 95th percentile, and of the 33 reads 4 s gave, the
        # "95th" was the second largest; the first seconds after the drain
        # are the noisiest (UML, 2026-12-02: p95 44-73 ms over 4 s, 18-28 ms
        # over 12 s, same build, no idle keepers).
        reads = []
        t_reads = now_ns()
        while now_ns() - t_reads < 12e9:
            for slot, (name, _, _, node, _, _) in enumerate(DEVICES):
                r = mb.read_input_registers(256 + 32 * slot, 12, slave=1)
                if r.isError():
                    reads.append((name, None, None, None, now_ns()))
                    continue
                v = r.registers
                pos = (v[0] << 16) | v[1]
                reads.append((name, pos, v[11], v[9], now_ns()))
            time.sleep(0.1)
        mb.close()
        # A shutdown under full load (four devices at 1 ms,
        # every plugin running) ends in the reverse order of the start, exit 0.
        t_stop = time.time()
        daemon.send_signal(signal.SIGTERM)
        rc = daemon.wait(timeout=10)
        took = time.time() - t_stop
        check(rc == 0, f"SIGTERM under full load: exit {rc}")
        check_bound(took < 1.0, f"SIGTERM under full load: exit after {took:.3f} s (limit 1 s)")
    finally:
        if watch and watch.poll() is None:
            watch.send_signal(signal.SIGINT)
        if daemon.poll() is None:
            daemon.send_signal(signal.SIGTERM)
            daemon.wait(timeout=10)
        sim.send_signal(signal.SIGTERM)
        sim.wait(timeout=10)
        if watch:
            try:
                watch.wait(timeout=5)
            except subprocess.TimeoutExpired:
                watch.kill()

    # --- analysis -------------------------------------------------------
    truth = {}  # node -> [(ts, data_hex, pos)]
    for line in open(f"{work}/truth.txt"):
        f = line.split()
        if len(f) < 8 or f[4] != "tpdo1":
            continue
        pos = next((int(x[4:]) for x in f[8:] if x.startswith("pos=")), None)
        truth.setdefault(int(f[3]), []).append((int(f[0]), f[7].lower(), pos))
    tap = {}
    for line in open(f"{work}/tap.jsonl"):
        try:
            j = json.loads(line)
        except ValueError:
            continue
        if j.get("type") == "sample" and j.get("kind") == "tpdo":
            tap.setdefault(j["node_id"], []).append((j["rx_timestamp_ns"], j["raw"].lower(), j.get("position")))
    dds = {}
    dds_status = []
    for line in open(f"{work}/watch.jsonl"):
        try:
            j = json.loads(line)
        except ValueError:
            continue
        if j.get("topic") == "EncoderSample":
            dds.setdefault(j["node_id"], []).append((j["rx_timestamp_ns"], j.get("position"), j["sequence"], j["stale"]))
        elif j.get("topic") == "DeviceStatus":
            dds_status.append(j)

    margin = int(0.3e9)  # frames in flight at the window's edges are not judged
    for name, model, serial, node, _, _ in DEVICES:
        sent = [t for t in truth.get(node, []) if t0 + margin <= t[0] <= t1 - margin]
        period = (t1 - t0 - 2 * margin) / 1e9
        check(len(sent) > 0, f"{name}: {len(sent)} TPDOs sent in {period:.1f} s ({len(sent) / period:.0f}/s, nominal 1000/s)")
        if not sent:
            continue
        # JSON tap: the same payload bytes, in the same order, none missing.
        # Payloads repeat when a position wraps, so match sequentially.
        missing, gaps, first = match_in_order([x[1] for x in sent], [t[1] for t in tap.get(node, [])])
        check(missing == 0, f"{name}: JSON tap has every sent payload, in order ({len(sent) - missing}/{len(sent)})")
        check(gaps == 0, f"{name}: JSON tap contiguous over the window")
        # Nothing lost from the very first TPDO after the
        # gateway's NMT start (the device sends none before it), i.e. the hot
        # path has the device's mapping before it is started.
        since_start = [t for t in truth.get(node, []) if t[0] <= t1 - margin]
        tap_node = [t[1] for t in tap.get(node, [])]
        missing0, gaps0, first0 = match_in_order([x[1] for x in since_start], tap_node)
        check(missing0 == 0 and gaps0 == 0 and first0 == 0,
              f"{name}: JSON tap has every TPDO from the first one after NMT start "
              f"({len(since_start) - missing0}/{len(since_start)}, first at tap index {first0})")
        # DDS: the same positions, in order, none missing, nothing foreign in
        # between. Stale re-publications (the plugin repeats the last value
        # with stale=true when a device goes quiet, e.g. during a UML stall)
        # are not new values and are left out. EncoderSample is numbered per
        # device by TPDOs alone, so the numbers are contiguous.
        d = [x for x in dds.get(node, []) if not x[3]]
        missing_d, gaps_d, first_d = match_in_order([x[2] for x in sent], [x[1] for x in d])
        check(missing_d == 0, f"{name}: DDS subscriber got every sent position, in order ({len(sent) - missing_d}/{len(sent)})")
        check(gaps_d == 0, f"{name}: no foreign DDS values between them")
        if first_d is not None:
            seqs = [x[2] for x in d[first_d:first_d + len(sent)]]
            check(all(y == x + 1 for x, y in zip(seqs, seqs[1:])),
                  f"{name}: DDS sequence numbers contiguous, no gap ({len(seqs)} samples)")
        # Modbus: values the device really sent, fresh.
        mine = [r for r in reads if r[0] == name]
        good = [r for r in mine if r[1] is not None]
        check(len(good) == len(mine) and good, f"{name}: {len(good)} Modbus reads answered")
        if good:
            allpos = set((p & 0xFFFFFFFF) for (_, _, p) in truth.get(node, []) if p is not None)
            known = sum(1 for r in good if r[1] in allpos)
            check(known == len(good), f"{name}: every Modbus position is one the device sent ({known}/{len(good)})")
            # Data age: compared with when the simulator really sent its last
            # frame before the read, so a stall of the whole UML (which slows
            # the simulator too) is not blamed on the gateway.
            sends = [t[0] for t in truth.get(node, [])]
            excess = []
            import bisect
            for r in good:
                k = bisect.bisect_right(sends, r[4]) - 1
                if k >= 0:
                    excess.append(r[2] - (r[4] - sends[k]) / 1e6)
            excess.sort()
            ages = sorted(r[2] for r in good)
            # Median and 95th percentile: a single stall of UML's one CPU
            # (the host's other load) is not the gateway's; the max is shown.
            p95 = excess[min(len(excess) - 1, (len(excess) * 95) // 100)] if excess else None
            check_bound(excess and excess[len(excess) // 2] <= 10 and p95 <= 50,
                  f"{name}: Modbus data age median {ages[len(ages) // 2]} ms, max {ages[-1]} ms; beyond the time "
                  f"since the device's last frame: median {excess[len(excess) // 2]:.1f} ms, "
                  f"p95 {p95 if p95 is not None else float('nan'):.1f} ms, max {excess[-1] if excess else 0:.1f} ms "
                  f"(1 ms updates; limits: median 10 ms, p95 50 ms in UML)")
            # Online is the heartbeat consumer's verdict (consumer time 200 ms): a time bound too. Under
            # ASan on the QEMU bed the simulator sent 21 of its 1000 TPDOs a second and one read of 23
            # said offline (forced-QEMU .ci/run, 2026-11-30); judged in the default build on both beds.
            offline = sum(1 for r in good if r[3] != 1)
            check_bound(offline == 0, f"{name}: Modbus online=1 while sending ({offline} of {len(good)} reads offline)")
    off = [s for s in dds_status if s.get("node_id") == 13 and not s.get("online", True)]
    check(bool(off), "DDS DeviceStatus shows the silenced device offline")
    stale = [x for x in dds.get(13, []) if x[3]]
    check(bool(stale), "DDS EncoderSample of the silenced device re-published with stale=true")
    print(f"{len(FAIL)} failed" if FAIL else "all checks passed")
    return 1 if FAIL else 0


if __name__ == "__main__":
    sys.exit(main())
