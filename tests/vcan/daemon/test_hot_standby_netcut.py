"""Hot standby with the Ethernet between the two gateways cut
(docs/operations.md "Hot standby"; CiA 302-2 flying master decided on the
bus): the two gateways run in their own network namespaces, as on two PCs.
Their "Ethernet" is a veth pair (DDS and Modbus run over it); their CAN is
one bus: each has a vxcan end, joined with the simulator's by can-gw rules
(a full mesh, one hop per frame).

Checks, from every frame on the bus and the daemons' status:
  * before the cut: a is master, b standby, and b reaches a over the veth;
  * the veth cut (one end down): b no longer reaches a, and for 3 s the bus
    still has exactly one master (only a's heartbeat says 05h) and both
    daemons keep their roles;
  * a killed while the link is cut: b's first heartbeat saying master (05h)
    is on the bus within 1 s of a's last frame (both from the traces: a's
    own frames from candump -x in its namespace, b's heartbeat from the
    simulator's end), and a started again (still cut) joins as standby:
    one master;
  * the link back: still one master, no election;
  * every frame attributed to its sender (candump -x inside each namespace
    marks that namespace's own frames TX): while standby, each gateway sent
    nothing but its heartbeat and the election's frames.
Runs inside UML:
  tests/vcan/run-in-vcan -- /usr/bin/python3 tests/vcan/daemon/test_hot_standby_netcut.py --daemon ...
"""
import os
import signal
import subprocess
import time

import bus_trace
import e2e
from e2e import sh

DEVICES = [("rot-a", "RFC-4800", "RFC-4800", 1001, 10), ("mt-a", "MC1-2800", "MC1-2800", 2001, 20)]
NAMES = [d[0] for d in DEVICES]
NODE = {"a": 120, "b": 121}
NS = {"a": "gwa", "b": "gwb"}
CAN = {"a": "vxa1", "b": "vxb1"}  # each gateway's end, inside its namespace
IP = {"a": "10.9.0.1", "b": "10.9.0.2"}
VETH = {"a": "vea", "b": "veb"}
SIM_CAN = "vxs1"
HB = 0x700


def setup_network():
    """Namespaces gwa and gwb, a vxcan end each and one for the simulator, can-gw
    joining the root ends into one bus, and a veth pair between the namespaces."""
    # vxcan, can-gw and veth: loaded by tests/vcan/run-in-vcan on either bed.
    ends = {"a": "vxa0", "b": "vxb0", "s": "vxs0"}
    for k in NS:
        sh("ip", "netns", "add", NS[k])
        sh("ip", "-n", NS[k], "link", "set", "lo", "up")
        sh("ip", "link", "add", ends[k], "type", "vxcan", "peer", "name", CAN[k], "netns", NS[k])
        sh("ip", "-n", NS[k], "link", "set", CAN[k], "up")
    sh("ip", "link", "add", ends["s"], "type", "vxcan", "peer", "name", SIM_CAN)
    sh("ip", "link", "set", SIM_CAN, "up")
    for e in ends.values():
        sh("ip", "link", "set", e, "up")
    for src in ends.values():
        for dst in ends.values():
            if src != dst:
                sh("cangw", "-A", "-s", src, "-d", dst, "-e")
    sh("ip", "link", "add", VETH["a"], "netns", NS["a"], "type", "veth", "peer", "name", VETH["b"], "netns", NS["b"])
    for k in NS:
        sh("ip", "-n", NS[k], "addr", "add", IP[k] + "/24", "dev", VETH[k])
        sh("ip", "-n", NS[k], "link", "set", VETH[k], "up")


def reaches(src, dst_ip, port):
    """True when a TCP connection from namespace NS[src] to dst_ip:port opens."""
    code = ("import socket,sys\ns=socket.socket();s.settimeout(1)\n"
            "try:\n s.connect((%r,%d));print('up')\nexcept OSError:\n print('down')\n" % (dst_ip, port))
    r = subprocess.run(["ip", "netns", "exec", NS[src], "/usr/bin/python3", "-c", code], capture_output=True, text=True)
    return r.stdout.strip() == "up"


def only_standby_frames(sent, k):
    """The frames of `sent` a standby may send: its heartbeat and the election's (0x71..0x76)."""
    return [hex(i) for _, i, _ in sent if i != HB + NODE[k] and not 0x71 <= i <= 0x76]


def config(ws, k):
    bus = {"name": "line1", "interface": CAN[k], "bitrate": 250, "discovery_period_s": 3600}
    devices = [{"name": n, "bus": "line1", "serial": s, "model": m, "node_id": nid, "heartbeat_ms": 100}
               for (n, m, _, s, nid) in DEVICES]
    extra = ('[redundancy]\nmode = "hot-standby"\nnode_id = %d\n'
             '[outputs.modbus]\nbind = "%s"\nport = 1502\n' % (NODE[k], IP[k]))
    return e2e.write_config(ws, [bus], devices, extra=extra)


def role(daemon):
    try:
        r = daemon.status()["buses"][0].get("redundancy")
        return (r["role"], r["master_node"]) if r else None
    except (OSError, ValueError, KeyError):
        return None


def wait_role(daemon, want, timeout=10):
    end = time.time() + timeout
    while time.time() < end:
        if role(daemon) == want:
            return True
        time.sleep(0.02)
    return False


def masters(frames, t0, t1):
    """Gateways whose heartbeat said master (05h) between t0 and t1."""
    return {k for t, cid, d in frames for k in NODE if t0 <= t <= t1 and cid == HB + NODE[k] and d[:1] == b"\x05"}


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_hot_standby_netcut")
    setup_network()
    ws = {k: e2e.Workspace("netcut-" + k, args.keep, base="/run") for k in NS}
    cfg = {k: config(ws[k], k) for k in NS}
    listener = e2e.CanListener(SIM_CAN)
    sim = e2e.Simulator(args.sim, ws["a"], {SIM_CAN: ["%s:serial=%d,node=%d" % (sm, s, n)
                                                     for (_, _, sm, s, n) in DEVICES]})
    daemons = {}
    # candump -x inside each namespace: the frames that namespace sent are marked TX, so every
    # frame on the bus is attributed to its sender.
    sent_by = {k: bus_trace.Candump(CAN[k], ws[k].path("sent.log"), netns=NS[k]) for k in NS}

    def start(k, n):
        extra = ["--plugin-dir", args.plugins] if args.plugins else []
        daemons[k] = e2e.Daemon(args.daemon, cfg[k], ws[k], log_name="daemon-%d.log" % n, extra_args=extra,
                                run_as=("ip", "netns", "exec", NS[k]))
        return daemons[k]

    try:
        a = start("a", 1)
        report.check(a.wait_socket() and wait_role(a, ("master", NODE["a"])), "gateway a (namespace gwa): master")
        _, ok = a.wait_until(e2e.all_operational(NAMES), 30, interval=0.05)
        report.check(ok is not None, "gateway a: every device operational over the vxcan/can-gw bus")
        b = start("b", 1)
        report.check(b.wait_socket() and wait_role(b, ("standby", NODE["a"])), "gateway b (namespace gwb): standby")
        report.check(reaches("b", IP["a"], 1502), "before the cut: b reaches a over their Ethernet (veth)")

        sh("ip", "-n", NS["a"], "link", "set", VETH["a"], "down")
        t_cut = time.time()
        report.check(not reaches("b", IP["a"], 1502), "the Ethernet is cut: b no longer reaches a")
        time.sleep(3.0)  # three seconds cut observed: a window, not a wait
        t_end = time.time()
        seen = masters(listener.snapshot(t_cut), t_cut, t_end)
        report.check(seen == {"a"}, "cut for 3 s: exactly one master on the bus (only a's heartbeat says 05h)",
                     str(seen))
        report.check(role(a) == ("master", NODE["a"]) and role(b) == ("standby", NODE["a"]),
                     "cut: both keep their roles", "%s %s" % (role(a), role(b)))

        os.kill(a.pid, signal.SIGKILL)
        a.proc.wait(5)
        a.log.close()
        t_kill = time.time()
        report.check(wait_role(b, ("master", NODE["b"]), 5), "cut, a killed: b is master")
        listener.wait_for(bus_trace.master_heartbeat(NODE["b"]), 5, since=t_kill)
        sent_by["a"].wait_past(t_kill)
        took = bus_trace.takeover(sent_by["a"].sent(0, t_kill), listener.snapshot(t_kill - 5.0), NODE["b"])
        print("FIGURE takeover with the Ethernet cut: %s from a's last frame to b's first 05h heartbeat" % (
            "%.3f s" % took if took is not None else "none"))
        report.check(took is not None and took <= 1.0,
                     "cut: b took over within 1 s of a's last frame (bus traces: a's last frame to b's first 05h "
                     "heartbeat)", "%s s" % took)
        t_a_back = time.time()
        a = start("a", 2)
        report.check(a.wait_socket() and wait_role(a, ("standby", NODE["b"])),
                     "cut: a started again asks on the bus and joins as standby", str(role(a)))
        _, ok = b.wait_until(e2e.all_operational(NAMES), 20, interval=0.05)
        report.check(ok is not None, "cut: every device operational under b")

        sh("ip", "-n", NS["a"], "link", "set", VETH["a"], "up")
        t_up = time.time()
        time.sleep(2.0)  # two seconds of the link back observed: a window, not a wait
        seen = masters(listener.snapshot(t_up), t_up, time.time())
        report.check(seen == {"b"} and role(a) == ("standby", NODE["b"]),
                     "the Ethernet back: still one master (b), no election", "%s %s" % (seen, role(a)))
        whole = masters(listener.snapshot(t_cut), t_cut, t_kill)
        report.check(whole == {"a"}, "from the cut to the kill, never a second master", str(whole))
        # Every frame attributed to its sender (candump -x in each namespace): while standby, a gateway
        # sent only its heartbeat and election frames: no NMT, SDO, LSS, SYNC or guarding.
        # b was standby until it claimed the role (its first 0x71 after the kill, from its own trace;
        # the role is master 50 ms later, its first SDO and NMT a few microseconds before its 05h).
        t_b_claim = min(t for t, cid, d in sent_by["b"].sent(t_kill) if cid == 0x71)
        b_sent = sent_by["b"].sent(0, t_b_claim)
        a_sent = sent_by["a"].sent(t_a_back, time.time())
        report.check(b_sent and not only_standby_frames(b_sent, "b"),
                     "b, standby until the kill, sent only its heartbeat and election frames (%d frames)" % len(
                         b_sent), str(only_standby_frames(b_sent, "b")[:8]))
        report.check(a_sent and not only_standby_frames(a_sent, "a"),
                     "a, standby after its return, sent only its heartbeat and election frames (%d frames)" % len(
                         a_sent), str(only_standby_frames(a_sent, "a")[:8]))
        a_master_sent = [i for _, i, _ in sent_by["a"].sent(0, t_kill) if 0x600 < i < 0x680 or i == 0x000]
        report.check(a_master_sent, "the attribution sees the master's own commands (a's SDO/NMT before the kill)",
                     "%d" % len(a_master_sent))
    finally:
        e2e.shut_down_pair(daemons.values(), [sim, listener] + list(sent_by.values()), ws.values())
    return report.finish()


if __name__ == "__main__":
    raise SystemExit(main())
