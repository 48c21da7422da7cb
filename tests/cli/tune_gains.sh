#!/usr/bin/env bash
# The gains each trace ran with: tune record asks BALANCE's status before switching the trace on, so the file holds
# the board's own "report=status ... kp= ki= kd=" line (docs/captures.md, "Loop traces"); tune report shows them
# (text, and --json "gains": {kp, ki, kd}), tune compare side by side. Two gain sets recorded on the simulated robot
# with --gains; a trace without the status line (as recorded before) still reads, with "gains": null.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1

"$saulctl" tune record --sim --seed 2 --duration 10s --excite chirp -o shipped.trace >/dev/null &&
  "$saulctl" tune record --sim --seed 2 --duration 10s --excite chirp --gains 140 700 4.5 -o stiff.trace >/dev/null
check "two gain sets recorded" test $? -eq 0
check "the file holds BALANCE's status line with the gains" grep -aq "report=status .*kp=140 ki=700 kd=4.5 " stiff.trace

"$saulctl" tune report stiff.trace >stiff.txt
check "tune report names the gains" grep -q "^stiff.trace: .* gains kp=140 ki=700 kd=4.5$" stiff.txt
"$saulctl" tune report shipped.trace --json >shipped.json
check "tune report --json: gains {kp, ki, kd} (the simulator's shipped 100 500 3)" python3 -c "
import json,sys; g=json.load(open('shipped.json'))['gains']; print(g); sys.exit(g != {'kp': 100, 'ki': 500, 'kd': 3})"

"$saulctl" tune compare shipped.trace stiff.trace >cmp.txt
cat cmp.txt
check "compare: both gain sets side by side" python3 -c "
import sys; rows={l.split()[0]: l.split()[1:] for l in open('cmp.txt') if l.strip()}
sys.exit(not (rows.get('kp') == ['100.000', '140.000'] and rows.get('ki') == ['500.000', '700.000']
              and rows.get('kd') == ['3.000', '4.500']))"
"$saulctl" tune compare --json shipped.trace stiff.trace >cmp.json
check "compare --json: each report's gains" python3 -c "
import json,sys; a=json.load(open('cmp.json')); print([r['gains'] for r in a])
sys.exit([r['gains']['kp'] for r in a] != [100, 140])"

# A trace as recorded before the status line (the same bytes without it) reads as before, its gains unknown.
python3 -c "
import re; b=open('stiff.trace','rb').read(); open('old.trace','wb').write(re.sub(rb'report=status[^\n]*\n', b'', b))"
check "the old-style trace has no status line" bash -c "! grep -aq report=status old.trace"
"$saulctl" tune report old.trace --json >old.json
check "an old trace still reads: same records, gains null" python3 -c "
import json,sys; o=json.load(open('old.json'))
print(o['gains'], o['records']); sys.exit(not (o['gains'] is None and o['records'] == 10000))"
"$saulctl" tune report old.trace >old.txt
check "... and the text says the gains are not given" grep -q "gains not given" old.txt

echo "$fails failed"
exit $((fails > 0))
