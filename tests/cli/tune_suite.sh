#!/usr/bin/env bash
# Bench suites asserting tuning figures (docs/bench-tests.md, "Tuning figures"): `trace chirp 1 for 20s` then
# `expect tune ...` on the simulated robot. A limit the shipped gains cannot meet fails the suite with the figure, its
# measured value and the limit; the figures are the ones `tune record --sim` + `tune report --json` find in the same
# run (the suite arms on the same simulated schedule, 20 ms for the status reply included, so the traces are the same); a wrong unit or an unknown figure is
# a suite error (exit 2) naming it; `expect tune` without a trace fails, and so does a trace whose test signal BALANCE
# refuses (the 10 % cap). The shipped suite also passes over a running
# `saulctl sim`'s ptys (the trace read from the BALANCE console port, as from the robot).
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1

suite() {  # NAME EXPECT-LINE: armed on tune record --sim's schedule, a 20 s 1 deg chirp, then the expectation
  printf 'requires: sim\nsim type balance speed_limit 20\nsim type balance speed_limit 30\nsim type balance speed_limit 40\nsim type balance speed_limit 50\nwait 1500ms\nsim button down\nwait 3200ms\nsim button up\nwait 2520ms\ntrace chirp 1 for 20s\n%s\n' "$2" >"$1"
}

suite pass.saul "expect tune overshoot<25% settling<1.2s rise<200ms delay<100ms oscillation=none saturation<5% falls=0"
"$saulctl" test --sim --seed 2 pass.saul >pass.txt
check "limits the shipped gains meet pass (exit 0)" test $? -eq 0

suite tight.saul "expect tune settling<2s overshoot<0.1%"
"$saulctl" test --sim --seed 2 tight.saul --junit tight.xml >tight.txt
check "overshoot<0.1% fails the suite (exit 1)" test $? -eq 1
cat tight.txt
check "the failure names the figure, its value and the limit" \
  grep -Eq "FAIL .*tight.saul:12 expect tune .* -> overshoot [0-9.]+ % breaks overshoot<0.1%" tight.txt
check "the JUnit report has the failure" grep -q '<failure message="overshoot [0-9.]* % breaks overshoot&lt;0.1%' tight.xml

# The same figures from outside the suite engine: tune record + tune report on the same seed and schedule.
"$saulctl" tune record --sim --seed 2 --duration 20s --excite chirp --amplitude 1 -o run.trace >/dev/null &&
  "$saulctl" tune report run.trace --json >run.json
check "tune record + report of the same run" test $? -eq 0
measured=$(sed -n 's/.*-> overshoot \([0-9.]*\) % breaks.*/\1/p' tight.txt)
check "the suite's overshoot ($measured %) is tune report's" python3 -c "
import json,sys; j=json.load(open('run.json')); o=j['step']['overshoot_pct']; print(o)
sys.exit(not abs(o - float('$measured')) <= 0.005 * max(1, abs(o)))"

suite settle.saul "expect tune settling<=10ms"
"$saulctl" test --sim --seed 2 settle.saul >settle.txt
check "settling<=10ms fails, naming settling" grep -Eq -- "-> settling [0-9.]+ s breaks settling<=0.01s" settle.txt

suite osc.saul "expect tune oscillation!=none"
"$saulctl" test --sim --seed 2 osc.saul >osc.txt
check "oscillation!=none fails when none is found" grep -q -- "-> oscillation none breaks oscillation!=none" osc.txt

suite unit.saul "expect tune overshoot<0.6s"
"$saulctl" test --sim unit.saul >unit.txt 2>unit.err
check "a wrong unit is a suite error (exit 2)" test $? -eq 2
check "... naming the figure's unit" grep -q "unit.saul:12: 'overshoot<0.6s': overshoot is in %, not s" unit.err

suite name.saul "expect tune wobble<3"
"$saulctl" test --sim name.saul >name.txt 2>name.err
check "an unknown figure is a suite error naming the figures" grep -q "no tuning figure 'wobble' (overshoot, rise" name.err

# At the power-on 10 % cap BALANCE refuses the test signal: the trace step fails with its reason and the fix.
printf 'requires: sim\nwait 1500ms\nsim button down\nwait 3200ms\nsim button up\nwait 2520ms\ntrace step 1 for 2s\n' >low.saul
"$saulctl" test --sim --seed 2 low.saul >low.txt
check "a test signal at the 10 % cap fails the trace step (exit 1)" test $? -eq 1
cat low.txt
check "... with BALANCE's refusal and how to raise the cap" grep -q "trace step 1 for 2s .*BALANCE refused: error: excite needs the speed cap >= 50 % (speed_limit is 10 %: .*(raise the cap before arming: 'console balance speed_limit 20 expect ok', then 30, 40 ... 50)" low.txt

printf 'requires: sim\nexpect tune overshoot<25%%\n' >none.saul
"$saulctl" test --sim none.saul >none.txt
check "expect tune without a trace fails" grep -q "no trace to judge" none.txt

# The same suite over a running `saulctl sim`'s ptys, in real time (about 30 s): the trace comes through the BALANCE
# console port the way it would from the robot's USB console (LiveTarget::console_take).
# Known weakness (issue 36's note): on a loaded machine the live figures vary from run to run (overshoot 6 % to 79 %
# seen with two CPU hogs beside ctest -j2; the in-process run above is exact): up to three fresh simulators, each
# attempt printed; the check passes when one attempt passes.
for attempt in 1 2 3; do
  rm -f paths
  "$saulctl" sim --quiet --paths-file paths --for 90s >sim.log 2>&1 &
  sim=$!
  for _ in $(seq 200); do [[ -s paths ]] && break; sleep 0.05; done
  "$saulctl" test --link "slcan:$(sed -n 's/^can=//p' paths)" --console-balance "$(sed -n 's/^balance=//p' paths)" \
    --sim-control "$(sed -n 's/^control=//p' paths)" "$2/tests/suites/tune_figures.saul" >live.txt 2>&1
  status=$?
  kill "$sim" 2>/dev/null; wait "$sim" 2>/dev/null
  echo "live attempt $attempt: exit $status"
  [[ $status -eq 0 ]] && break
  cat live.txt
done
check "live (saulctl sim's ptys): tests/suites/tune_figures.saul passes" test $status -eq 0
records=$(sed -n 's/.*trace chirp 1 for 20s  -> \([0-9]*\) records at.*/\1/p' live.txt)
check "live: the 20 s trace came through the console port (${records:-no} records)" test "${records:-0}" -ge 18000

echo "$fails failed"
exit $((fails > 0))
