#!/usr/bin/env bash
# scripts/bench --check-doc can fail: a figure typed into the generated table
# by hand, or a record newer than the page, is found. Every generated row
# names its bed (host, UML, QEMU), whether the idle keepers ran (yes, no, ?)
# and its run's commit and time, and the header says how many runs the rows
# come from: for the committed record, for a record of two runs, and for a
# record that --only merged into an older one; a row that lacks any of them
# is found.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
bench="$repo/scripts/bench"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$repo/docs/performance.md" "$work/doc.md"
cp "$repo/bench/results/latest.json" "$work/record.json"
# The other bed's record (scripts/bench --other-bed), read from beside the record.
for side in "$repo"/bench/results/latest-*.json; do [ ! -e "$side" ] || cp "$side" "$work/"; done
check() { /usr/bin/python3 "$bench" --check-doc --record "$work/record.json" --doc-file "$work/doc.md"; }
check || { echo "FAIL: the committed page and record differ"; exit 1; }
# A hand edit inside the table.
sed -i '/scripts\/bench: generated/,/scripts\/bench: end/ s/| met |/| met (typed) |/' "$work/doc.md"
if check 2>/dev/null; then echo "FAIL: a hand edit of the table was not found"; exit 1; fi
cp "$repo/docs/performance.md" "$work/doc.md"
# A newer record than the page.
sed -i 's/"commit": "[^"]*"/"commit": "0000000"/' "$work/record.json"
if check 2>/dev/null; then echo "FAIL: a record newer than the page was not found"; exit 1; fi
echo "bench doc selftest: both differences found"

# rows_name_their_origin PAGE [HEADER-PATTERN]: every row of PAGE's generated
# table names bed, keepers, commit and run time; the header matches the pattern.
rows_name_their_origin() {
  /usr/bin/python3 - "$@" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
section = text[text.index("<!-- scripts/bench: generated"):text.index("<!-- scripts/bench: end -->")]
lines = section.splitlines()
head = [l for l in lines if l.startswith("Measured by `scripts/bench`")]
table = [l for l in lines if l.startswith("|")]
bad = []
if len(head) != 1 or not re.search(r"rows from (\d+ runs?|an unknown number of runs)", head[0]):
    bad.append("header: does not say how many runs the rows come from: %r" % head)
elif len(sys.argv) > 2 and not re.search(sys.argv[2], head[0]):
    bad.append("header: %r does not match %r" % (head[0], sys.argv[2]))
want = "| figure | target | measured | same-run baseline | ratio | verdict | bed | keepers | commit | run (UTC) |"
if not table or table[0] != want:
    bad.append("columns: %r" % table[:1])
for l in table[2:]:
    if l == want or l.startswith("|---"):  # the other bed's table begins here
        continue
    cells = [c.strip() for c in l.strip("|").split(" | ")]
    if len(cells) != 10:
        bad.append("%d cells: %s" % (len(cells), l))
        continue
    bed, keepers, commit, when = cells[6:]
    if bed not in ("host", "UML", "QEMU"):
        bad.append("no bed: " + l)
    if keepers not in ("yes", "no", "?") or (bed == "host" and keepers != "no"):
        bad.append("no keepers: " + l)
    if not re.fullmatch(r"[0-9a-f]{7,40}(-dirty)?\??", commit):
        bad.append("no commit: " + l)
    if not re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d\??", when):
        bad.append("no run time: " + l)
if len(table) < 3:
    bad.append("no rows")
print("\n".join(bad), file=sys.stderr)
sys.exit(1 if bad else 0)
PY
}

# The committed page.
rows_name_their_origin "$repo/docs/performance.md" \
  || { echo "FAIL: a row of the committed page does not name its bed, keepers and commit"; exit 1; }

# Three records from the committed one's rows: "legacy", as records were
# written before rows named their run (guest rows "UML", no keepers, no run:
# the header's time and commit only); "two", rows of two runs (host rows, then
# guest rows in QEMU without the keepers from a dirty tree); "merged", the
# restart group measured again (--only) into the legacy record.
/usr/bin/python3 -B - "$bench" "$repo/bench/results/latest.json" "$work" <<'PY'
import importlib.machinery, importlib.util, json, sys
loader = importlib.machinery.SourceFileLoader("bench", sys.argv[1])
bench = importlib.util.module_from_spec(importlib.util.spec_from_loader("bench", loader))
loader.exec_module(bench)
committed, work = json.load(open(sys.argv[2])), sys.argv[3]
guest = {g[0] for g in bench.GROUPS if g[2]}
def save(name, record):
    with open("%s/%s.json" % (work, name), "w") as f:
        json.dump(record, f)
rows = [{k: v for k, v in r.items() if k not in ("run", "keepers")} for r in committed["rows"]]
legacy = {"time": "2026-11-28 12:34", "commit": "4ad261a", "host": committed["host"], "errors": [],
          "rows": [dict(r, where="UML" if r["group"] in guest else "host") for r in rows]}
runs = [{"time": "2027-01-02 03:04", "commit": "abcdef1", "dirty": False, "load": "0.50",
         "file": "bench/results/20270102T030400Z.json"},
        {"time": "2027-01-02 05:06", "commit": "1234567", "dirty": True, "load": "1.50",
         "file": "bench/results/20270102T050600Z.json"}]
save("legacy", legacy)
save("two", dict(legacy, rows=[dict(r, where="QEMU" if r["group"] in guest else "host", keepers=False,
                                    run=runs[r["group"] in guest]) for r in rows]))
merged = dict(legacy, time=runs[1]["time"], commit=runs[1]["commit"],
              rows=[dict(r, where="QEMU", keepers=True, run=runs[1]) for r in rows if r["group"] == "restart"])
bench.merge_only(merged, ["restart"], work + "/legacy.json")
save("merged", merged)
PY
for name in legacy two merged; do
  cp "$repo/docs/performance.md" "$work/$name.md"
  /usr/bin/python3 "$bench" --doc --record "$work/$name.json" --doc-file "$work/$name.md"
done
expect() {  # expect PAGE GREP-PATTERN WHAT
  grep -q "$2" "$work/$1.md" || { echo "FAIL: $1 record: $3"; exit 1; }
}
rows_name_their_origin "$work/legacy.md" 'rows from an unknown number of runs .*\(2026-11-28 12:34 UTC, commit 4ad261a,' \
  || { echo "FAIL: legacy record"; exit 1; }
expect legacy '^| 32 remembered: second start -> all operational .* | UML | ? | 4ad261a? | 2026-11-28 12:34? |$' \
  "an old guest row is not UML, keepers ?, the header's commit and time marked ?"
expect legacy '^| hot path, no plugin: .* | host | no | 4ad261a? | 2026-11-28 12:34? |$' "an old host row"
# shellcheck disable=SC2016  # the backticks are the page's Markdown
run1='2027-01-02 03:04 UTC, commit abcdef1, load 0.50 at the start, `bench/results/20270102T030400Z.json`'
rows_name_their_origin "$work/two.md" "rows from 2 runs \\($run1; 2027-01-02 05:06 UTC, commit 1234567-dirty," \
  || { echo "FAIL: a record of two runs"; exit 1; }
expect two '^| second start: exec to the daemon.* | QEMU | no | 1234567-dirty | 2027-01-02 05:06 |$' \
  "a guest row does not name QEMU, no keepers and its dirty commit"
expect two '^| hot path, no plugin: .* | host | no | abcdef1 | 2027-01-02 03:04 |$' "a host row does not name its run"
rows_name_their_origin "$work/merged.md" 'rows from 1 run \(2027-01-02 05:06 UTC.* and from an unknown number of runs' \
  || { echo "FAIL: a record merged by --only into an older one"; exit 1; }
expect merged '^| second start: exec to the daemon.* | QEMU | yes | 1234567-dirty | 2027-01-02 05:06 |$' \
  "the group measured again does not name its own run"
expect merged '^| 32 remembered: second start -> all operational .* | UML | ? | 4ad261a? | 2026-11-28 12:34? |$' \
  "a row of the older record is not marked unsure after the merge"

# A row that lacks its bed, keepers, commit or run time is found (an emptied
# cell, a cell gone).
for cut in 's/ | QEMU | no | / | - | no | /' 's/ | host | no | / | host | - | /' 's/ | 1234567-dirty | / | - | /' \
           's/ | 2027-01-02 03:04 |$/ | - |/' 's/ | host | no | / | host | /' 's/ | abcdef1 | / | /'; do
  cp "$work/two.md" "$work/cut.md"
  sed -i "/^| second start: exec to the daemon\|^| hot path, no plugin/ $cut" "$work/cut.md"
  cmp -s "$work/two.md" "$work/cut.md" && { echo "FAIL: the edit '$cut' changed nothing"; exit 1; }
  if rows_name_their_origin "$work/cut.md" 2>/dev/null; then
    echo "FAIL: a row without its bed, keepers, commit or time was not found ($cut)"; exit 1
  fi
done
# A record row that names no bed: scripts/bench --doc refuses it.
/usr/bin/python3 -c 'import json, sys; r = json.load(open(sys.argv[1])); del r["rows"][-1]["where"]
json.dump(r, open(sys.argv[2], "w"))' "$work/two.json" "$work/nobed.json"
cp "$work/two.md" "$work/nobed.md"
if /usr/bin/python3 "$bench" --doc --record "$work/nobed.json" --doc-file "$work/nobed.md" 2>/dev/null; then
  echo "FAIL: a record row without its bed was rendered"; exit 1
fi
# The other bed's record (scripts/bench --other-bed qemu) beside the main one:
# its own table after the main one, its rows naming QEMU and their own run;
# the main table unchanged by it.
mkdir "$work/side"
cp "$work/legacy.json" "$work/side/record.json"
/usr/bin/python3 -c 'import json, sys; r = json.load(open(sys.argv[1]))
r["rows"] = [x for x in r["rows"] if x["where"] == "QEMU"]
json.dump(r, open(sys.argv[2], "w"))' "$work/two.json" "$work/side/latest-qemu.json"
cp "$repo/docs/performance.md" "$work/side.md"
/usr/bin/python3 "$bench" --doc --record "$work/side/record.json" --doc-file "$work/side.md"
rows_name_their_origin "$work/side.md" || { echo "FAIL: a page with the other bed's table"; exit 1; }
expect side '^The guest groups on the QEMU bed as well (`scripts/bench --other-bed qemu`'   "the other bed's table has no header naming its bed and option"
expect side '^| second start: exec to the daemon.* | QEMU | no | 1234567-dirty | 2027-01-02 05:06 |$'   "the other bed's row does not name QEMU and its own run"
expect side '^| 32 remembered: second start -> all operational .* | UML | ? | 4ad261a? | 2026-11-28 12:34? |$'   "the main table's guest row is not kept beside the other bed's"
echo "bench doc selftest: every row names its bed, keepers and commit; rows that do not are found"
