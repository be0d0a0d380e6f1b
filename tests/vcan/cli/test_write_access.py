"""Who may use the control socket, with callers that are
not root (docs/operations.md "Control socket" > "Access").

The rule: the socket has mode 0660 (the service's user and group), so only
they may connect; reads (status, sdo-read) are for whoever may connect;
writes (sdo-write, nmt, lss-set-node-id) are refused with permission_denied
(CLI exit code 4) unless [control] writes_enabled is set -- then not even
root may write -- and the caller is root, the daemon's own user or in
[control] write_group, by the groups the kernel gives its process
(SO_PEERCRED's gid, SO_PEERGROUPS), the ones it checked the 0660 mode with.

Scenario (UML, real SocketCAN, cobridge-sim, the real daemon and CLI): the
daemon runs as a service user, as under systemd (User=, Group=); clients
run as other users through setpriv. The users and groups exist only inside
this UML run: copies of /etc/passwd and /etc/group with them added are
bind-mounted over the originals in UML's own mount table (the host's files
are never written).

  user          primary group   supplementary (database)   what it proves
  cbt-svc       cbt-svc         -                          the daemon's own user may write
  cbt-reader    cbt-reader      cbt-svc                    reads; a write refused, exit 4
  cbt-primary   cbt-admin       cbt-svc                    write group as primary group
  cbt-member    cbt-member      cbt-svc, cbt-admin         write group as supplementary group
  cbt-outsider  cbt-outsider    -                          cannot connect; the CLI says why

and two whose process groups differ from the database: cbt-reader given
cbt-admin by the process only (setpriv --groups, like systemd's
SupplementaryGroups=) may write; cbt-member with cbt-admin dropped may not.
"""
import grp
import json
import os
import pwd
import signal
import stat
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
import e2e  # noqa: E402

# name: (uid, primary group); groups: name -> (gid, members in the database)
USERS = {"cbt-svc": (64100, "cbt-svc"), "cbt-reader": (64102, "cbt-reader"), "cbt-primary": (64103, "cbt-admin"),
         "cbt-member": (64104, "cbt-member"), "cbt-outsider": (64105, "cbt-outsider")}
GROUPS = {"cbt-svc": (64100, ["cbt-reader", "cbt-primary", "cbt-member"]), "cbt-admin": (64101, ["cbt-member"]),
          "cbt-reader": (64102, []), "cbt-member": (64104, []), "cbt-outsider": (64105, [])}
WRITE = ["sdo", "write", "-i", "vcan0", "-n", "20", "1017:0", "100", "--size", "2", "--json"]
READ = ["sdo", "read", "-i", "vcan0", "-n", "20", "1018:4", "--json"]


def in_can_bed_guest():
    """True inside a guest of tests/vcan/run-in-vcan (UML or QEMU), whose PID 1 is its
    init script: the bind mounts below then change the guest's mount table, never the
    host's."""
    try:
        with open("/proc/1/cmdline", "rb") as f:
            return b"/run-in-vcan." in f.read()
    except OSError:
        return False


def install_identities(ws):
    """Bind-mounts /etc/passwd and /etc/group copies holding the test users
    (the guest's mount table only). Returns the mounted paths."""
    with open("/etc/passwd") as f:
        passwd = f.read().rstrip("\n").split("\n")
    with open("/etc/group") as f:
        group = f.read().rstrip("\n").split("\n")
    passwd += ["%s:x:%d:%d::/nonexistent:/usr/sbin/nologin" % (n, uid, GROUPS[g][0]) for n, (uid, g) in USERS.items()]
    group += ["%s:x:%d:%s" % (n, gid, ",".join(m)) for n, (gid, m) in GROUPS.items()]
    mounted = []
    for name, lines in (("passwd", passwd), ("group", group)):
        copy = ws.path(name)
        with open(copy, "w") as f:
            f.write("\n".join(lines) + "\n")
        os.chmod(copy, 0o644)
        subprocess.run(["mount", "--bind", copy, "/etc/" + name], check=True)
        mounted.append("/etc/" + name)
    return mounted


def as_user(user, groups=None):
    """setpriv prefix: the user's uid and primary gid, and either its
    database groups (--init-groups, as a login) or exactly `groups`."""
    uid, primary = USERS[user]
    prefix = ["setpriv", "--reuid=%d" % uid, "--regid=%d" % GROUPS[primary][0]]
    if groups is None:
        prefix.append("--init-groups")
    else:
        prefix.append("--groups=" + (",".join(str(GROUPS[g][0]) for g in groups)))
    return prefix + ["--"]


def cli(args, ws, prefix, *argv):
    r = subprocess.run(prefix + [args.cli] + list(argv) + ["--control", ws.control], capture_output=True, text=True,
                       timeout=30)
    try:
        doc = json.loads(r.stdout.strip().splitlines()[-1]) if r.stdout.strip() else {}
    except ValueError:
        doc = {"raw": r.stdout}
    return r.returncode, doc, r.stdout.strip() + " " + r.stderr.strip()


RAW_CLIENT = r"""
import socket, sys
s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
s.settimeout(10)
try:
    s.connect(sys.argv[1])
except OSError as e:
    print("connect: %s" % e.strerror)
    sys.exit(3)
s.sendall((sys.argv[2] + "\n").encode())
data = b""
while not data.endswith(b"\n"):
    chunk = s.recv(65536)
    if not chunk:
        break
    data += chunk
print(data.decode().strip())
"""


def raw(ws, prefix, line):
    """One request line through a bare Unix socket client run as `prefix`."""
    r = subprocess.run(prefix + ["/usr/bin/python3", "-c", RAW_CLIENT, ws.control, line], capture_output=True,
                       text=True, timeout=30)
    return r.returncode, r.stdout.strip()


def log_text(daemon):
    with open(daemon.log_path) as f:
        return f.read()


def refused(rc, doc):
    return rc == 4 and doc.get("ok") is False and doc.get("error", {}).get("code") == "permission_denied"


def reload(daemon, ws, bus, devices, extra):
    """Rewrites the configuration and waits for the daemon's "reloaded" line."""
    before = log_text(daemon).count("reloaded:")
    e2e.write_config(ws, [bus], devices, extra=extra)
    daemon.proc.send_signal(signal.SIGHUP)
    end = time.time() + 10
    while time.time() < end and log_text(daemon).count("reloaded:") == before:
        time.sleep(0.1)
    return log_text(daemon).count("reloaded:") > before


def writes_off_phase(report, args, ws):
    """Default configuration: read-only for everyone, root and the write group too."""
    rc, doc, out = cli(args, ws, [], *WRITE)
    report.check(refused(rc, doc) and "writes_enabled = false" in doc["error"].get("message", ""),
                 "writes_enabled = false (the default): root's SDO write refused, exit 4, permission_denied", out)
    rc, doc, out = cli(args, ws, as_user("cbt-member"), *WRITE)
    report.check(refused(rc, doc), "writes_enabled = false: a write group member's SDO write refused, exit 4", out)
    rc, doc, out = cli(args, ws, as_user("cbt-reader"), *READ)
    report.check(rc == 0 and doc.get("via") == "daemon" and doc.get("hex") == "D2070000",
                 "writes_enabled = false: reads still answered (cbt-reader, serial 2002)", out)
    rc, doc, out = cli(args, ws, [], "commission", "--json")
    report.check(refused(rc, doc) and "writes_enabled = false" in doc["error"].get("message", ""),
                 "writes_enabled = false: root's `commission` (node-IDs reassigned) refused, exit 4",
                 out)


def reader_phase(report, args, ws, daemon):
    reader = as_user("cbt-reader")
    rc, doc, out = cli(args, ws, reader, "status", "--json")
    report.check(rc == 0 and len(doc.get("buses", [])) == 1, "a reader in the socket's group gets the status", out[:120])
    rc, doc, out = cli(args, ws, reader, *READ)
    report.check(rc == 0 and doc.get("via") == "daemon" and doc.get("hex") == "D2070000",
                 "a reader in the socket's group reads an SDO through the daemon", out)
    rc, doc, out = cli(args, ws, reader, *WRITE)
    msg = doc.get("error", {}).get("message", "")
    report.check(refused(rc, doc) and 'uid 64102 is not in the write group "cbt-admin"' in msg,
                 "the reader's SDO write refused: exit 4, permission_denied naming its uid and the write group", out)
    rc, doc, out = cli(args, ws, reader, "nmt", "-i", "vcan0", "stop", "20", "--json")
    report.check(refused(rc, doc), "the reader's NMT stop refused, exit 4", out)
    report.check(daemon.devices()["mt-a"]["state"] == "operational", "the refused NMT stop did not reach the device")
    rc, line = raw(ws, reader, "sdo-write vcan0 20 1017 0 6400")
    try:
        doc = json.loads(line)
    except ValueError:
        doc = {}
    report.check(rc == 0 and doc.get("ok") is False and doc.get("error", {}).get("code") == "permission_denied",
                 "a raw control-socket client of the reader: sdo-write answered permission_denied", line)
    rc, doc, out = cli(args, ws, reader, "commission", "--bus", "line1", "--json")
    report.check(refused(rc, doc) and 'uid 64102 is not in the write group "cbt-admin"' in
                 doc.get("error", {}).get("message", ""),
                 "the reader's `commission` refused like its other writes, exit 4", out)
    text = log_text(daemon)
    report.check("refused to uid 64102 pid" in text, "every refused write logged with the caller's uid")
    report.check("commission of bus 'line1' refused to uid 64102 pid" in text,
                 "the refused commission logged with the caller's uid")


def writer_phase(report, args, ws, daemon):
    cases = [("cbt-primary", as_user("cbt-primary"), 64103, "in the write group as its primary group"),
             ("cbt-member", as_user("cbt-member"), 64104, "in the write group as a supplementary group"),
             ("cbt-reader", as_user("cbt-reader", ["cbt-svc", "cbt-admin"]), 64102,
              "given the write group by its process only (setpriv --groups, as SupplementaryGroups=)"),
             ("cbt-svc", as_user("cbt-svc"), 64100, "the daemon's own user (not in the write group)"),
             ("root", [], 0, "root")]
    for name, prefix, uid, why in cases:
        before = log_text(daemon).count("by uid %d pid" % uid)
        rc, doc, out = cli(args, ws, prefix, *WRITE)
        logged = log_text(daemon).count("by uid %d pid" % uid) > before
        report.check(rc == 0 and doc.get("via") == "daemon" and logged,
                     "%s, %s: SDO write done through the daemon, logged with uid %d" % (name, why, uid), out)
    rc, doc, out = cli(args, ws, as_user("cbt-member"), "nmt", "-i", "vcan0", "start", "20", "--json")
    report.check(rc == 0 and "control socket: NMT on bus vcan0 node 20 by uid 64104 pid" in log_text(daemon),
                 "a write group member's NMT start done and logged with its uid", out)
    rc, doc, out = cli(args, ws, as_user("cbt-member"), "commission", "--bus", "line1", "--json")
    report.check(rc == 0 and "control socket: commission of bus 'line1' by uid 64104 pid" in log_text(daemon),
                 "a write group member's `commission` done and logged with its uid", out)
    rc, doc, out = cli(args, ws, as_user("cbt-member", ["cbt-svc"]), *WRITE)
    report.check(refused(rc, doc),
                 "cbt-member with the write group dropped from its process (the database still lists it): refused",
                 out)
    rc, line = raw(ws, as_user("cbt-member"), "nmt vcan0 start 20")
    report.check(rc == 0 and '"ok":true' in line.replace(" ", ""), "a raw control-socket client of a member: NMT done",
                 line)


def outsider_phase(report, args, ws, listener):
    outsider = as_user("cbt-outsider")
    rc, doc, out = cli(args, ws, outsider, "status")
    report.check(rc == 4 and "Permission denied" in out and "mode 0660" in out,
                 "a user outside the socket's group: `status` exit 4, says the socket is the service's", out)
    # The member's `commission` before this phase makes the daemon's own LSS
    # and SDO traffic: the window below opens once that has ended.
    daemon_quiet = listener.wait_quiet(lambda i, d: i in (0x614, 0x7E5), quiet=1.0, timeout=20)
    report.check(daemon_quiet is not None, "the daemon's own commissioning traffic ended before the outsider's phase")
    since = time.time()
    rc, doc, out = cli(args, ws, outsider, *READ)
    report.check(refused(rc, doc) and "Permission denied" in doc["error"].get("message", ""),
                 "the outsider's SDO read: exit 4, permission_denied, no direct access", out)
    rc, doc, out = cli(args, ws, outsider, "scan", "-i", "vcan0", "--json")
    report.check(refused(rc, doc), "the outsider's scan: exit 4 (no second master's probe of the daemon's bus)", out)
    time.sleep(0.3)
    sdo = [f for f in listener.snapshot(since) if f[1] == 0x614 or f[1] == 0x7E5]
    report.check(not sdo, "no SDO or LSS request of the outsider on the bus", "%d frames" % len(sdo))
    rc, line = raw(ws, outsider, "status")
    report.check(rc == 3 and "Permission denied" in line, "a raw client of the outsider cannot connect", line)


ASCII_CLIENT = r"""
import socket, sys
kind, where, line = sys.argv[1], sys.argv[2], sys.argv[3]
if kind == "unix":
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(10)
    s.connect(where)
else:
    s = socket.create_connection(("127.0.0.1", int(where)), timeout=10)
print("local %s" % (s.getsockname()[1] if kind == "tcp" else "-"))
s.sendall((line + "\r\n").encode())
data = b""
while not data.endswith(b"\r\n"):  # as cocomm: the answer ends with CR LF
    chunk = s.recv(1)
    if not chunk:
        break
    data += chunk
print(data.decode().strip())
"""

ASCII_TCP_PORT = 5309


def ascii_socket(ws):
    """Beside the control socket: a directory the service's user owns."""
    return os.path.join(os.path.dirname(ws.control), "ascii.sock")


def ascii_request(ws, prefix, kind, line):
    """One CiA 309-3 request as `prefix`'s user: (client's local port, answer)."""
    where = ascii_socket(ws) if kind == "unix" else str(ASCII_TCP_PORT)
    r = subprocess.run(prefix + ["/usr/bin/python3", "-c", ASCII_CLIENT, kind, where, line], capture_output=True,
                       text=True, timeout=30)
    lines = r.stdout.strip().splitlines()
    return (lines[0].split()[1] if lines else "?"), (lines[1] if len(lines) > 1 else r.stderr.strip())


def ascii_phase(report, args, ws, bus, devices):
    """The 309-3 gateway's writes have their own allow list
    (write_allow, TCP) and group (write_group, Unix socket), as the control
    socket has; a refusal answers ERROR: 100 and is logged with the caller."""
    extra = ('[ascii_gateway]\nsocket = %s\ntcp_port = %d\nwrites_enabled = true\nwrite_group = "cbt-admin"\n'
             'write_allow = ["10.0.0.0/8"]\n' % (e2e.toml_value(ascii_socket(ws)), ASCII_TCP_PORT))
    config = e2e.write_config(ws, [bus], devices, extra=extra)
    daemon = e2e.Daemon(args.daemon, config, ws, run_as=as_user("cbt-svc"), log_name="daemon-ascii.log")
    try:
        _, took = daemon.wait_until(e2e.all_operational(["rot-a", "mt-a"]), 60, interval=0.1)
        report.check(took is not None, "309-3 phase: daemon with [ascii_gateway] up, devices operational")
        write = "[1] 20 w 0x1017 0 u16 100"
        _, answer = ascii_request(ws, as_user("cbt-reader"), "unix", write)
        report.check(answer == "[1] ERROR: 100", "309-3 Unix socket: cbt-reader (not in write_group) may not write",
                     answer)
        _, answer = ascii_request(ws, as_user("cbt-reader"), "unix", "[2] 20 r 0x1018 4 u32")
        report.check(answer == "[2] 2002", "309-3 Unix socket: cbt-reader still reads", answer)
        _, answer = ascii_request(ws, as_user("cbt-member"), "unix", write)
        report.check(answer == "[1] OK", "309-3 Unix socket: cbt-member (write_group) writes", answer)
        port, answer = ascii_request(ws, [], "tcp", write)
        report.check(answer == "[1] ERROR: 100", "309-3 TCP: a client outside write_allow (127.0.0.1) may not write",
                     answer)
        _, answer = ascii_request(ws, [], "tcp", "[3] 20 r 0x1018 4 u32")
        report.check(answer == "[3] 2002", "309-3 TCP: the same client still reads", answer)
        text = log_text(daemon)
        report.check("refused to uid 64102 pid" in text and "not in write_group" in text,
                     "the refused Unix-socket write logged with the caller's uid")
        report.check("by uid 64104 pid" in text, "the allowed write logged with the member's uid")
        report.check(("refused to tcp 127.0.0.1:%s" % port) in text and "not in write_allow" in text,
                     "the refused TCP write logged with the client's address and port", port)
        e2e.check_clean_exit(report, daemon, "309-3 phase: SIGTERM -> exit 0 within 1 s")
        daemon = None
    finally:
        if daemon is not None:
            daemon.stop()


def main():
    args = e2e.parse_args()
    args.daemon, args.cli = os.path.abspath(args.daemon), os.path.abspath(args.cli)  # run through setpriv
    report = e2e.Report("test_write_access")
    if not in_can_bed_guest():
        print("FAIL: this test bind-mounts /etc/passwd and /etc/group: run it in a CAN bed guest (tests/vcan/run-in-vcan)")
        return 1
    ws = e2e.Workspace("write-access", args.keep)
    mounted = install_identities(ws)
    svc_uid, svc_gid = USERS["cbt-svc"][0], GROUPS["cbt-svc"][0]
    report.check(pwd.getpwnam("cbt-member").pw_uid == 64104 and "cbt-member" in grp.getgrnam("cbt-admin").gr_mem,
                 "test users and groups visible (inside the guest only)")
    # The service's directories, as systemd's StateDirectory= / RuntimeDirectory= make them.
    for d in (ws.dir, ws.run):
        os.chmod(d, 0o755)
    os.makedirs(ws.state)
    os.makedirs(os.path.dirname(ws.control))
    for d in (ws.state, os.path.dirname(ws.control)):
        os.chown(d, svc_uid, svc_gid)
        os.chmod(d, 0o755)
    listener = e2e.CanListener("vcan0")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["RFC-4800:serial=1001,node=10", "MC1-2800:serial=2002,node=20"]})
    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30}
    devices = [{"name": "rot-a", "bus": "line1", "serial": 1001, "model": "RFC-4800", "node_id": 10,
                "heartbeat_ms": 100},
               {"name": "mt-a", "bus": "line1", "serial": 2002, "model": "MC1-2800", "node_id": 20,
                "heartbeat_ms": 100}]
    config = e2e.write_config(ws, [bus], devices)
    daemon = e2e.Daemon(args.daemon, config, ws, run_as=as_user("cbt-svc"))
    try:
        if not report.check(daemon.wait_socket(), "control socket up (daemon running as cbt-svc)"):
            print(daemon.tail(40))
            return report.finish()
        st = os.stat(ws.control)
        report.check(stat.S_IMODE(st.st_mode) == 0o660 and st.st_uid == svc_uid and st.st_gid == svc_gid,
                     "the socket: mode 0660, owner cbt-svc, group cbt-svc",
                     "%o %d:%d" % (stat.S_IMODE(st.st_mode), st.st_uid, st.st_gid))
        _, took = daemon.wait_until(e2e.all_operational(["rot-a", "mt-a"]), 60, interval=0.1)
        if not report.check(took is not None, "two devices operational", "%.2f s" % took if took else ""):
            print(daemon.tail(60))
        writes_off_phase(report, args, ws)
        on = '[control]\nwrites_enabled = true\nwrite_group = "cbt-admin"\n'
        report.check(reload(daemon, ws, bus, devices, on), "SIGHUP: writes_enabled = true, write_group = cbt-admin")
        reader_phase(report, args, ws, daemon)
        writer_phase(report, args, ws, daemon)
        outsider_phase(report, args, ws, listener)
        report.check(reload(daemon, ws, bus, devices, '[control]\nwrite_group = "cbt-admin"\n'),
                     "SIGHUP: writes_enabled back to its default (false)")
        rc, doc, out = cli(args, ws, [], *WRITE)
        report.check(refused(rc, doc), "after the reload root's write is refused again", out)
        rc, doc, out = cli(args, ws, as_user("cbt-svc"), *WRITE)
        report.check(refused(rc, doc), "and the daemon's own user's", out)
        if report.failed:
            print(daemon.tail(80))
        e2e.check_clean_exit(report, daemon)
        daemon = None
        ascii_phase(report, args, ws, bus, devices)
    finally:
        e2e.shut_down(ws, daemon, sim, listener)
        for m in mounted:
            subprocess.run(["umount", m])
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
