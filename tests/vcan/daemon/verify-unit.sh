#!/bin/sh
# verify-unit.sh UNIT DAEMON: `systemd-analyze verify` of the service unit template,
# with ExecStart pointed at the built daemon (the installed unit names <prefix>/bin/cobridged,
# which does not exist on a build machine). Any message is a failure.
set -eu
unit=$1
daemon=$2
work=$(mktemp -d /tmp/cobridge-unit.XXXXXX)
trap 'rm -rf "$work"' EXIT
sed -e "s#@COBRIDGE_UNIT_BINDIR@/cobridged#$daemon#g" -e "s#@COBRIDGE_UNIT_SYSCONFDIR@#/etc#g" \
    -e "s#@COBRIDGE_UNIT_DOCDIR@#/usr/share/doc/cobridge#g" "$unit" > "$work/cobridged.service"
grep -q "^ExecStart=$daemon " "$work/cobridged.service" || { echo "FAIL: ExecStart not rewritten"; exit 1; }
out=$(systemd-analyze verify "$work/cobridged.service" 2>&1) || { echo "$out"; echo "FAIL: systemd-analyze verify"; exit 1; }
if [ -n "$out" ]; then
  echo "$out"
  echo "FAIL: systemd-analyze verify printed messages"
  exit 1
fi
echo "PASS: systemd-analyze verify $(basename "$unit")"
# The sandbox (docs/operations.md, Unit hardening): exposure at most 2.0.
sec=$(systemd-analyze security --offline=true "$work/cobridged.service" 2>&1 | grep -o 'Overall exposure level for cobridged.service: [0-9.]*')
level=${sec##* }
case "$level" in
  0.*|1.*|2.0) echo "PASS: $sec" ;;
  *) echo "FAIL: systemd-analyze security: '${sec:-no exposure level}' (must be <= 2.0)"; exit 1 ;;
esac
