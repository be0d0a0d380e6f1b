#!/bin/sh
# verify-unit.sh UNIT DAEMON: `systemd-analyze verify` of the service unit,
# with ExecStart pointed at the built daemon (the unit names /usr/bin/cobridged,
# which does not exist on a build machine). Any message is a failure.
set -eu
unit=$1
daemon=$2
work=$(mktemp -d /tmp/cobridge-unit.XXXXXX)
trap 'rm -rf "$work"' EXIT
sed "s#/usr/bin/cobridged#$daemon#g" "$unit" > "$work/cobridged.service"
grep -q "^ExecStart=$daemon " "$work/cobridged.service" || { echo "FAIL: ExecStart not rewritten"; exit 1; }
out=$(systemd-analyze verify "$work/cobridged.service" 2>&1) || { echo "$out"; echo "FAIL: systemd-analyze verify"; exit 1; }
if [ -n "$out" ]; then
  echo "$out"
  echo "FAIL: systemd-analyze verify printed messages"
  exit 1
fi
echo "PASS: systemd-analyze verify $(basename "$unit")"
