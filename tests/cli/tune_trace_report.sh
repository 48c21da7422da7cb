#!/usr/bin/env bash
# saulctl tune report reads a loop trace file (tune::read_trace_series): the issue's done-when, with 20 s instead of
# 10 s (tune record --sim --seed 2 --duration 20s --excite chirp, then tune report --json: the 8 s deconvolution
# windows want 20 s or more, docs/tuning.md), its keys and plausible figures
# for the shipped gains; a record cut out of the trace shows as a gap and one iteration missing by seq; a corrupt
# record is a problem naming its byte offset and the rest is still analysed.
set -uo pipefail
saulctl=$1
source "$(dirname "$0")/check.bash"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1

"$saulctl" tune record --sim --seed 2 --duration 20s --excite chirp -o a.trace && "$saulctl" tune report a.trace --json >a.json
check "the done-when command exits 0" test $? -eq 0
python3 - a.json <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print({k: v for k, v in j.items() if k not in ("spectra", "step")})
print({k: v for k, v in (j["step"] or {}).items() if not isinstance(v, list)})
for key in ("sample_rate_hz", "records", "gaps", "step", "oscillation", "saturation_pct", "loop_period_us", "seq_missing"):
    assert key in j, key
assert j["source"] == "loop_trace", j["source"]
assert abs(j["sample_rate_hz"] - 1000) < 1, j["sample_rate_hz"]
assert j["records"] >= 19990 and j["gaps"] == 0 and j["seq_missing"] == 0 and j["problems_total"] == 0
assert set(j["loop_period_us"]) >= {"p50", "p99", "max"} and abs(j["loop_period_us"]["p50"] - 1000) < 1
s = j["step"]
assert s is not None, j.get("step_reason")
for key in ("overshoot_pct", "rise_time_s", "settling_time_s", "windows_used"):
    assert key in s, key
assert s["windows_used"] >= 10, s["windows_used"]          # 8 s windows every 0.5 s over 20 s
assert 0 <= s["overshoot_pct"] < 60, s["overshoot_pct"]      # the shipped gains balance: damped, not ringing
assert 0.01 < s["rise_time_s"] < 0.5 and 0.02 < s["settling_time_s"] < 1.0, s
assert 0 <= j["saturation_pct"] < 5 and j["oscillation"] is None
PY
check "JSON keys and plausible figures (1 kHz, 0 gaps, a step response from >= 10 windows)" test $? -eq 0

# The steady error's verdict (docs/tuning.md "The steady error"): the shipped gains end ~20 % past the setpoint (the
# held lean accelerates the robot; the I term follows the output's ramp with an error of ramp / Ki): told as that, not
# "more Ki". No I term at all (Ki 0) is a real Ki problem: on seeds 2-4 the robot falls and the text says "more Ki".
# (Seed 1, since BALANCE's drive model follows the SET_RPM the VESCs got, balances 20-30 s on P and D alone, its
# steps before the fall ending x1.32 past the setpoint, inside the held lean's "ok": told as a fall only.)
"$saulctl" tune report a.trace >a.txt
check "shipped gains: the steady error is told as pitch past the setpoint, ok, no 'more Ki'" \
  bash -c "grep 'steady error' a.txt && grep -q 'steady error .*past the setpoint.* ok\$' a.txt && ! grep -q 'more Ki' a.txt"
for seed in 2 3 4; do
  "$saulctl" tune record --sim --seed $seed --gains 100 0 3 --duration 20s --excite step -o ki0.trace >/dev/null 2>&1
  "$saulctl" tune report ki0.trace >ki0.txt
  check "Ki 0 (seed $seed): a fall and a steady error judged CHECK (more Ki)" \
    bash -c "grep -q 'falls .* CHECK' ki0.txt && grep 'steady error.*CHECK.*(more Ki)' ki0.txt"
done

# Cut one whole record out (a USB packet lost): a gap of 2 ms and one iteration missing by seq.
python3 - a.trace cut.trace bad.trace <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
starts = [i for i in range(len(data) - 2) if data[i] == 0xAA and data[i + 1] == 0x23 and data[i + 2] == 0x20]
open(sys.argv[2], "wb").write(bytes(data[:starts[5000]] + data[starts[5001]:]))
data[starts[3000] + 10] ^= 0x40
open(sys.argv[3], "wb").write(bytes(data))
print("corrupt record at byte", starts[3000])
PY
"$saulctl" tune report cut.trace --json >cut.json
check "a cut record: gaps 1, seq_missing 1" python3 -c "
import json,sys; j=json.load(open('cut.json')); print(j['gaps'], j['seq_missing'], j['gap_list']); sys.exit(not (j['gaps']==1 and j['seq_missing']==1))"
"$saulctl" tune report bad.trace --json >bad.json
check "a corrupt record: a problem naming its byte offset, the rest analysed" python3 -c "
import json,sys; j=json.load(open('bad.json')); print(j['problems']); sys.exit(not (any('bad.trace: byte ' in p and 'corrupt' in p for p in j['problems']) and j['records']>=19980 and j['step'] is not None))"
"$saulctl" tune report bad.trace >bad.txt
check "the text report tells the corrupt record too" grep -q "byte [0-9]*: a corrupt or cut record" bad.txt

# --gains: the simulated robot runs the gain set asked for (soft and stiff give different figures from the same seed).
"$saulctl" tune record --sim --seed 1 --gains 70 350 2 --duration 20s --excite chirp -o soft.trace >/dev/null &&
  "$saulctl" tune record --sim --seed 1 --gains 140 700 4 --duration 20s --excite chirp -o stiff.trace >/dev/null
check "tune record --sim --gains records (soft and stiff)" test $? -eq 0
"$saulctl" tune report soft.trace --json >soft.json && "$saulctl" tune report stiff.trace --json >stiff.json
check "the stiffer set rises faster (soft rise > 1.5 x stiff's)" python3 -c "
import json,sys; a=json.load(open('soft.json'))['step']; b=json.load(open('stiff.json'))['step']
print(a['rise_time_s'], b['rise_time_s']); sys.exit(not a['rise_time_s'] > 1.5 * b['rise_time_s'])"
"$saulctl" tune record --console-balance /dev/null --gains 1 2 3 -o x.trace >/dev/null 2>&1
check "--gains without --sim: usage error (2)" test $? -eq 2
"$saulctl" tune record --sim --gains 1 2 -o x.trace >/dev/null 2>&1
check "--gains with two numbers: usage error (2)" test $? -eq 2

echo "$fails failed"
exit $((fails > 0))
