"""Bad configurations (the config layer's bad_*
fixtures: wrong types, unknown keys, node-ID out of range (CiA 301 §7.5.2:
1..127), duplicate names, ...; and here a missing EDS and a malformed
CiA 306 EDS) each give a clear error (file:line:column: message) and a
non-zero exit of `cobridged --check-config` and of `cobridged --config`,
without touching the bus: a raw socket on every vcan sees no frame.
"""
import glob
import os
import re
import shutil
import subprocess
import sys
import time

import e2e

HERE = os.path.dirname(os.path.abspath(__file__))
CONFIG_FIXTURES = os.path.join(e2e.SOURCE_DIR, "tests", "unit", "config", "fixtures")
OWN_FIXTURES = os.path.join(HERE, "fixtures")
DIAGNOSTIC = re.compile(r"^\S+?:\d+(:\d+)?: .+", re.M)


def staged_fixtures(ws):
    """The fixtures, copied with their interfaces pointed at the vcans, so that
    a daemon that did open its buses would be seen doing it."""
    out = []
    for path in sorted(glob.glob(os.path.join(CONFIG_FIXTURES, "bad_*.toml"))) + \
            sorted(glob.glob(os.path.join(OWN_FIXTURES, "bad_*.toml"))):
        origin = "config" if path.startswith(CONFIG_FIXTURES) else "daemon"
        with open(path) as f:
            text = f.read()
        text = re.sub(r'interface\s*=\s*"can(\d)"', lambda m: 'interface = "vcan%s"' % (int(m.group(1)) % 2), text)
        target = ws.path("%s-%s" % (origin, os.path.basename(path)))
        with open(target, "w") as f:
            f.write(text)
        out.append((origin + "/" + os.path.basename(path), target))
    shutil.copy(os.path.join(OWN_FIXTURES, "malformed.eds"), ws.path("malformed.eds"))
    shutil.copy(os.path.join(OWN_FIXTURES, "unknown_family.eds"), ws.path("unknown_family.eds"))
    # 50 000 levels of nesting (toml++ recurses per level).
    deep = ws.path("daemon-bad_deep_nesting.toml")
    with open(deep, "w") as f:
        f.write('[[bus]]\nname = "line1"\ninterface = "vcan0"\nx = ' + "[" * 50000 + "]" * 50000 + "\n")
    out.append(("daemon/bad_deep_nesting.toml", deep))
    # 100 000 levels of dotted keys and table headers
    # (toml++ recurses per segment: SIGSEGV), each form in its own file.
    keys = ".".join(["a"] * 100000)
    for form, text in (("dotted_key", keys + " = 1"), ("table_header", "[" + keys + "]"),
                       ("array_header", "[[" + keys + "]]"), ("inline_key", "x = { " + keys + " = 1 }")):
        name = "daemon-bad_deep_%s.toml" % form
        with open(ws.path(name), "w") as f:
            f.write('[[bus]]\nname = "line1"\ninterface = "vcan0"\n\n' + text + "\n")
        out.append(("daemon/bad_deep_%s.toml" % form, ws.path(name)))
    return out


def bad_state_file(report, args, ws, config):
    """docs/operations.md, "A state file that cannot be read": a state file
    with malformed lines is not a bad configuration: the daemon starts, and
    says once, at error level, naming the file and each line that does not
    read (file:line: why), that it set the file aside
    (test_state_file.py follows the hold through)."""
    os.makedirs(ws.state, exist_ok=True)
    state = os.path.join(ws.state, "assignments.state")
    with open(state, "w") as f:
        f.write("# remembered node-IDs\n"
                "bus=line1 serial=0x1 vendor=0x12 product=0x34 revision=0x1 node=5\n"
                "bus=line1 serial=zz vendor=1 product=1 revision=1 node=1\n"
                "garbage\n")
    daemon = e2e.Daemon(args.daemon, config, ws, log_name="daemon-badstate.log")
    up = daemon.wait_socket(10)
    rc, _ = daemon.stop()
    with open(daemon.log_path) as f:
        log = f.read()
    warnings = [l for l in log.splitlines() if "state file %s: 2 lines do not read:" % state in l]
    report.check(up and rc == 0, "a malformed state file does not stop the daemon", "exit %s" % rc)
    report.check(len(warnings) == 1 and "%s:3:" % state in log and "%s:4:" % state in log and "%s:2:" % state not in log,
                 "the lines that do not read are logged once, each as file:line", log[-600:])
    report.check("set aside as %s.bad-" % state in log and not os.path.exists(state),
                 "and the file is set aside, not written over", log[-600:])


def exposure(report, args, ws):
    """A valid file that opens doors to the network passes,
    with a warning at each line that opens one."""
    open_ = e2e.write_config(ws, [{"name": "line1", "interface": "vcan0"}],
                             [{"name": "enc", "bus": "line1", "serial": 1, "model": "RM9", "node_id": 5}],
                             file_name="exposed.toml",
                             extra='[outputs.modbus]\nbind = "0.0.0.0"\nwrites_enabled = true\n'
                                   '[web]\nbind = "0.0.0.0"\n')
    r = subprocess.run([args.daemon, "--check-config", open_], capture_output=True, text=True, timeout=20)
    warned = [l for l in r.stderr.splitlines() if l.startswith("warning: %s:" % open_)]
    report.check(r.returncode == 0 and any("[outputs.modbus] listens on 0.0.0.0" in l for l in warned) and
                 any("writes_enabled and no write_allow" in l for l in warned) and
                 any("[web] serves 0.0.0.0:8080" in l and "without TLS" in l for l in warned),
                 "--check-config passes an exposed file and warns at file:line about each door",
                 "exit %d; %s" % (r.returncode, " | ".join(warned)[:400]))


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_bad_config")
    ws = e2e.Workspace("badconfig", args.keep)
    listeners = [e2e.CanListener("vcan0"), e2e.CanListener("vcan1")]
    try:
        fixtures = staged_fixtures(ws)
        report.check(len(fixtures) >= 16, "bad fixtures found", "%d" % len(fixtures))
        for name, path in fixtures:
            t0 = time.time()
            r = subprocess.run([args.daemon, "--check-config", path], capture_output=True, text=True, timeout=20)
            diags = [l for l in r.stderr.splitlines() if l.startswith(ws.dir) and DIAGNOSTIC.match(l)]
            # returncode < 0: killed by a signal (a stack overflow is -11, SIGSEGV).
            report.check(r.returncode == 1 and diags,
                         "%s: --check-config exits 1 with file:line:col diagnostics" % name,
                         "exit %d, first: %s" % (r.returncode, diags[0] if diags else r.stderr.strip()[:200]))
            if name.endswith("bad_malformed_eds.toml"):
                report.check("malformed.eds:25:" in r.stderr and "malformed.eds:47:" in r.stderr,
                             "%s: each EDS problem named with its file and line" % name, r.stderr.strip()[:400])
            expected = {"bad_deep_nesting.toml": "nested more than 32 levels deep",
                        "bad_deep_dotted_key.toml": ":5:60: key nested more than 32 levels deep",
                        "bad_deep_table_header.toml": ":5:65: table header nested more than 32 levels deep",
                        "bad_deep_array_header.toml": ":5:64: table header nested more than 32 levels deep",
                        "bad_deep_inline_key.toml": ":5:64: key nested more than 32 levels deep",
                        "bad_unknown_family.toml": "names no device family cobridge knows",
                        "bad_long_control_socket.toml": "a Unix socket path may have at most 107",
                        "bad_output_unknown_key.toml": "unknown key 'prot'",
                        "bad_missing_plugin.toml": "libcobridge_historian.so"}
            for suffix, text in expected.items():
                if name.endswith(suffix):
                    report.check(text in r.stderr, "%s: the error says %r" % (name, text), r.stderr.strip()[-300:])
            if name.endswith("bad_missing_eds.toml"):
                report.check("does not exist" in r.stderr, "%s: the missing EDS file is named" % name,
                             r.stderr.strip()[:300])

            r2 = subprocess.run([args.daemon, "--config", path, "--foreground"], capture_output=True, text=True,
                                timeout=20)
            took = time.time() - t0
            report.check(r2.returncode == 1 and "no bus was touched" in r2.stderr and
                         [l for l in r2.stderr.splitlines() if DIAGNOSTIC.match(l)],
                         "%s: cobridged --config exits 1 with the same errors" % name,
                         "exit %d" % r2.returncode)
            frames = [f for li in listeners for f in li.snapshot(t0)]
            report.check(not frames, "%s: no frame on vcan0/vcan1" % name, "%d frames" % len(frames))

        # The same check accepts a good configuration: the test can tell them apart.
        good = e2e.write_config(ws, [{"name": "line1", "interface": "vcan0"}],
                                [{"name": "enc", "bus": "line1", "serial": 1, "model": "RM9", "node_id": 5}])
        r = subprocess.run([args.daemon, "--check-config", good], capture_output=True, text=True, timeout=20)
        report.check(r.returncode == 0 and "ok" in r.stdout, "a good configuration passes --check-config",
                     (r.stdout + r.stderr).strip()[:300])
        t0 = time.time()
        r = subprocess.run([args.daemon, "--check-config", good], capture_output=True, text=True, timeout=20)
        frames = [f for li in listeners for f in li.snapshot(t0)]
        report.check(not frames, "--check-config of a good configuration never opens a bus", "%d frames" % len(frames))
        exposure(report, args, ws)
        bad_state_file(report, args, ws, good)
    finally:
        for li in listeners:
            li.close()
        ws.cleanup()
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
