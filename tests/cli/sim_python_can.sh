#!/usr/bin/env bash
# python-can's slcan interface (Debian's python3-can) as an independent client of `saulctl sim`: it must read
# telemetry and get a mode command acknowledged. Skipped with a reason when python3-can is missing.
set -uo pipefail
saulctl=$1
work=$(mktemp -d)
sim=""
trap 'kill $sim 2>/dev/null; wait $sim 2>/dev/null; rm -rf "$work"' EXIT
if ! /usr/bin/python3 -c 'import can' 2>/dev/null; then
  echo "SKIP python-can is not installed (apt-get install python3-can)"
  echo "0 passed, 0 failed"
  exit 0
fi
"$saulctl" sim --quiet --paths-file "$work/paths" --for 60s >"$work/sim.log" 2>&1 &
sim=$!
for _ in $(seq 200); do [[ -s $work/paths ]] && break; sleep 0.05; done
can=$(sed -n 's/^can=//p' "$work/paths")
/usr/bin/python3 - "$can" <<'PY'
import sys, time
import can
bus = can.Bus(interface="slcan", channel=sys.argv[1], bitrate=500000)
fails = 0
def check(name, ok):
    global fails
    print(("ok   " if ok else "FAIL ") + name)
    fails += 0 if ok else 1
deadline = time.monotonic() + 5
tel = None
while time.monotonic() < deadline and tel is None:
    m = bus.recv(0.5)
    if m is not None and m.arbitration_id == 0x400 and not m.is_extended_id:
        tel = m
check("python-can reads telemetry A (0x400, 7 bytes, state OFF) from the simulator",
      tel is not None and tel.dlc == 7 and tel.data[6] == 0)
bus.send(can.Message(arbitration_id=0x302, data=[0x00], is_extended_id=False))
ack = None
deadline = time.monotonic() + 5
while time.monotonic() < deadline and ack is None:
    m = bus.recv(0.5)
    if m is not None and m.arbitration_id == 0x402 and not m.is_extended_id:
        ack = m
check("mode off from python-can is acknowledged: 402#020000", ack is not None and bytes(ack.data) == b"\x02\x00\x00")
bus.shutdown()
print(f"{2 - fails} passed, {fails} failed")
sys.exit(1 if fails else 0)
PY
