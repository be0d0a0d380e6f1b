#!/usr/bin/env bash
# Resident memory of the real cobridged serving 32 simulated encoders with
# DDS + Modbus + JSON tap on, each encoder sending TPDO1 every 10 ms.
# With `web` as second argument the [web] service is on too, and the figure
# is taken while 50 clients poll /metrics and the page's JSON (target:
# RSS added by the web service <= 4 MiB = the difference of the two runs).
# Runs inside UML (real SocketCAN):
#   tests/vcan/run-in-vcan --ifaces 1 --timeout 400 -- tests/bench/daemon_rss_in_uml.sh BUILD_DIR [web]
set -uo pipefail
build=${1:?usage: daemon_rss_in_uml.sh BUILD_DIR [web]}
web=${2:-}
repo=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d /tmp/cobridge-rss.XXXXXX)
export CYCLONEDDS_URI='<General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces></General>'
models=(RFC-4800 RSA-3200 MC1-2800 MZ1-2200)
args=()
{
  printf '[gateway]\nid = "rss"\nstate_dir = "%s/state"\ncontrol_socket = "%s/control.sock"\ndevice_dirs = ["%s/config/devices"]\n' "$work" "$work" "$repo"
  printf '[logging]\nlevel = "warn"\ntarget = "console"\n'
  printf '[[bus]]\nname = "line1"\ninterface = "vcan0"\nlss_timeout_ms = 30\n'
  for i in $(seq 1 32); do
    m=${models[$(( (i - 1) % 4 ))]}
    args+=(--device "$m:serial=$((5000 + i)),node=$i,motion=constant:0.1")
    printf '[[device]]\nname = "enc%d"\nbus = "line1"\nserial = %d\nmodel = "%s"\nnode_id = %d\nheartbeat_ms = 200\n[device.tpdo1]\nmapping = ["position", "speed"]\ntransmission = 254\nevent_timer_ms = 10\n' \
      "$i" "$((5000 + i))" "$m" "$i"
  done
  [ "$web" = web ] && printf '[web]\nport = 8089\n'
  printf '[outputs.dds]\n[outputs.modbus]\nbind = "127.0.0.1"\nport = 1502\n[outputs.jsontap]\npath = "/dev/null"\n'
} > "$work/rss.toml"
"$build/sim/app/cobridge-sim" --iface vcan0 "${args[@]}" --state-dir "$work/nv" > "$work/sim.log" 2>&1 &
sim=$!
"$build/daemon/cobridged" --foreground --config "$work/rss.toml" --plugin-dir "$build/lib/cobridge/plugins" > "$work/daemon.log" 2>&1 &
daemon=$!
for t in $(seq 1 240); do
  sleep 1
  n=$("$build/daemon/cli/cobridge" status --control "$work/control.sock" --json 2>/dev/null | /usr/bin/python3 -c \
    'import json,sys; d=json.load(sys.stdin); print(sum(1 for b in d["buses"] for x in b["devices"] if x["state"]=="operational"))' 2>/dev/null || echo 0)
  [ "$n" = 32 ] && break
done
hammer=()
if [ "$web" = web ]; then
  for c in $(seq 1 50); do
    ( while :; do curl -s -o /dev/null http://127.0.0.1:8089/metrics; curl -s -o /dev/null http://127.0.0.1:8089/api/v1/status; done ) &
    hammer+=($!)
  done
fi
sleep 5
rss=$(awk '/VmRSS/ {print $2}' /proc/$daemon/status)
hwm=$(awk '/VmHWM/ {print $2}' /proc/$daemon/status)
threads=$(awk '/Threads/ {print $2}' /proc/$daemon/status)
[ ${#hammer[@]} -gt 0 ] && kill ${hammer[@]} 2>/dev/null
label="DDS+Modbus+JSON tap"
if [ "$web" = web ]; then
  code=$(curl -s -o /dev/null -w '%{http_code}' http://127.0.0.1:8089/metrics)
  label="$label+web (50 clients polling; /metrics answered $code)"
fi
echo "cobridged with $n/32 devices operational, TPDO1 every 10 ms each, $label: VmRSS ${rss} KiB, peak ${hwm} KiB, ${threads} threads (after ${t} s)"
kill -TERM $daemon $sim; wait 2>/dev/null
rm -rf "$work"
[ "$n" = 32 ]
