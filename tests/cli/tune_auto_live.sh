#!/usr/bin/env bash
# saulctl tune auto on a live robot (no --sim), against `saulctl sim`'s BALANCE console pty. Without --yes it prints
# the experiment (gains, excitation, amplitude, duration, limits) and sends nothing, exit 0. With --yes on a robot
# that is not armed in BALANCE it is refused (exit 1) and sends nothing: the sim's status afterwards shows no trace
# record sent, no excitation and its gains unchanged; so is --yes on a robot armed at the 10 % speed cap (BALANCE
# refuses a test signal below 50 %), with the way to raise it. Armed (the button on the control pty, the speed cap
# raised to 50 % first), --yes runs the plan: each set sent with 'pid' and acknowledged, printed as it is sent, a gain set
# proposed, and the robot's own gains restored and read back (its status shows them again). Ctrl-C (SIGINT) and kill
# (SIGTERM) in the middle of a set also restore them. Waits are on the simulator's own status or on saulctl's output,
# never on the wall clock alone (a loaded machine runs the simulator slower than real time). The simulator runs at 3x
# real time: a live trace's duration is on the robot's clock (its records' time), so each set still traces 10 s.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
sim=
trap '[[ -n $sim ]] && kill "$sim" 2>/dev/null; rm -rf "$work"' EXIT
cd "$work" || exit 1

# The simulator outlives the test (its ctest timeout is 900 s; the EXIT trap ends it): a loaded machine ran past 600 s.
"$saulctl" sim --quiet --speed 3 --paths-file paths --for 1000s >sim.log 2>&1 &
sim=$!
for _ in $(seq 200); do [[ -s paths ]] && break; sleep 0.05; done
balance=$(sed -n 's/^balance=//p' paths)
control=$(sed -n 's/^control=//p' paths)
check "saulctl sim gives a BALANCE console pty" test -n "$balance"
status() { timeout 10 "$saulctl" console "$balance" status 2>/dev/null | grep -a "^report=status"; }
gains() { status | sed -n 's/.* \(kp=[^ ]* ki=[^ ]* kd=[^ ]*\) .*/\1/p'; }

"$saulctl" tune auto --console-balance "$balance" >plan.txt 2>plan.err
check "without --yes: exit 0" test $? -eq 0
cat plan.txt
check "the plan names the robot's console" grep -q "^live plan (robot: BALANCE console $balance)" plan.txt
check "the plan gives the excitation, its amplitude and duration" \
  grep -q "excitation: chirp of 1 deg on the pitch setpoint, 0.5-15 Hz, 20 s per set" plan.txt
check "the plan gives the limits" grep -q "limits:     amplitude at most 2 deg and 20 s per excitation" plan.txt
check "it says nothing was sent" grep -q "^nothing sent: this is the plan only" plan.txt
check "no gains sent, proposed or applied" bash -c "! grep -Eq '^(sending|proposed|applied)' plan.txt"

"$saulctl" tune auto --console-balance "$balance" --yes >yes.txt 2>yes.err
check "--yes on a disarmed robot: refused, exit 1" test $? -eq 1
cat yes.err
check "... saying it is not armed in BALANCE, it never arms, nothing was sent" \
  grep -q "the robot is in OFF, not armed in BALANCE: arm it on its tether first (tune auto never arms it); nothing was sent" yes.err
check "... and nothing printed as sent" bash -c "! grep -q '^sending' yes.txt"
status >status.txt
cat status.txt
check "BALANCE answers its status" grep -aq "^report=status board=balance state=OFF" status.txt
timeout 10 "$saulctl" console "$balance" status >trace.txt 2>&1
check "no trace record was sent and no excitation runs" grep -aq "^report=trace divider=[0-9]* sent=0 .* excite=none" trace.txt
check "its gains are the shipped ones still" test "$(gains)" = "kp=100 ki=500 kd=3"

exec 3<>"$control"
upright() {  # disarmed, the body fell off balance: back on the bench stand, and the pitch followed
  printf 'upright\n' >&3
  for _ in $(seq 100); do
    pitch=$(status | sed -n 's/.* pitch_x100=-\{0,1\}\([0-9]*\) .*/\1/p')
    [[ -n $pitch && $pitch -le 300 ]] && break
    sleep 0.1
  done
}
# refused_at PCT WHAT LINE: console-armed at a PCT % cap outside the window a test signal needs, --yes is refused
# before anything is sent with LINE (naming the cap, the bound and the fix); then disarmed and set upright again.
refused_at() {
  timeout 10 "$saulctl" console "$balance" arm >"arm$1.txt" 2>&1
  check "console arm at the $1 % cap" grep -q "^ok" "arm$1.txt"
  "$saulctl" tune auto --console-balance "$balance" --yes >"refused$1.txt" 2>"refused$1.err"
  check "--yes at the $1 % cap: refused, exit 1" test $? -eq 1
  cat "refused$1.err"
  check "... one line naming the cap, the $2 and the fix, nothing sent" grep -qx -- "$3" "refused$1.err"
  check "... and nothing printed as sent" bash -c "! grep -q '^sending' refused$1.txt"
  timeout 10 "$saulctl" console "$balance" status >"trace$1.txt" 2>&1
  check "... no trace record sent, no excitation" grep -aq "^report=trace divider=[0-9]* sent=0 .* excite=none" "trace$1.txt"
  check "... its gains unchanged" test "$(gains)" = "kp=100 ki=500 kd=3"
  timeout 10 "$saulctl" console "$balance" disarm >/dev/null 2>&1
  upright
}
# BALANCE refuses a test signal below 50 % (the power-on cap is 10 %) and above 90 % (at the full cap the robot came
# back so hard that it fell).
refused_at 10 minimum "saulctl tune auto: $balance: the speed cap is 10 %, and BALANCE refuses a test signal below 50 %: disarm, then 'saulctl console $balance speed_limit 20', 30, 40, 50 (one 10 % step per command, only while disarmed), and arm again; nothing was sent"
for pct in 20 30 40 50 60 70 80 90 100; do timeout 10 "$saulctl" console "$balance" speed_limit $pct >/dev/null 2>&1; done
refused_at 100 maximum "saulctl tune auto: $balance: the speed cap is 100 %, and BALANCE refuses a test signal above 90 %: disarm, then 'saulctl console $balance speed_limit 90', arm again; nothing was sent"

# Arm it: the speed cap raised while disarmed (BALANCE refuses a test signal below 50 %), then the arming button.
for pct in 20 30 40 50; do timeout 10 "$saulctl" console "$balance" speed_limit $pct >/dev/null 2>&1; done
printf 'button down\n' >&3
for _ in $(seq 600); do status | grep -q "state=BALANCE" && break; sleep 0.1; done
printf 'button up\n' >&3
status >armed.txt
check "the simulated robot is armed in BALANCE with the cap at 50 %" grep -q "state=BALANCE .* speed_limit_pct=50" armed.txt

"$saulctl" tune auto --console-balance "$balance" --yes --duration 10s >run.txt 2>run.err
code=$?
cat run.txt run.err
check "--yes on the armed robot: gains proposed, exit 0 (got $code)" bash -c "test $code -eq 0 && grep -q '^proposed: Kp [0-9.]* Ki [0-9.]* Kd [0-9.]*' run.txt"
check "the robot's gains read first" grep -q "^the robot's gains: kp=100 ki=500 kd=3" run.txt
check "every set sent is printed and acknowledged (x1.2 at least)" grep -q "^sending: pid 120 600 3.6 (x1.2) ... acknowledged" run.txt
check "the robot's gains restored, read back" grep -q "^restored: the robot reports kp=100 ki=500 kd=3 again" run.txt
check "the sim's status shows its own gains again" test "$(gains)" = "kp=100 ki=500 kd=3"
check "the proposal is not applied" grep -q "^not applied: the robot runs its own gains again" run.txt

# Interrupted in the middle of a set (after x1.2 was acknowledged): the gains are restored all the same.
# A run can end by itself before x1.2 (a CI run measured x1.0's overshoot at 32.8 % instead of 12 %, the simulator
# starved beside two builds): that run says why, restores the gains, and the test starts another, three at most.
for signal in INT TERM; do
  for attempt in 1 2 3; do
    if ! status | grep -q "state=BALANCE"; then  # not armed any more (a latch, once, on a loaded machine): again
      status
      timeout 10 "$saulctl" console "$balance" disarm >/dev/null 2>&1
      upright
      printf 'button down\n' >&3
      for _ in $(seq 600); do status | grep -q "state=BALANCE" && break; sleep 0.1; done
      printf 'button up\n' >&3
    fi
    "$saulctl" tune auto --console-balance "$balance" --yes --duration 10s >sig.txt 2>sig.err &
    auto=$!
    for _ in $(seq 1200); do
      grep -q "(x1.2) ... acknowledged" sig.txt && break
      kill -0 "$auto" 2>/dev/null || break
      sleep 0.1
    done
    grep -q "(x1.2) ... acknowledged" sig.txt && break
    wait "$auto"
    echo "SIG$signal attempt $attempt: the run ended by itself (exit $?) before x1.2:"
    cat sig.txt sig.err
  done
  check "SIG$signal: the x1.2 set was sent and acknowledged" grep -q "^sending: pid 120 600 3.6 (x1.2) ... acknowledged" sig.txt
  kill -s "$signal" "$auto"
  wait "$auto"
  code=$?
  cat sig.txt sig.err
  check "SIG$signal: exit 1 (interrupted)" test $code -eq 1
  check "SIG$signal: the robot's gains restored, read back" grep -q "^restored: the robot reports kp=100 ki=500 kd=3 again" sig.txt
  check "SIG$signal: the sim's status shows its own gains again" test "$(gains)" = "kp=100 ki=500 kd=3"
done
exec 3>&-

"$saulctl" tune auto --console-balance "$balance" --yes --duration 5s >/dev/null 2>&1
check "--duration below 10 s: usage error (2)" test $? -eq 2
"$saulctl" tune auto --yes >/dev/null 2>noport.err
check "--yes without --console-balance: usage error (2)" test $? -eq 2

echo "$fails failed"
exit $((fails > 0))
