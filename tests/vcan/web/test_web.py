#!/usr/bin/python3
"""The web service end to end, inside UML (tests/vcan/run-in-vcan): cobridge-sim with
three encoders (one per family, TPDO1 every 10 ms, --truth) -> cobridged with
[web] on UML's loopback -> HTTP clients.

Checks (docs/web.md):
* /api/v1/status is the document `cobridge status --json` prints (same keys,
  same devices) and /metrics says what it says;
* values move, and the position the API shows is one the simulator sent
  (truth file);
* an injected EMCY (simulator `fault <serial> hardware-fault`) shows in the
  EMCY history with the family's text, and in cobridge_device_emcy_total;
* a power cycle shows as a boot-up (boot_ups, metrics), the device back
  operational;
* a silenced device is stale in the JSON and cobridge_value_stale 1;
* each output's own figures: a Modbus client that connects shows as
  modbus_clients_connected 1 in the JSON and /metrics, and 0 once it left;
* bad requests get 4xx and change nothing;
* 50 clients hammering /metrics: no frame or sample lost (kernel and ring
  drops stay 0) and every TPDO the simulator sent reached the hot path;
  prints FIGURE lines: request latency p50/p99 of 200 requests, RSS added.
With --browser (as CI runs it: the API checks and the page share one boot):
after the checks above, one headless Chromium (DevTools protocol on a pipe)
loads the page and its DOM is checked
(every device listed, values changing, a sparkline of positions drawn for
each moving device, the Modbus output listed, the silenced device marked stale);
screenshots are saved with --screenshot-dir.
"""
import http.client
import glob
import json
import os
import re
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
import e2e  # noqa: E402
from headless_page import BrowserCrashed, BrowserError, HeadlessPage  # noqa: E402

PORT = 18080
MODBUS_PORT = 15020
DEVICES = [  # name, model, sim model, serial, node, motion
    ("rot-a", "RFC-4800", "RFC-4800", 1001, 10, "constant:0.3"),
    ("mt-a", "MC1-2800", "MC1-2800", 2001, 20, "constant:0.2"),
    ("ifm-a", "RM9", "RM9000", 3001, 30, "constant:0.5"),
]


def get(path, method="GET", body=None, headers=None):
    c = http.client.HTTPConnection("127.0.0.1", PORT, timeout=5)
    c.request(method, path, body=body, headers=headers or {})
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, dict(r.getheaders()), data


def status():
    code, _, data = get("/api/v1/status")
    return json.loads(data) if code == 200 else None


def metrics():
    _, _, data = get("/metrics")
    out = {}
    for line in data.decode().splitlines():
        if line.startswith("#") or not line:
            continue
        name, value = line.rsplit(" ", 1)
        out[name] = float(value)
    return out


def metric(m, metric_name, **labels):
    for k, v in m.items():
        if not k.startswith(metric_name + "{") and k != metric_name:
            continue
        if all('%s="%s"' % (lk, lv) in k for lk, lv in labels.items()):
            return v
    return None


def devices(st):
    return {d["name"]: d for b in st["buses"] for d in b["devices"]}


def merge(a, b):
    """Two shapes as one: the union of their keys (a null takes the other's)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return {k: merge(a.get(k), b.get(k)) for k in a.keys() | b.keys()}
    return a if b is None else b


def keys(x):
    """The shape of a JSON document: its keys, recursively (values ignored).
    A list's shape is that of all its items merged: a step carries its LSS
    counts only when it made exchanges, so the first item alone would make
    the shape depend on which step came last."""
    if isinstance(x, dict):
        return {k: keys(v) for k, v in x.items() if k not in ("values", "heartbeat_age_s")}
    if isinstance(x, list):
        shape = None
        for item in x:
            shape = merge(shape, keys(item))
        return [shape] if x else []
    return None


def same_shape(cli, control):
    """/api/v1/status against `cobridge status --json`, a few times: the two
    are read one after the other, and a device may change in between (a
    periodic discovery step, an EMCY). Returns (same, what differed, the
    status document, the CLI's document) of the last reading."""
    diff, st, cli_doc = "no document", None, None
    for _ in range(3):
        r = subprocess.run([cli, "status", "--json", "--control", control], stdout=subprocess.PIPE, text=True,
                           timeout=10)
        st = status()
        cli_doc = json.loads(r.stdout) if r.returncode == 0 else None
        if st is None or cli_doc is None:
            continue
        a, b = keys(st), keys(cli_doc)
        if a == b:
            return True, "", st, cli_doc
        diff = "HTTP %s | CLI %s" % (json.dumps(a, sort_keys=True), json.dumps(b, sort_keys=True))
        time.sleep(0.2)
    return False, diff, st, cli_doc


def rss_kib(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def percentile(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100.0 * (len(xs) - 1))))]


def main():
    import argparse
    p = argparse.ArgumentParser()
    p.add_argument("--daemon", required=True)
    p.add_argument("--cli", required=True)
    p.add_argument("--sim", required=True)
    p.add_argument("--browser", action="store_true")
    p.add_argument("--screenshot-dir")
    p.add_argument("--keep", action="store_true")
    args = p.parse_args()
    report = e2e.Report("test_web" + (" (browser)" if args.browser else ""))
    ws = e2e.Workspace("web", args.keep)
    truth = ws.path("truth.txt")
    sim = e2e.Simulator(args.sim, ws, {"vcan0": ["%s:serial=%d,node=%d%s,motion=%s" % (
        sm, s, n, ",bitrate=250" if sm.startswith("RM") else "", mo) for (_, _, sm, s, n, mo) in DEVICES]},
        extra_args=("--truth", truth))

    bus = {"name": "line1", "interface": "vcan0", "bitrate": 250, "discovery_period_s": 30, "node_pool": "40-60"}
    devs = [{"name": name, "bus": "line1", "serial": s, "model": m, "node_id": n, "heartbeat_ms": 100,
             "tpdo1": {"mapping": ["position", "speed"] if not m.startswith("RM") else ["position"],
                       "transmission": "event", "event_timer_ms": 10}}
            for (name, m, _, s, n, _) in DEVICES]
    config = e2e.write_config(ws, [bus], devs, extra="[web]\nport = %d\n\n[outputs.modbus]\nbind = \"127.0.0.1\"\n"
                              "port = %d\n" % (PORT, MODBUS_PORT))
    daemon = e2e.Daemon(args.daemon, config, ws)
    shown = {}
    names = [d[0] for d in DEVICES]
    try:
        report.check(daemon.wait_socket(), "control socket up")
        _, took = daemon.wait_until(e2e.all_operational(names), 60, interval=0.1)
        report.check(took is not None, "three devices operational", "%.2f s" % took if took else daemon.tail(40))
        time.sleep(0.5)
        print("FIGURE daemon RSS before any HTTP request: %d KiB" % rss_kib(daemon.pid), flush=True)

        # ---- one schema, one source
        same, diff, st, cli_doc = same_shape(args.cli, ws.control)
        report.check(same, "/api/v1/status has the keys of `cobridge status --json`", diff)
        report.check(st is not None and cli_doc is not None and
                     [(d["name"], d["node_id"], d["state"]) for b in st["buses"] for d in b["devices"]] ==
                     [(d["name"], d["node_id"], d["state"]) for b in cli_doc["buses"] for d in b["devices"]],
                     "same devices, node-IDs and states in both")
        code, hdr, _ = get("/")
        report.check(code == 200 and "text/html" in hdr.get("Content-Type", ""), "/ serves the page")

        # ---- values move and come from the devices
        # shown: node -> (name, position), checked against the truth file once the simulator stopped
        st1 = devices(status())
        time.sleep(1.0)
        st2 = devices(status())
        for (name, _, _, serial, node, _) in DEVICES:
            a, b = st1[name].get("values"), st2[name].get("values")
            ok = a and b and a.get("position") != b.get("position") and b["age_s"] < 0.5 and not b["stale"]
            report.check(bool(ok), "%s: position moves, fresh, not stale" % name,
                         "%s -> %s, %s" % (a and a.get("position"), b and b.get("position"), json.dumps(b)))
            shown[node] = (name, b and b.get("position"))
        m = metrics()
        for (name, _, _, _, node, _) in DEVICES:
            report.check(metric(m, "cobridge_device_up", name=name, node=str(node)) == 1.0, "%s: cobridge_device_up 1" % name)
            age = metric(m, "cobridge_value_age_seconds", name=name)
            report.check(age is not None and age < 0.5, "%s: cobridge_value_age_seconds < 0.5" % name, str(age))
        report.check((metric(m, "cobridge_frames_received_total", bus="line1", socket="hot_path") or 0) > 100,
                     "cobridge_frames_received_total{bus=line1,socket=hot_path} counts")

        # ---- each output's own figures (plugin ABI 3 stats)
        modbus_figures(report)

        # ---- EMCY
        name, serial = DEVICES[0][0], DEVICES[0][3]
        before = devices(status())[name]["emcy_count"]
        sim.command("fault %d hardware-fault" % serial)
        # The web service rebuilds its snapshot at most every 250 ms: poll it, not the control socket.
        web_hist = []
        t_end = time.time() + 5
        while time.time() < t_end:
            d = devices(status())[name]
            if d["emcy_count"] > before:
                web_hist = d["emcy_history"]
                break
            time.sleep(0.05)
        report.check(bool(web_hist) and web_hist[-1]["text"] != "" and bool(web_hist[-1]["at"]),
                     "%s: injected EMCY in the history with text and time" % name, json.dumps(web_hist[-1:]))
        report.check((metric(metrics(), "cobridge_device_emcy_total", name=name) or 0) > before,
                     "%s: cobridge_device_emcy_total counts it" % name)
        sim.command("fault %d clear" % serial)  # it measures again (the page must show it move)

        # ---- power cycle
        name, serial = DEVICES[1][0], DEVICES[1][3]
        boots = devices(status())[name]["boot_ups"]
        sim.command("power-cycle %d" % serial)
        ok = False
        t_end = time.time() + 10
        while time.time() < t_end:
            d = devices(status())[name]
            if d["boot_ups"] > boots and d["state"] == "operational":
                ok = True
                break
            time.sleep(0.1)
        report.check(ok, "%s: power cycle seen (boot_ups +1) and operational again" % name)
        report.check((metric(metrics(), "cobridge_device_boot_ups_total", name=name) or 0) > boots,
                     "%s: cobridge_device_boot_ups_total counts it" % name)
        # Offline during the power cycle made its values stale; flowing again, they are not.
        fresh = None
        t_end = time.time() + 5
        while time.time() < t_end:
            v = devices(status())[name].get("values") or {}
            fresh = v
            if v and not v["stale"] and v["age_s"] < 0.5:
                break
            time.sleep(0.1)
        report.check(bool(fresh) and not fresh["stale"], "%s: values fresh and not stale after the power cycle" % name,
                     json.dumps(fresh))
        report.check(metric(metrics(), "cobridge_value_stale", name=name) == 0,
                     "%s: cobridge_value_stale 0 after the power cycle" % name)

        # ---- the power cycle's flight recorder capture, listed in the status and served over HTTP
        cap = None
        end = time.time() + 8
        while time.time() < end and cap is None:
            st = status() or {"buses": []}
            caps = [c for b in st["buses"] for c in ((b.get("recorder") or {}).get("captures") or [])]
            cap = next((c for c in caps if "boot-up" in c["causes"]), None)
            time.sleep(0.2)
        report.check(cap is not None, "%s: the power cycle's capture is listed (recorder.captures)" % name, str(cap))
        if cap:
            code, headers, body = get("/api/v1/captures/" + cap["name"])
            lines = body.decode(errors="replace").splitlines()
            ok = code == 200 and len(lines) == cap["frames"] and all(
                re.match(r"^\(\d+\.\d{6}\) \S+ [0-9A-F]{3,8}#", l) for l in lines)
            report.check(ok, "the capture is served at /api/v1/captures/NAME as a candump -l log (%d lines)" % len(
                lines), "HTTP %s, %s" % (code, lines[:2]))
            code, _, _ = get("/api/v1/captures/..%2Fstate%2Fassignments.state")
            report.check(code in (400, 404), "a capture path outside the recorder's names is refused", str(code))

        # ---- heartbeat / TPDO arrival histograms; the whole text passes promtool
        _, _, text = get("/metrics")
        r = subprocess.run(["promtool", "check", "metrics"], input=text, capture_output=True)
        report.check(r.returncode == 0 and not r.stdout.strip() and not r.stderr.strip(),
                     "/metrics passes promtool check metrics (histograms included)",
                     (r.stdout + r.stderr).decode()[:300])
        m = metrics()
        count = metric(m, "cobridge_heartbeat_interval_seconds_count", name=name) or 0
        within = metric(m, "cobridge_heartbeat_interval_seconds_bucket", name=name, le="0.2") or 0
        report.check(count >= 5 and within >= 0.9 * count,
                     "%s: heartbeat intervals in cobridge_heartbeat_interval_seconds (100 ms producer: %d of %d "
                     "within 0.2 s)" % (name, within, count))
        report.check((metric(m, "cobridge_tpdo_interval_seconds_count", name=name) or 0) >= 5,
                     "%s: TPDO intervals in cobridge_tpdo_interval_seconds" % name)

        # ---- bad requests: 4xx, no effect
        before = status()
        bad = [get("/api/v1/status", "POST", body=b"commission"), get("/metrics", "DELETE"),
               get("/api/v1/commission"), get("/" + "a" * 400), get("/metrics", "PUT", body=b"x")]
        report.check(all(400 <= c < 500 for (c, _, _) in bad), "bad requests get 4xx", str([c for (c, _, _) in bad]))
        after = status()
        report.check([d["boot_ups"] for d in devices(before).values()] == [d["boot_ups"] for d in devices(after).values()]
                     and [d["configurations"] for d in devices(before).values()] ==
                     [d["configurations"] for d in devices(after).values()], "... and change nothing")

        # ---- latency and RSS (UML figures: one slow CPU)
        for path in ("/api/v1/status", "/metrics", "/"):
            lat = []
            c = http.client.HTTPConnection("127.0.0.1", PORT, timeout=5)
            for _ in range(200):
                t0 = time.perf_counter()
                c.request("GET", path)
                c.getresponse().read()
                lat.append((time.perf_counter() - t0) * 1000)
            c.close()
            print("FIGURE web latency %s: p50 %.2f ms, p99 %.2f ms (200 requests, keep-alive, UML)" % (
                path, percentile(lat, 50), percentile(lat, 99)), flush=True)
            report.check(percentile(lat, 99) <= 20 * 5, "%s p99 within 100 ms in UML" % path)

        # ---- 50 clients hammering /metrics: nothing lost
        def counters():
            b = status()["buses"][0]["counters"]
            return b

        def sent_tpdos():
            n = 0
            with open(truth) as f:
                for line in f:
                    fl = line.split()
                    if len(fl) >= 5 and fl[4] == "tpdo1":
                        n += 1
            return n

        c0 = counters()
        stop = threading.Event()
        served = [0]
        lock = threading.Lock()

        def hammer():
            c = http.client.HTTPConnection("127.0.0.1", PORT, timeout=10)
            while not stop.is_set():
                try:
                    c.request("GET", "/metrics")
                    c.getresponse().read()
                    with lock:
                        served[0] += 1
                except Exception:
                    c.close()
                    c = http.client.HTTPConnection("127.0.0.1", PORT, timeout=10)
            c.close()

        threads = [threading.Thread(target=hammer) for _ in range(50)]
        for t in threads:
            t.start()
        time.sleep(10)  # the load's duration, not a synchronisation
        stop.set()
        for t in threads:
            t.join()
        time.sleep(0.5)
        c1 = counters()
        lost = {k: c1[k] - c0[k] for k in ("ring_drops", "hot_kernel_drops", "rx_overflow_drops", "status_drops")}
        print("FIGURE 50 clients x 10 s on /metrics: %d answers; drops during it: %s; hot-path frames %d" % (
            served[0], lost, c1["hot_rx_frames"] - c0["hot_rx_frames"]), flush=True)
        report.check(all(v == 0 for v in lost.values()), "no frame or sample lost while 50 clients hammer /metrics",
                     str(lost))
        report.check(served[0] > 50, "the hammering clients were served", str(served[0]))

        # ---- a stale device
        name, serial = DEVICES[2][0], DEVICES[2][3]
        sim.command("silence %d on" % serial)
        ok = False
        t_end = time.time() + 5
        while time.time() < t_end:
            v = devices(status())[name].get("values")
            if v and v["stale"]:
                ok = True
                break
            time.sleep(0.1)
        report.check(ok, "%s: silenced -> stale in /api/v1/status" % name)
        report.check(metric(metrics(), "cobridge_value_stale", name=name) == 1.0, "%s: cobridge_value_stale 1" % name)

        if args.browser:
            browser(report, ws, args, names, name)

        pid = daemon.pid
        print("FIGURE daemon RSS with the web service after the load: %d KiB" % rss_kib(pid), flush=True)
    finally:
        sim.stop()  # flushes the truth file
        sent = {}
        with open(truth) as f:
            for line in f:
                fl = line.split()
                if len(fl) >= 8 and fl[4] == "tpdo1":
                    pos = next((int(x[4:]) for x in fl[8:] if x.startswith("pos=")), None)
                    if pos is not None:
                        sent.setdefault(int(fl[3]), set()).add(pos & 0xFFFFFFFF)
        for node, (name, pos) in sorted(shown.items()):
            report.check(pos is not None and (pos & 0xFFFFFFFF) in sent.get(node, ()),
                         "%s: the position shown is one the simulator sent (truth file)" % name, str(pos))
        e2e.shut_down(ws, daemon, sim)
    return report.finish()


def modbus_clients():
    """modbus_clients_connected as /api/v1/status and /metrics show it."""
    outs = [o for o in (status() or {}).get("outputs", []) if o["type"] == "modbus"]
    api = outs[0]["figures"].get("modbus_clients_connected") if outs else None
    return api, metric(metrics(), "cobridge_output_modbus_clients_connected", output="modbus")


def wait_clients(want, within=3.0):
    seen = (None, None)
    t_end = time.time() + within
    while time.time() < t_end:
        seen = modbus_clients()
        if seen == (want, float(want)):
            break
        time.sleep(0.1)
    return seen


def modbus_figures(report):
    """A real Modbus TCP client (read holding registers 0, 1 register; Modbus
    Application Protocol v1.1b3 §6.3) connects: the web shows it, then not."""
    report.check(wait_clients(0) == (0, 0.0), "outputs: no Modbus client connected at first", str(modbus_clients()))
    c = socket.create_connection(("127.0.0.1", MODBUS_PORT), timeout=5)
    try:
        c.sendall(struct.pack(">HHHBBHH", 1, 0, 6, 1, 3, 0, 1))
        answer = c.recv(64)
        report.check(len(answer) >= 9 and answer[7] == 3, "outputs: the Modbus client got its answer", answer.hex())
        seen = wait_clients(1)
        report.check(seen == (1, 1.0), "outputs: modbus_clients_connected 1 in the JSON and /metrics", str(seen))
    finally:
        c.close()
    seen = wait_clients(0)
    report.check(seen == (0, 0.0), "outputs: modbus_clients_connected back to 0 once it left", str(seen))


def sparkline_points(dom, name):
    """How many points the sparkline of a device row draws (0: none)."""
    m = re.search(r'<tr class="device[^"]*" data-name="%s".*?<svg class="spark"[^>]*>(.*?)</svg>' % re.escape(name),
                  dom, re.S)
    if not m:
        return 0
    pts = re.search(r'points="([^"]*)"', m.group(1))
    return len(pts.group(1).split()) if pts else 0


def positions(dom, names):
    """The position text each device row shows (td.pos), by device name."""
    out = {}
    for n in names:
        m = re.search(r'<tr class="device[^"]*" data-name="%s".*?<td class="num val pos">([^<]*)</td>' % re.escape(n),
                      dom, re.S)
        out[n] = m.group(1) if m else None
    return out


def shown_fresh(dom, name):
    """The device's row is on the page and not marked stale."""
    return re.search(r'<tr class="device[^"]*" data-name="%s"[^>]*data-stale="0"' % re.escape(name), dom) is not None


# The device's timeline as a person uses it: opens its details, which stay
# open across the page's redraws, and follows the newest capture link there.
TIMELINE_JS = """(async () => {
  const list = () => document.querySelector('ol.timeline[data-timeline="%s"]');
  if (!list()) return {found: false};
  list().closest('details').querySelector('summary').click();
  await new Promise(r => setTimeout(r, 2500));
  const kinds = [...list().querySelectorAll('li.tl')].map(li => li.dataset.kind);
  const link = list().querySelector('li.tl[data-capture] a');
  const got = link ? await fetch(link.href) : null;
  const text = got ? await got.text() : '';
  return {found: true, open: list().closest('details').open, kinds: kinds,
          capture: link ? link.textContent : null, status: got ? got.status : 0,
          lines: text.split('\\n').filter(l => l).length,
          candump: /^\\(\\d+\\.\\d{6}\\) \\S+ [0-9A-F]{3,8}#/.test(text)};
})()"""


def timeline_in_page(page, name):
    return page.evaluate(TIMELINE_JS % name, await_promise=True)


def take_views(work, url, names, stale_name, screenshot):
    """Everything Chromium does, in one Chromium: the page as a person sees it
    once its own polls (1 s, real time) ran, twice a few seconds apart (every
    device listed, its values changed in between, the silenced device marked
    stale), and a screenshot when asked. Returns (doms, png); the caller
    checks them. Raises BrowserError (BrowserCrashed: Chromium died)."""
    page = HeadlessPage(work)
    try:
        t0 = time.time()
        page.open(url)
        # A sparkline's polyline is drawn from the second position on. 43 s in
        # UML alone; > 200 s with a build beside it (2026-11-26).
        drawn = page.wait_for("document.querySelectorAll('svg.spark polyline').length >= %d" % (len(names) - 1), 300)
        drawn_at = time.time() - t0
        print("FIGURE chromium started in %.1f s, page drawn %.1f s after the start (%s)" % (
            page.started_in, drawn_at, "drawn" if drawn else "not drawn"), flush=True)
        doms = [page.dom()]
        first = positions(doms[0], names)
        moving = [n for n in names if n != stale_name]

        def settled(dom):  # every moving device shows new, fresh values
            now = positions(dom, names)
            return all(now[n] != first[n] and shown_fresh(dom, n) for n in moving)

        # A few seconds on, or longer while a starved UML lets the page's polls
        # come late (they run in real time); the caller's checks decide.
        time.sleep(3)
        doms.append(page.dom())
        t_end = time.time() + 60
        while not settled(doms[-1]) and time.time() < t_end:
            time.sleep(1)
            doms[-1] = page.dom()
        print("FIGURE the page showed new values %.1f s after the first view" % (time.time() - t0 - drawn_at),
              flush=True)
        # The device table fits a 1,280 px screen (its details fold): no bus section scrolls sideways.
        page.screenshot_png(width=1280, height=900)
        overflow = page.evaluate("Math.max(0, ...[...document.querySelectorAll('section.bus')]"
                                 ".map(s => s.scrollWidth - s.clientWidth))")
        tl = timeline_in_page(page, stale_name)
        pngs = {w: page.screenshot_png(width=w, height=900) for w in (1280, 1920)} if screenshot else None
        print("FIGURE the browser part took %.1f s" % (time.time() - t0), flush=True)
        return doms, (pngs, overflow, tl)
    finally:
        page.close()


def views_with_one_fresh_chromium(work, url, names, stale_name, screenshot):
    """take_views; Chromium's --single-process mode inside UML has died on its
    own (CI, 2026-11-27, twice, 10-20 s into its life: "Page.navigate" and
    "Runtime.evaluate: Chromium closed its pipe"; passing by hand in the same
    tree). That is the browser, not the page: one fresh Chromium, and the
    first one's stderr printed. Any other browser error fails at once."""
    for attempt in (1, 2):
        where = os.path.join(work, "chromium-%d" % attempt)
        os.makedirs(where)
        try:
            return take_views(where, url, names, stale_name, screenshot)
        except BrowserCrashed as e:
            print("FIGURE chromium died (attempt %d): %s; its stderr ends:\n%s" % (
                attempt, e, HeadlessPage.log_tail(where, 25)), flush=True)
            if attempt == 2:
                raise


def browser(report, ws, args, names, stale_name):
    url = "http://127.0.0.1:%d/" % PORT
    work = tempfile.mkdtemp(prefix="cobridge-chrome-", dir="/tmp")
    try:
        doms, (pngs, overflow, tl) = views_with_one_fresh_chromium(work, url, names, stale_name,
                                                                    bool(args.screenshot_dir))
    except BrowserError as e:
        logs = sorted(glob.glob(os.path.join(work, "*", "chromium.log")))
        report.check(False, "browser: Chromium drove the page", "%s; its stderr ends:\n%s" % (
            e, HeadlessPage.log_tail(os.path.dirname(logs[-1]), 25) if logs else "(no log)"))
        return
    finally:
        shutil.rmtree(work, ignore_errors=True)
    first, second = positions(doms[0], names), positions(doms[-1], names)
    for n in names:
        report.check(first[n] is not None and second[n] is not None, "browser: %s listed" % n)
        if n != stale_name:
            report.check(first[n] not in (None, "\u2013") and first[n] != second[n],
                         "browser: %s values change on the page" % n, "%s -> %s" % (first[n], second[n]))
            # A device whose values flow again after a fault or a power cycle is not stale.
            report.check(shown_fresh(doms[-1], n), "browser: %s not marked stale" % n)
            pts = sparkline_points(doms[-1], n)
            report.check(pts >= 2, "browser: %s sparkline drawn" % n, "%d points" % pts)
    m = re.search(r'<tr class="device ([^"]*)" data-name="%s"[^>]*data-stale="1"' % re.escape(stale_name), doms[-1])
    report.check(m is not None and "stale" in m.group(1), "browser: %s marked stale" % stale_name)
    report.check('class="flag stale"' in doms[-1], "browser: the STALE flag is shown")
    report.check('class="emcy"' in doms[-1], "browser: the EMCY history is shown")
    report.check(overflow == 0, "browser: the device table fits a 1,280 px screen (nothing scrolls sideways)",
                 "%s px too wide" % overflow)
    row = re.search(r'<tr class="device[^"]*" data-name="%s".*?</tr>' % re.escape(stale_name), doms[-1], re.S)
    report.check(row is not None and 'class="nmt-unknown"' in row.group(0) and ">unknown<" in row.group(0),
                 "browser: the silenced device's NMT state reads unknown, not its last heartbeat's")
    report.check('data-capture="' in doms[-1] and 'href="api/v1/captures/' in doms[-1],
                 "browser: the bus's flight recorder captures are listed, each a link to its file")
    report.check(tl.get("found") and tl.get("open") and "heartbeat" in tl.get("kinds", []) and
                 "state" in tl.get("kinds", []),
                 "browser: %s's timeline shows the heartbeat loss and the state change; its details stay open "
                 "across redraws" % stale_name, json.dumps(tl))
    report.check(tl.get("capture") and tl.get("status") == 200 and tl.get("lines", 0) > 0 and tl.get("candump"),
                 "browser: the timeline's capture link serves the frames as a candump -l log", json.dumps(tl))
    report.check('stroke-width="2"' in doms[-1] and "<circle" in doms[-1],
                 "browser: the sparkline is drawn legibly (2 px stroke, the newest point marked)")
    report.check("\u00a7" in doms[-1] and not re.search(r"\([JEF]\u00a7", doms[-1]),
                 "browser: EMCY text cites the manual by name and section, no internal key like (J\u00a71.8.1)")
    load = re.search(r'data-load="([0-9.]+)"', doms[-1])
    report.check(load is not None and float(load.group(1)) > 0, "browser: the bus load is shown",
                 load.group(1) + " %" if load else "none")
    ctl = re.search(r'<span[^>]*data-controller="([^"]*)"[^>]*>(.*?)</span>', doms[-1], re.S)
    report.check(ctl is not None and ctl.group(1) == "unknown" and "the driver reports no state" in ctl.group(2),
                 "browser: the CAN controller line says where its figures come from (vcan: the driver reports no "
                 "state over netlink)", ctl.group(0)[:200] if ctl else "none")
    report.check('data-output="modbus"' in doms[-1] and 'data-figure="modbus_clients_connected"' in doms[-1],
                 "browser: the Modbus output and its clients connected are shown")
    for width, png in (pngs or {}).items():
        ok = png.startswith(b"\x89PNG") and len(png) > 10000
        report.check(ok, "browser: screenshot at %d px taken" % width, "%d bytes" % len(png))
        if ok:
            os.makedirs(args.screenshot_dir, exist_ok=True)
            with open(os.path.join(args.screenshot_dir, "web-status-%d.png" % width), "wb") as f:
                f.write(png)


if __name__ == "__main__":
    sys.exit(main())
