#!/usr/bin/env bash
# scripts/bench --check-doc can fail: a figure typed into the generated table
# by hand, or a record newer than the page, is found.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$repo/docs/performance.md" "$work/doc.md"
cp "$repo/bench/results/latest.json" "$work/record.json"
check() { /usr/bin/python3 "$repo/scripts/bench" --check-doc --record "$work/record.json" --doc-file "$work/doc.md"; }
check || { echo "FAIL: the committed page and record differ"; exit 1; }
# A hand edit inside the table.
sed -i '/scripts\/bench: generated/,/scripts\/bench: end/ s/| met |/| met (typed) |/' "$work/doc.md"
if check 2>/dev/null; then echo "FAIL: a hand edit of the table was not found"; exit 1; fi
cp "$repo/docs/performance.md" "$work/doc.md"
# A newer record than the page.
sed -i 's/"commit": "[^"]*"/"commit": "0000000"/' "$work/record.json"
if check 2>/dev/null; then echo "FAIL: a record newer than the page was not found"; exit 1; fi
echo "bench doc selftest: both differences found"
