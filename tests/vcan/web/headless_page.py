"""One headless Chromium, driven over the DevTools protocol on a pipe.

Chromium starts slowly inside UML (one slow CPU: 50-85 s a start on
2026-11-26), so a test starts it once and takes every view it needs from
that one page: the DOM as the page's own script left it (after its polls
ran in real time), again a few seconds later, and a screenshot.

--remote-debugging-pipe: Chromium reads protocol messages on fd 3 and
writes them on fd 4, each a JSON text ended by NUL (no WebSocket needed).
--single-process: no zygote, renderer or GPU processes to fork and exec,
which halves the start inside UML (30 s against 54 s, measured).
"""
import base64
import fcntl
import json
import os
import select
import subprocess
import time


class BrowserError(Exception):
    pass


class BrowserCrashed(BrowserError):
    """Chromium ended (its pipe closed): the browser died, not the page."""


class HeadlessPage:
    def __init__(self, work, size=(1400, 700), start_within=300.0):
        home = os.path.join(work, "chrome-home")
        os.makedirs(home, exist_ok=True)
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()

        def wire():  # in the child, before exec: the protocol's two fds
            r, w = fcntl.fcntl(to_child_r, fcntl.F_DUPFD, 10), fcntl.fcntl(from_child_w, fcntl.F_DUPFD, 10)
            os.dup2(r, 3)
            os.dup2(w, 4)

        args = ["chromium", "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--single-process", "--no-zygote", "--no-first-run", "--disable-extensions",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--disable-default-apps", "--mute-audio", "--disable-breakpad", "--remote-debugging-pipe",
                "--user-data-dir=" + os.path.join(home, "profile"), "--window-size=%d,%d" % size, "about:blank"]
        self.log_path = os.path.join(work, "chromium.log")  # its stderr, for a crash's report
        with open(self.log_path, "wb") as log:
            self._proc = subprocess.Popen(args, env=dict(os.environ, HOME=home), stdin=subprocess.DEVNULL,
                                          stdout=subprocess.DEVNULL, stderr=log,
                                          preexec_fn=wire, pass_fds=(3, 4))
        os.close(to_child_r)
        os.close(from_child_w)
        self._buf = b""
        self._next_id = 0
        self._session = None
        t0 = time.time()
        targets = self._call("Target.getTargets", timeout=start_within)["targetInfos"]
        page = next((t for t in targets if t["type"] == "page"), None)
        if page is None:
            raise BrowserError("no page target among %r" % targets)
        self._session = self._call("Target.attachToTarget", {"targetId": page["targetId"], "flatten": True},
                                   session=False)["sessionId"]
        self.started_in = time.time() - t0

    @staticmethod
    def log_tail(work, n=12):
        try:
            with open(os.path.join(work, "chromium.log"), errors="replace") as f:
                return "".join(f.readlines()[-n:])
        except OSError:
            return ""

    def _send(self, method, params, session):
        self._next_id += 1
        msg = {"id": self._next_id, "method": method, "params": params or {}}
        if session and self._session:
            msg["sessionId"] = self._session
        os.write(self._to_child, json.dumps(msg).encode() + b"\0")
        return self._next_id

    def _call(self, method, params=None, timeout=60.0, session=True):
        want = self._send(method, params, session)
        deadline = time.time() + timeout
        while True:
            while b"\0" in self._buf:
                raw, self._buf = self._buf.split(b"\0", 1)
                msg = json.loads(raw)
                if msg.get("id") == want:
                    if "error" in msg:
                        raise BrowserError("%s: %s" % (method, msg["error"]))
                    return msg.get("result", {})
            left = deadline - time.time()
            if left <= 0:
                raise BrowserError("%s: no answer within %.0f s" % (method, timeout))
            ready, _, _ = select.select([self._from_child], [], [], left)
            if ready:
                chunk = os.read(self._from_child, 1 << 16)
                if not chunk:
                    raise BrowserCrashed("%s: Chromium closed its pipe (exit %s)" % (method, self._proc.poll()))
                self._buf += chunk

    def open(self, url, timeout=120.0):
        self._call("Page.navigate", {"url": url}, timeout=timeout)

    def evaluate(self, expression, timeout=60.0, await_promise=False):
        r = self._call("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                            "awaitPromise": await_promise}, timeout=timeout)
        if "exceptionDetails" in r:
            raise BrowserError("%s: %s" % (expression, r["exceptionDetails"].get("text")))
        return r["result"].get("value")

    def wait_for(self, expression, within):
        """Polls a JavaScript condition until it holds (True) or `within` s pass (False)."""
        deadline = time.time() + within
        while time.time() < deadline:
            if self.evaluate(expression):
                return True
            time.sleep(0.25)
        return False

    def dom(self):
        return self.evaluate("document.documentElement.outerHTML")

    def screenshot_png(self, width=1400, height=1000):
        self._call("Emulation.setDeviceMetricsOverride",
                   {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        return base64.b64decode(self._call("Page.captureScreenshot", {"format": "png"}, timeout=120)["data"])

    def close(self):
        try:
            if self._proc.poll() is None:
                self._send("Browser.close", None, session=False)
                self._proc.wait(timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            self._proc.kill()
            self._proc.wait()
        finally:
            os.close(self._to_child)
            os.close(self._from_child)
