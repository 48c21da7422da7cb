#!/usr/bin/env bash
# saulctl tune auto on a live robot (no --sim): it prints the experiment it would run (gains, excitation, amplitude,
# duration, limits) and sends nothing, exit 0; --yes is refused (exit 1: not implemented for live robots yet), again
# sending nothing. The robot here is `saulctl sim`'s BALANCE console pty: afterwards its status shows no trace
# record sent, no excitation and its gains unchanged (a `trace on`, an `excite` or a `pid` typed there would show).
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
sim=
trap '[[ -n $sim ]] && kill "$sim" 2>/dev/null; rm -rf "$work"' EXIT
cd "$work" || exit 1

"$saulctl" sim --quiet --paths-file paths --for 30s >sim.log 2>&1 &
sim=$!
for _ in $(seq 200); do [[ -s paths ]] && break; sleep 0.05; done
balance=$(sed -n 's/^balance=//p' paths)
check "saulctl sim gives a BALANCE console pty" test -n "$balance"

"$saulctl" tune auto --console-balance "$balance" >plan.txt 2>plan.err
check "without --yes: exit 0" test $? -eq 0
cat plan.txt
check "the plan names the robot's console" grep -q "^live plan (robot: BALANCE console $balance)" plan.txt
check "the plan gives the excitation, its amplitude and duration" \
  grep -q "excitation: chirp of 1 deg on the pitch setpoint, 0.5-15 Hz, 20 s per set" plan.txt
check "the plan gives the limits" grep -q "limits:     amplitude at most 2 deg and 20 s per excitation" plan.txt
check "it says nothing was sent" grep -q "^nothing sent: this is the plan only" plan.txt
check "no gains proposed or applied" bash -c "! grep -Eq '^(proposed|applied)' plan.txt"

"$saulctl" tune auto --console-balance "$balance" --yes >yes.txt 2>yes.err
check "--yes on a live robot: refused, exit 1" test $? -eq 1
check "... saying it is not implemented for live robots yet and nothing was sent" \
  grep -q "not implemented for live robots yet; nothing was sent" yes.err

timeout 10 "$saulctl" console "$balance" status >status.txt 2>&1
cat status.txt
check "BALANCE answers its status" grep -aq "^report=status board=balance" status.txt
check "no trace record was sent and no excitation runs" grep -aq "^report=trace divider=[0-9]* sent=0 .* excite=none" status.txt
check "its gains are the shipped ones still" grep -aq "^report=status .* kp=100 ki=500 kd=3 " status.txt

echo "$fails failed"
exit $((fails > 0))
