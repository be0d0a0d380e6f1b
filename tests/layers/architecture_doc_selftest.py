#!/usr/bin/env python3
"""scripts/check-architecture-doc can fail: on a fixture table that names a
removed file (a path, a stem after its folder, a brace pair with one half
gone) it exits 1 and names each; on a table whose places all exist, 0."""
import os
import subprocess
import sys
import tempfile

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts", "check-architecture-doc")

HEAD = "# x\n\n## Where is it\n\n| Concept | Where |\n|---|---|\n"
GOOD = ("| Restore guard | `daemon/bus/restore_guard.{hpp,cpp}`, `daemon/bus/` (`supervisor`, `RestoreGuard`) |\n"
        "| A config key is no place | `daemon/config/` (`load`); `on_config_drift`, `cobridge why` |\n")
BAD = ("| Gone | `daemon/bus/service/` (`service_request`, `direct_answer`) |\n"
       "| Half gone | `daemon/bus/restore_guard.{hpp,cxx}` |\n"
       "| Moved | `daemon/bus/service/line_connection` |\n")


def run(text):
    with tempfile.NamedTemporaryFile("w", suffix=".md", delete=False) as f:
        f.write(HEAD + text)
    try:
        p = subprocess.run([sys.executable, SCRIPT, "--doc", f.name], capture_output=True, text=True)
        return p.returncode, p.stdout + p.stderr
    finally:
        os.unlink(f.name)


def main():
    failures = []
    rc, out = run(GOOD)
    if rc != 0:
        failures.append("a table of existing places: exit %d, want 0\n%s" % (rc, out))
    rc, out = run(BAD)
    want = ("direct_answer (in daemon/bus/service/)", "restore_guard.{hpp,cxx}", "daemon/bus/service/line_connection")
    if rc != 1 or not all(w in out for w in want):
        failures.append("a table naming 3 removed places: exit %d, want 1 naming %s\n%s" % (rc, want, out))
    rc, out = run("")
    if rc != 2:
        failures.append("no rows: exit %d, want 2" % rc)
    for f in failures:
        print("FAIL", f)
    print("architecture_doc_selftest: %d failed" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
