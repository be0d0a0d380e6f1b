#!/usr/bin/python3
"""cobridge-sim's command line as a user meets it: --help documents every
option, key and control command (exit 0); a bad argument names itself and
what is allowed, exits 2 and never crashes. Runs without a CAN interface:
arguments are checked before any socket opens.
"""

import subprocess

import simtest
from simtest import REPORT, check


def run(args):
    p = subprocess.run([args.sim, "--help"], capture_output=True, text=True, timeout=30)
    check(p.returncode == 0, "--help exit code %d" % p.returncode)
    for word in ("--iface", "--device", "--state-dir", "--truth", "--control", "--devices-dir", "serial=", "node=",
                 "channels=", "bitrate=", "lss=", "segmented=", "motion=", "power-cycle", "power-off", "power-on",
                 "silence", "fault", "move", "flood", "babble", "bus-error", "quit", "RFC-4800", "MC1-2800", "RM9000"):
        check(word in p.stdout, "--help does not mention %s" % word)
    REPORT.ok("--help documents options, keys, models and control commands")

    cases = [
        ([], "--iface"),
        (["--iface", "vcan0"], "--device"),
        (["--iface", "vcan0", "--device", "NOPE"], "unknown model 'NOPE'"),
        (["--iface", "vcan0", "--device", "RFC-4800:node=0"], "node must be 1..127 or 'unconfigured'"),
        (["--iface", "vcan0", "--device", "RFC-4800:bitrate=20"], "50|125|250|500|800|1000"),
        (["--iface", "vcan0", "--device", "MC1-2800:channels=2"], "channels"),
        (["--iface", "vcan0", "--device", "RFC-4800:lss=v2"], "default|v1|v3|none"),
        (["--iface", "vcan0", "--device", "RFC-4800:segmented=maybe"], "on|off"),
        (["--iface", "vcan0", "--device", "RFC-4800:motion=wobble:3"], "motion"),
        (["--device", "RFC-4800", "--iface", "vcan0"], "before any --iface"),
        (["--iface", "vcan0", "--device", "RFC-4800:serial=1", "--device", "RM9000:serial=1"], "serial 1"),
        (["--iface", "vcan0", "--device", "RFC-4800", "--devices-dir", "/nonexistent"], "--devices-dir"),
    ]
    for argv, expect in cases:
        p = subprocess.run([args.sim] + argv, capture_output=True, text=True, timeout=30, stdin=subprocess.DEVNULL)
        check(p.returncode == 2, "%s: exit code %d (stderr %r), expected 2" % (argv, p.returncode, p.stderr))
        check(expect in p.stderr, "%s: stderr %r does not name %r" % (argv, p.stderr, expect))
        REPORT.ok("exit 2: %s" % " ".join(argv) if argv else "exit 2: no arguments", p.stderr.strip().splitlines()[0])


if __name__ == "__main__":
    simtest.main(run)
