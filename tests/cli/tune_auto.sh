#!/usr/bin/env bash
# saulctl tune auto --sim: proposes gains from simulator experiments and verifies them on 20 seeds (60 s each, on
# simulated time); the issue's check: they hold 60 s on all 20 seeds with a lower pitch RMS than the shipped gains.
# Checked again here from outside tune auto: the proposed gains run through 'tune record --sim --gains' for 60 s on
# two seeds and analysed by 'tune report' hold (no fall) with a lower pitch RMS than the shipped set on the same seed.
# Nothing is applied; without --sim only the live plan is printed (exit 0; tests/cli/tune_auto_live.sh).
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1

"$saulctl" tune auto --sim >auto.txt 2>auto.err
check "tune auto --sim exits 0 (gains proposed)" test $? -eq 0
cat auto.txt
check "it prints the experiment" grep -q "^experiment: " auto.txt
check "held 60 s on 20 of 20 seeds" grep -q "^verification: held 60 s on 20 of 20 seeds" auto.txt
check "it says it applies nothing" grep -q "^not applied: " auto.txt
read -r kp ki kd < <(sed -n 's/^proposed: Kp \([0-9.]*\) Ki \([0-9.]*\) Kd \([0-9.]*\) .*/\1 \2 \3/p' auto.txt)
check "proposed gains parsed (${kp:-?} ${ki:-?} ${kd:-?})" test -n "${kd:-}"
for seed in 3 17; do
  "$saulctl" tune record --sim --seed $seed --gains "$kp" "$ki" "$kd" --duration 60s -o p.trace >/dev/null &&
    "$saulctl" tune record --sim --seed $seed --duration 60s -o s.trace >/dev/null &&
    "$saulctl" tune report p.trace --json >p.json && "$saulctl" tune report s.trace --json >s.json
  check "seed $seed: both sets recorded 60 s" test $? -eq 0
  check "seed $seed: proposed holds with a lower pitch RMS than shipped" python3 -c "
import json,sys; p=json.load(open('p.json')); s=json.load(open('s.json'))
print(p['pitch_rms_deg'], s['pitch_rms_deg'], p['falls']); sys.exit(not (p['falls']==0 and p['pitch_rms_deg'] < s['pitch_rms_deg']))"
done
"$saulctl" tune auto >live.txt 2>&1
check "without --sim: exit 0, the live plan printed, nothing sent (tune_auto_live.sh checks the robot)" test $? -eq 0
check "without --sim: it says nothing was sent" grep -q "^nothing sent: this is the plan only" live.txt

echo "$fails failed"
exit $((fails > 0))
