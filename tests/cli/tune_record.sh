#!/usr/bin/env bash
# saulctl tune record --sim: a loop trace of the simulated robot on simulated time, the issue's done-when: 10 s with a
# chirp at 1 degree gives >= 9990 records and 0 gaps at 1 kHz in `saulctl stats`; decode, convert (CSV, the column
# names the tune analysis reads) and stats --json read it; a corrupt record is reported with its byte offset and the
# rest is read; --dump brings the flight recorder's 5 s before a tilt cutoff; refusals and usage errors.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
sim=""
trap '[[ -n $sim ]] && kill "$sim" 2>/dev/null; rm -rf "$work"' EXIT

"$saulctl" tune record --sim --seed 3 --duration 10s --excite chirp --amplitude 1 -o "$work/run.trace" >"$work/rec" 2>&1
check "tune record --sim exits 0" test $? -eq 0
cat "$work/rec"
check "it says what it recorded and why it stopped" grep -q "^stopped: duration" "$work/rec"
check "it says how much faster than real time" grep -q "x real time)" "$work/rec"
check "the file starts with its header" test "$(head -c 12 "$work/run.trace")" = "SAULTRACE 1"
"$saulctl" stats "$work/run.trace" >"$work/stats" 2>&1
cat "$work/stats"
records=$(sed -n 's/.*loop trace, \([0-9]*\) records over.*/\1/p' "$work/stats")
check ">= 9990 records (got ${records:-none})" test "${records:-0}" -ge 9990
check "0 gaps" grep -q "^gaps: 0 (0 records missing)" "$work/stats"
check "at 1 kHz, every loop" grep -Eq "\((999\.[5-9]|1000\.[0-4]) Hz, every 1 loop\)" "$work/stats"
check "the chirp is marked in the records" grep -Eq "records with an excitation: (99[0-9][0-9]|[1-9][0-9]{4})" "$work/stats"
"$saulctl" stats --json "$work/run.trace" >"$work/stats.json"
check "stats --json: gaps 0" python3 -c "import json,sys; j=json.load(open(sys.argv[1])); sys.exit(j['gaps']!=0 or j['records']<9990)" "$work/stats.json"

"$saulctl" convert "$work/run.trace" "$work/run.csv" 2>"$work/conv"
check "convert writes a CSV" test -s "$work/run.csv"
check "CSV columns as the tune analysis reads them" test "$(head -1 "$work/run.csv")" = \
  "time_s,seq,pitch_deg,rate_dps,setpoint_deg,p_term,i_term,d_term,output,erpm_left,erpm_right,wheel_mmps,request_mmps,state,faults,excite,excite_deg"
check "one CSV row per record" test "$(($(wc -l <"$work/run.csv") - 1))" = "$records"
check "the CSV's excitation stays within 1 degree and is a chirp (2)" python3 - "$work/run.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
ex = [float(r["excite_deg"]) for r in rows if r["excite"] == "2"]
sys.exit(not (len(ex) > 9000 and max(abs(x) for x in ex) <= 1.0 and max(ex) > 0.99 and min(ex) < -0.99))
PY
"$saulctl" decode --json "$work/run.trace" | head -3 >"$work/dec.json"
check "decode --json: physical units, state by name" python3 -c "
import json,sys
for l in open(sys.argv[1]):
    j=json.loads(l); assert j['state']=='BALANCE' and 'pitch_deg' in j and j['excite']=='chirp', j" "$work/dec.json"
"$saulctl" decode "$work/run.trace" | head -2 >"$work/dec.txt"
check "decode: one line per record" grep -q "seq .* pitch .* deg" "$work/dec.txt"

"$saulctl" plot "$work/run.trace" -o "$work/run.html" 2>"$work/plot.err"
check "plot draws the trace's panels (html page)" grep -q "pitch \[deg\]" "$work/run.html"

# Corruption: flip a byte inside the 100th record (after the header and the "ok" lines), cut the file short.
python3 - "$work/run.trace" "$work/bad.trace" <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
starts = [i for i in range(len(data) - 2) if data[i] == 0xAA and data[i + 1] == 0x23 and data[i + 2] == 0x20]
data[starts[100] + 10] ^= 0x40
open(sys.argv[2], "wb").write(bytes(data[:-20]))
print(starts[100])
PY
"$saulctl" stats "$work/bad.trace" >"$work/bad" 2>"$work/bad.err"
cat "$work/bad.err"
check "a corrupt record is reported with its byte offset" grep -q "corrupt record at byte [0-9]* (bad_crc); the rest is read" "$work/bad.err"
check "the cut record at the end too" grep -q "(truncated)" "$work/bad.err"
check "the rest is read: 2 records fewer" grep -q "loop trace, $((records - 2)) records" "$work/bad"
check "and the lost record shows as a gap" grep -q "^gaps: 1 (1 records missing)" "$work/bad"

# A direct step test (--excite step) meets BALANCE's 10 ms SET_RPM period at every phase: each step starts 1 ms
# later in it than the one before (steps a whole number of periods apart all met it at one phase, and the averaged
# response was that phase's: docs/tuning.md, "Estimate and direct step").
"$saulctl" tune record --sim --seed 3 --duration 56s --excite step --amplitude 1 -o "$work/step.trace" >"$work/steprec" 2>&1
check "tune record --excite step exits 0" test $? -eq 0
"$saulctl" convert "$work/step.trace" "$work/step.csv" 2>/dev/null
check "--excite step: 10 steps whose starts fall on every millisecond of the 10 ms motor-command period" \
  python3 - "$work/step.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
starts = [round(float(b["time_s"]) * 1000) for a, b in zip(rows, rows[1:]) if a["excite"] == "0" and b["excite"] != "0"]
phases = sorted({(t - starts[0]) % 10 for t in starts})
print("steps start at (ms)", starts, "phases in the 10 ms period", phases)
sys.exit(not (len(starts) >= 10 and phases == list(range(10))))
PY

"$saulctl" tune record --sim --seed 3 --duration 2s --dump -o "$work/dump.trace" >"$work/dump" 2>&1
cat "$work/dump"
check "--dump: the flight recorder's 5000 records" grep -q "^flight recorder: 5000 records" "$work/dump"
"$saulctl" decode "$work/dump.trace" 2>/dev/null | grep -c "TILT_CUTOFF" >"$work/tilt" || true
check "the dump ends at the tilt cutoff" test "$(cat "$work/tilt")" -ge 1

# Live: `saulctl sim` streams the trace on its BALANCE console pty (trace on works in any state), here at 3x real
# time: a live trace's duration is on the robot's clock (its records' time), so 2 s is 2 s of records, not 6.
# The simulator runs until killed below (--for only bounds a test that died): under load the recordings take longer.
"$saulctl" sim --quiet --speed 3 --paths-file "$work/paths" --for 900s >"$work/sim.log" 2>&1 &
sim=$!
for _ in $(seq 200); do [[ -s $work/paths ]] && break; sleep 0.05; done
balance=$(sed -n 's/^balance=//p' "$work/paths")
"$saulctl" tune record --console-balance "$balance" --duration 2s -o "$work/live.trace" >"$work/live" 2>&1
check "live: the recording ends well" test $? -eq 0
cat "$work/live"
"$saulctl" stats "$work/live.trace" >"$work/live.stats" 2>&1
covered=$(sed -n 's/.* records over \([0-9.]*\) s .*/\1/p' "$work/live.stats")
check "live: 2 s on the robot's clock from a simulator at 3x real time (covered: $covered s)" \
  awk -v c="$covered" 'BEGIN { exit !(c >= 1.99 && c <= 2.2) }'
"$saulctl" tune record --console-balance "$balance" --duration 1s --excite step -o "$work/r.trace" >"$work/ref" 2>&1
check "live: excite outside BALANCE is refused, exit 1" test $? -eq 1
cat "$work/ref"
check "live: the refusal says why" grep -q "^stopped: BALANCE refused: error: excite runs only in BALANCE" "$work/ref"
# Beside another saulctl on the same port (the shared serial link): console's status gets its reply, the trace no gap.
"$saulctl" tune record --console-balance "$balance" --duration 9s -o "$work/shared.trace" >"$work/shared" 2>&1 &
rec=$!
sleep 1
timeout 10 "$saulctl" console "$balance" status >"$work/con" 2>&1
check "shared: saulctl console gets its reply while the trace records" grep -aq "^report=status board=balance" "$work/con"
wait "$rec"
check "shared: the recording ends well" test $? -eq 0
"$saulctl" stats "$work/shared.trace" >"$work/shared.stats" 2>&1
check "shared: 0 gaps" grep -q "^gaps: 0 (0 records missing)" "$work/shared.stats"
kill "$sim" 2>/dev/null; wait "$sim" 2>/dev/null

# The flight recorder live: `saulctl sim` armed by the button on its control pty, tilted beyond the cutoff, then
# `tune record --dump` on its BALANCE pty brings the 5 s before the latch.
"$saulctl" sim --quiet --paths-file "$work/paths2" --for 300s >"$work/sim2.log" 2>&1 &
sim=$!
for _ in $(seq 200); do [[ -s $work/paths2 ]] && break; sleep 0.05; done
balance=$(sed -n 's/^balance=//p' "$work/paths2")
control=$(sed -n 's/^control=//p' "$work/paths2")
# Waits on the simulator's own clock and state (its BALANCE console's status line), not on the wall clock: a
# loaded machine runs the simulator slower than real time.
status_field() { timeout 10 "$saulctl" console "$balance" status 2>/dev/null | sed -n "s/^report=status .*\<$1=\([^ ]*\).*/\1/p"; }
wait_for() {  # wait_for FIELD VALUE|">=N": up to 120 s
  for _ in $(seq 1200); do
    v=$(status_field "$1")
    if [[ $2 == ">="* ]]; then [[ -n $v && $v -ge ${2#>=} ]] && return 0; else [[ $v == "$2" ]] && return 0; fi
    sleep 0.1
  done
  echo "timed out waiting for $1 $2 (last: $v)"; return 1
}
exec 3<>"$control"
printf 'button down\n' >&3; wait_for state BALANCE; printf 'button up\n' >&3
armed_ms=$(status_field uptime_ms)
wait_for uptime_ms ">=$((armed_ms + 6000))"; printf 'tilt 40\n' >&3; wait_for state TILT_CUTOFF
"$saulctl" tune record --console-balance "$balance" --dump -o "$work/livedump.trace" >"$work/livedump" 2>&1
check "live --dump exits 0" test $? -eq 0
exec 3>&-
kill "$sim" 2>/dev/null; wait "$sim" 2>/dev/null
cat "$work/livedump"
"$saulctl" stats "$work/livedump.trace" >"$work/livedump.stats" 2>&1
cat "$work/livedump.stats"
check "live --dump: 5000 records" grep -q "loop trace, 5000 records" "$work/livedump.stats"
check "live --dump: 0 gaps" grep -q "^gaps: 0 (0 records missing)" "$work/livedump.stats"
check "live --dump: the 5 s of BALANCE and the latch's own loop" grep -q "^states: BALANCE 4999 TILT_CUTOFF 1;" "$work/livedump.stats"
"$saulctl" stats "$work/live.trace" >"$work/live.stats" 2>&1
cat "$work/live.stats"
live=$(sed -n 's/.*loop trace, \([0-9]*\) records over.*/\1/p' "$work/live.stats")
check "live from the sim's pty: about 2 s of records (got ${live:-none})" test "${live:-0}" -ge 1500
check "live: 0 gaps" grep -q "^gaps: 0 (0 records missing)" "$work/live.stats"

"$saulctl" tune record --duration 1s -o "$work/x.trace" >/dev/null 2>&1
check "no --sim and no port: usage error (2)" test $? -eq 2
"$saulctl" tune record --sim --amplitude 3 --excite step -o "$work/x.trace" >/dev/null 2>&1
check "--amplitude 3: usage error (2)" test $? -eq 2
"$saulctl" stats "$work/dec.txt" >/dev/null 2>&1
check "stats of a non-trace still goes its own way (not a trace)" test $? -ne 0
echo "$fails failed"
exit $((fails > 0))
