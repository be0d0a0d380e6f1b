#!/usr/bin/python3
"""DDS Security on the DDS output, end to end inside UML.

cobridge-sim (two encoders, TPDO1 every 10 ms) -> cobridged with
[outputs.dds.security] (credentials from scripts/dds-test-ca: governance with
allow_unauthenticated_participants false, join access control, read and write
access control on every topic) -> three subscribers (cobridge_dds_probe):

* reader-all, granted every cobridge topic, gets every topic: EncoderSample,
  DeviceStatus of both devices, GatewayStatus, and the EncoderEvent of an EMCY
  injected meanwhile (OMG DDS Security 1.1, 9.4.1.3: a subscribe grant);
* a plain participant (no security) gets nothing at all (9.4.1.2:
  allow_unauthenticated_participants false; 9.3: authentication);
* reader-status, granted DeviceStatus only, is refused EncoderSample (and the
  other topics) and gets no sample, but gets DeviceStatus (9.4.1.3;
  8.4.2.9: access control checks at topic and reader creation).

Also: the daemon's start says "DDS Security: on" with the identity's subject;
`cobridge watch` given reader-all's identity through CYCLONEDDS_URI's
<Security> section prints EncoderSamples (docs/dds.md); and `cobridged
--check-config` refuses a private key open to others and a partial set,
naming the key and the path.
"""
import argparse
import json
import os
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time

FAIL = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        FAIL.append(what)


DEVICES = [  # name, model, serial, node
    ("rot-a", "RFC-4800", 401, 10),
    ("mt-a", "MC1-2800", 402, 11),
]
LO = '<General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General>'
SECURITY_KEYS = ("identity_ca", "identity_certificate", "private_key", "permissions_ca", "governance", "permissions")


def security_files(ca, identity):
    return {"identity_ca": f"{ca}/identity_ca.pem", "identity_certificate": f"{ca}/{identity}.pem",
            "private_key": f"{ca}/{identity}_key.pem", "permissions_ca": f"{ca}/permissions_ca.pem",
            "governance": f"{ca}/governance.p7s", "permissions": f"{ca}/{identity}_permissions.p7s"}


def config_text(work, repo, security):
    out = ["[gateway]", 'id = "sec-gw"', f'state_dir = "{work}/state"', f'control_socket = "{work}/control.sock"',
           f'device_dirs = ["{repo}/config/devices"]',
           "[logging]", 'level = "info"', 'target = "console"',
           "[[bus]]", 'name = "line1"', 'interface = "vcan0"', "lss_timeout_ms = 30", "sdo_timeout_ms = 200"]
    for name, model, serial, node in DEVICES:
        out += ["[[device]]", f'name = "{name}"', 'bus = "line1"', f"serial = {serial}", f'model = "{model}"',
                f"node_id = {node}", "heartbeat_ms = 100", "[device.tpdo1]", 'mapping = ["position", "speed"]',
                "transmission = 254", "event_timer_ms = 10"]
    out += ["[outputs.dds]", 'sample_reliability = "reliable"', "sample_depth = 100"]
    if security is not None:
        out += ["[outputs.dds.security]"] + [f'{k} = "{v}"' for k, v in security.items()]
    return "\n".join(out) + "\n"


def uri_security(ca, identity, lib):
    """A <Security> section for CYCLONEDDS_URI (how `cobridge watch` gets an identity)."""
    f = security_files(ca, identity)
    return ("<Security><Authentication>"
            f'<Library path="{lib}/libdds_security_auth.so" initFunction="init_authentication" '
            'finalizeFunction="finalize_authentication"/>'
            f"<IdentityCA>file:{f['identity_ca']}</IdentityCA>"
            f"<IdentityCertificate>file:{f['identity_certificate']}</IdentityCertificate>"
            f"<PrivateKey>file:{f['private_key']}</PrivateKey></Authentication><AccessControl>"
            f'<Library path="{lib}/libdds_security_ac.so" initFunction="init_access_control" '
            'finalizeFunction="finalize_access_control"/>'
            f"<PermissionsCA>file:{f['permissions_ca']}</PermissionsCA>"
            f"<Governance>file:{f['governance']}</Governance>"
            f"<Permissions>file:{f['permissions']}</Permissions></AccessControl><Cryptographic>"
            f'<Library path="{lib}/libdds_security_crypto.so" initFunction="init_crypto" '
            'finalizeFunction="finalize_crypto"/></Cryptographic></Security>')


def operational(cli, work):
    try:
        r = subprocess.run([cli, "status", "--control", f"{work}/control.sock", "--json"], capture_output=True,
                           text=True, timeout=20)
        st = json.loads(r.stdout) if r.returncode == 0 else None
        return sum(1 for b in st["buses"] for d in b["devices"] if d["state"] == "operational") if st else 0
    except Exception:
        return 0


def sim_command(work, line):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(5)
    s.connect(f"{work}/sim.sock")
    s.sendall((line + "\n").encode())
    reply = s.recv(4096).decode()
    s.close()
    return reply.strip()


def read_events(path):
    ev = []
    for line in open(path):
        try:
            ev.append(json.loads(line))
        except ValueError:
            pass
    return ev


def check_config_refusals(a, work, ca):
    """--check-config: a key readable by others, and a partial set, are refused by key and path."""
    open_key = f"{work}/open_key.pem"
    shutil.copy(f"{ca}/gateway_key.pem", open_key)
    os.chmod(open_key, 0o644)
    files = security_files(ca, "gateway")
    cases = [
        ("private key mode 0644", dict(files, private_key=open_key), ["'security.private_key'", open_key, "chmod 600"]),
        ("permissions missing", {k: v for k, v in files.items() if k != "permissions"},
         ["missing 'security.permissions'"]),
        ("governance not there", dict(files, governance=f"{ca}/nope.p7s"), ["'security.governance'", f"{ca}/nope.p7s"]),
    ]
    for what, sec, wanted in cases:
        path = f"{work}/bad.toml"
        with open(path, "w") as f:
            f.write(config_text(work, a.repo, sec))
        r = subprocess.run([a.daemon, "--check-config", path, "--plugin-dir", a.plugins], capture_output=True,
                           text=True, timeout=60)
        text = r.stdout + r.stderr
        check(r.returncode != 0 and all(w in text for w in wanted),
              f"--check-config refuses {what}, naming {', '.join(wanted)} (exit {r.returncode}: {text.strip()[-300:]!r})")


def main():
    ap = argparse.ArgumentParser()
    for k in ("daemon", "cli", "sim", "probe", "plugins", "repo"):
        ap.add_argument("--" + k, required=True)
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--security-plugins", required=True, help="folder of Cyclone's libdds_security_*.so")
    a = ap.parse_args()
    os.environ["CYCLONEDDS_URI"] = LO
    t_begin = time.time()
    work = tempfile.mkdtemp(prefix="cobridge-ddssec-")
    ca = f"{work}/ca"
    r = subprocess.run([f"{a.repo}/scripts/dds-test-ca", ca], capture_output=True, text=True, timeout=60)
    check(r.returncode == 0 and "[outputs.dds.security]" in r.stdout,
          f"scripts/dds-test-ca made the credentials ({r.returncode}: {r.stderr.strip()[-200:]})")
    if r.returncode != 0:
        return 1
    check(stat.S_IMODE(os.stat(f"{ca}/gateway_key.pem").st_mode) == 0o600, "the test CA's keys are mode 0600")
    check_config_refusals(a, work, ca)

    with open(f"{work}/sec.toml", "w") as f:
        f.write(config_text(work, a.repo, security_files(ca, "gateway")))
    sim_args = [a.sim, "--iface", "vcan0", "--control", f"{work}/sim.sock", "--state-dir", f"{work}/nv"]
    for _, model, serial, node in DEVICES:
        sim_args += ["--device", f"{model}:serial={serial},node={node},motion=constant:0.3"]
    procs = {}
    procs["sim"] = subprocess.Popen(sim_args, stdout=subprocess.DEVNULL, stderr=open(f"{work}/sim.log", "w"))
    procs["daemon"] = subprocess.Popen([a.daemon, "--foreground", "--config", f"{work}/sec.toml",
                                        "--plugin-dir", a.plugins],
                                       stdout=subprocess.DEVNULL, stderr=open(f"{work}/daemon.log", "w"))
    probes = {"reader-all": ["--security-dir", ca, "--identity", "reader-all"],
              "plain": [],
              "reader-status": ["--security-dir", ca, "--identity", "reader-status"]}
    try:
        t0 = time.time()
        ops = 0
        while time.time() - t0 < 60 and procs["daemon"].poll() is None:
            ops = operational(a.cli, work)
            if ops == len(DEVICES):
                break
            time.sleep(0.5)
        check(ops == len(DEVICES), f"both devices operational after {time.time() - t0:.1f} s")
        log = open(f"{work}/daemon.log", errors="replace").read()
        for line in log.splitlines():
            if "DDS Security:" in line:
                print("  daemon: " + line, flush=True)
        check("DDS Security: on, identity 'CN=gateway,O=cobridge test'" in log,
              "the daemon's start says DDS Security is on, as CN=gateway,O=cobridge test")
        if ops != len(DEVICES):
            print(log[-3000:])
            return 1

        for name, extra in probes.items():
            procs[name] = subprocess.Popen([a.probe, "--domain", "0", "--seconds", "120",
                                            "--stop-file", f"{work}/{name}.stop"] + extra,
                                           stdout=open(f"{work}/{name}.jsonl", "w"),
                                           stderr=open(f"{work}/{name}.err", "w"))
        env = dict(os.environ, CYCLONEDDS_URI=LO + uri_security(ca, "reader-all", a.security_plugins))
        procs["watch"] = subprocess.Popen([a.cli, "watch", "--json", "--gateway", "sec-gw", "--count", "40",
                                           "--timeout", "30"], env=env,
                                          stdout=open(f"{work}/watch.jsonl", "w"), stderr=open(f"{work}/watch.err", "w"))
        # Discovery, authentication handshakes, matching: done once both granted readers hold a
        # DeviceStatus of the gateway (3 s in UML; the handshakes' crypto is slower on the QEMU bed).
        t_match = time.time()
        while time.time() - t_match < 60 and not all(
                any(e.get("ev") == "status" and e.get("gateway_id") == "sec-gw"
                    for e in read_events(f"{work}/{name}.jsonl")) for name in ("reader-all", "reader-status")):
            time.sleep(0.2)
        print(f"  the granted readers matched after {time.time() - t_match:.1f} s", flush=True)
        check(sim_command(work, f"fault {DEVICES[0][2]} hardware-fault").startswith("ok"),
              "simulator: EMCY (hardware fault) injected")
        time.sleep(a.seconds)
        sim_command(work, f"fault {DEVICES[0][2]} clear")
        for name in probes:
            open(f"{work}/{name}.stop", "w").close()
        for name in probes:
            procs[name].wait(timeout=30)
        procs["watch"].wait(timeout=40)

        t_stop = time.time()
        procs["daemon"].send_signal(signal.SIGTERM)
        rc = procs["daemon"].wait(timeout=10)
        check(rc == 0, f"daemon exits 0 on SIGTERM ({rc}, {time.time() - t_stop:.2f} s)")
    finally:
        for p in procs.values():
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()

    # --- analysis -------------------------------------------------------
    ev = {name: read_events(f"{work}/{name}.jsonl") for name in probes}

    def totals(name):
        t = [e for e in ev[name] if e.get("ev") == "totals"]
        return t[-1] if t else {}

    def refused(name):
        return sorted(e["topic"] for e in ev[name] if e.get("ev") == "refused")

    def status_nodes(name):
        return sorted({e["node"] for e in ev[name] if e.get("ev") == "status" and e["gateway_id"] == "sec-gw"})

    for name in probes:
        err = open(f"{work}/{name}.err", errors="replace").read().strip()
        print(f"  {name}: {json.dumps(totals(name))}, refused {refused(name)}"
              + (f", stderr {err[-300:]!r}" if err else ""), flush=True)
    nodes = sorted(d[3] for d in DEVICES)

    t = totals("reader-all")
    check(refused("reader-all") == [], "reader-all: every topic and reader allowed")
    check(t.get("samples", 0) >= 100, f"reader-all: EncoderSamples received ({t.get('samples')})")
    check(status_nodes("reader-all") == nodes, f"reader-all: DeviceStatus of both devices ({status_nodes('reader-all')})")
    check(t.get("gateways", 0) >= 1, f"reader-all: GatewayStatus received ({t.get('gateways')})")
    emcy = [e for e in ev["reader-all"] if e.get("ev") == "event" and e["node"] == DEVICES[0][3]]
    check(bool(emcy), f"reader-all: the injected EMCY on EncoderEvent ({len(emcy)} events of node {DEVICES[0][3]})")

    t = totals("plain")
    check(bool(t) and refused("plain") == [], "plain participant: ran, its readers created (no security to refuse them)")
    check(t and t.get("samples") == 0 and t.get("statuses") == 0 and t.get("events") == 0 and t.get("gateways") == 0,
          f"plain participant (no credentials): nothing received on any topic ({json.dumps(t)})")

    t = totals("reader-status")
    check(refused("reader-status") == ["EncoderEvent", "EncoderSample", "GatewayStatus"],
          f"reader-status: EncoderSample, EncoderEvent, GatewayStatus refused by its permissions ({refused('reader-status')})")
    check(t.get("samples", -1) == 0, f"reader-status: no EncoderSample ({t.get('samples')})")
    check(status_nodes("reader-status") == nodes,
          f"reader-status: DeviceStatus of both devices ({status_nodes('reader-status')})")

    watch = [json.loads(x) for x in open(f"{work}/watch.jsonl") if x.startswith("{")]
    check(any(w.get("topic") == "EncoderSample" for w in watch),
          f"cobridge watch with reader-all's identity in CYCLONEDDS_URI prints EncoderSamples ({len(watch)} lines)")

    print(f"  work dir {work}; run time {time.time() - t_begin:.1f} s", flush=True)
    print(f"{len(FAIL)} failed" if FAIL else "all checks passed")
    if not FAIL:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if FAIL else 0


if __name__ == "__main__":
    sys.exit(main())
