"""`cobridge scan` on a bus no daemon serves: the CLI is the master.

Scenario (UML, real SocketCAN, cobridge-sim): two configured encoders (an
RFC-4800 at node 10, an RM9000 at node 30) and one MC1-2800 at FFh
(non-configured, CiA 305).
Checks:
* the SDO probe (CiA 301 §7.2.4, 0x1018:1..4) lists nodes 10 and 30 with the
  identity the simulator holds for them (its `list` answer and truth);
* CiA 305 Fastscan finds the non-configured device, with its serial;
* `--assign-from 40` gives it node-ID 40 and stores it (CiA 305 configure
  node-ID 0x11, store configuration 0x17): the simulator shows the device at
  node 40, and a second scan lists it there by SDO, no longer by Fastscan.
"""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
import e2e  # noqa: E402

DEVICES = ["RFC-4800:serial=1001,node=10", "RM9000:serial=3001,node=30",
           "MC1-2800:serial=2042,node=unconfigured,lss=v3"]


def sim_nodes(sim):
    """serial -> node as the simulator holds it (`list`: serial:model:iface:node:state)."""
    nodes = {}
    for item in sim.command("list").split()[2:]:
        serial, _, _, node, _ = item.split(":", 4)
        nodes[int(serial, 0)] = node
    return nodes


def scan(args, *extra):
    rc, out, err = e2e.run_cli(args.cli, "scan", "-i", "vcan0", "--json", *extra, timeout=120)
    try:
        rows = json.loads(out)
    except ValueError:
        rows = None
    return rc, rows, out.strip()[:300] + err.strip()[:300]


def main():
    args = e2e.parse_args()
    report = e2e.Report("test_scan_direct")
    ws = e2e.Workspace("scan-direct", keep=args.keep)
    sim = e2e.Simulator(args.sim, ws, {"vcan0": DEVICES})
    try:
        before = sim_nodes(sim)
        report.check(before.get(2042) in ("255", "FF", "unconfigured", "-"), "the MC1-2800 starts non-configured",
                     str(before))
        rc, rows, text = scan(args)
        by_node = {r["node"]: r for r in rows or [] if r.get("node") is not None}
        report.check(rc == 0 and set(by_node) == {10, 30}, "SDO probe lists nodes 10 and 30", text)
        report.check(by_node.get(10, {}).get("serial") == [1001] and by_node.get(10, {}).get("vendor") == [0x182],
                     "node 10: 0x1018 vendor 0x182, serial 1001 (the simulator's)", str(by_node.get(10)))
        report.check(by_node.get(30, {}).get("serial") == [3001] and by_node.get(30, {}).get("vendor") == [0x69666D],
                     "node 30: 0x1018 vendor 0x69666D ('ifm'), serial 3001 (the simulator's)", str(by_node.get(30)))
        lss = [r for r in rows or [] if r.get("seen") == "fastscan"]
        report.check(len(lss) == 1 and lss[0]["serial"] == [2042], "Fastscan finds the non-configured device",
                     str(lss))

        rc, rows, text = scan(args, "--assign-from", "40")
        lss = [r for r in rows or [] if r.get("seen") == "fastscan"]
        report.check(rc == 0 and len(lss) == 1 and lss[0].get("assigned") == 40,
                     "--assign-from 40: node-ID 40 assigned and stored", text)
        after = sim_nodes(sim)
        report.check(after.get(2042) == "40", "the simulator holds the device at node 40", str(after))

        rc, rows, text = scan(args)
        by_node = {r["node"]: r for r in rows or [] if r.get("node") is not None}
        report.check(rc == 0 and by_node.get(40, {}).get("serial") == [2042]
                     and not [r for r in rows or [] if r.get("seen") == "fastscan"],
                     "a second scan lists it at node 40 by SDO, none left for Fastscan", text)
    finally:
        sim.stop()
        ws.cleanup()
    return report.finish()


if __name__ == "__main__":
    sys.exit(main())
