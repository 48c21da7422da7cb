#!/usr/bin/python3
"""The step response estimated from an excitation trace against the one measured by a direct step test (issue 36):
on the simulated robot (simulated time, no sleeps), for three gain sets and seeds 1-5, `saulctl tune record --sim`
records a chirp trace and a step trace with the same gains; `tune report` estimates the step response from the
chirp by deconvolution (`step`) and measures it at the steps of the other trace (`step_direct`). The overshoot
must agree within 5 percentage points in all 15 cases; the settling time within 15 % in at least 12 of them and
within 30 % in all (measured: 13 of 15 within 15 %, the others 16-17 % off; settling is the fragile figure, the
last crossing of a 5 % band around a response that creeps for seconds: docs/tuning.md). Both see
the pitch loop alone: while a test signal runs BALANCE holds the speed loop's lean (docs/tuning.md, "Estimate and
direct step").
Run: /usr/bin/python3 tests/tune/check_sim_agreement.py SAULCTL [--table]
For experiments (docs/tuning.md, "The chirp's band"): AGREE_SEEDS="1 2 ... 15" other seeds, AGREE_F0 / AGREE_F1 the
chirp's band, AGREE_KIND / AGREE_AMPLITUDE the signal; the settling share asserted is then 12/15 of the cases."""
import atexit
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

SAULCTL = sys.argv[1]
TMP = tempfile.mkdtemp(prefix="tune_agree_")
atexit.register(shutil.rmtree, TMP, ignore_errors=True)

GAINS = {"soft": ["70", "350", "2"], "shipped": [], "stiff": ["140", "700", "4"]}  # shipped: the sim's 100 500 3
SEEDS = [int(seed) for seed in os.environ.get("AGREE_SEEDS", "1 2 3 4 5").split()]
OVERSHOOT_POINTS = 5.0
SETTLING_SHARE = 0.15  # in at least SETTLING_AGREE of every 15 cases ...
SETTLING_AGREE = 12
SETTLING_WORST = 0.30  # ... and within this in all
FINAL_SHARE = 0.02  # the direct step's final value against the held lean's closed form (measured: within 1.2 %)
KIND, AMPLITUDE = os.environ.get("AGREE_KIND", "chirp"), os.environ.get("AGREE_AMPLITUDE", "1")
BAND = [arg for name in ("f0", "f1") if f"AGREE_{name.upper()}" in os.environ
        for arg in (f"--{name}", os.environ[f"AGREE_{name.upper()}"])]  # the chirp's band; tune record's default


def record(name, gains, seed, duration, *excite):
    path = f"{TMP}/{name}.trace"
    cmd = [SAULCTL, "tune", "record", "--sim", "--seed", str(seed), "--duration", duration, "-o", path, *excite]
    if gains:
        cmd += ["--gains", *gains]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"FAIL {' '.join(cmd)}: {p.stdout}{p.stderr}")
    p = subprocess.run([SAULCTL, "tune", "report", "--json", path], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"FAIL tune report {path}: {p.stderr}")
    return json.loads(p.stdout)


agreed = hard_fails = 0
rows = []
for label, gains in GAINS.items():
    for seed in SEEDS:
        chirp = record(f"{label}_{seed}_{KIND}", gains, seed, "120s", "--excite", KIND, "--amplitude", AMPLITUDE, *BAND)
        step = record(f"{label}_{seed}_step", gains, seed, "120s", "--excite", "step", "--amplitude", "1")
        est, direct = chirp["step"], step["step_direct"]
        what = f"{label} seed {seed}"
        if est is None or direct is None:
            print(f"FAIL {what}: estimate {chirp.get('step_reason')}, direct {step.get('step_direct_reason')}")
            hard_fails += 1
            continue
        # The direct step against the closed form of the held lean (docs/tuning.md, "The steady error"): pitch /
        # setpoint settles at Ki / (Ki - c), c = 1000 g (pi / 180) / 2.0 m/s permille/s per degree.
        ki = float((gains or ["100", "500", "3"])[1])
        closed = ki / (ki - 1000 * 9.80665 * math.pi / 180 / 2.0)
        if abs(direct["final_value"] / closed - 1) > FINAL_SHARE:
            print(f"FAIL {what}: direct final value {direct['final_value']} not within {100 * FINAL_SHARE:g} % of "
                  f"Ki / (Ki - c) = {closed:.4f}")
            hard_fails += 1
        d_os = est["overshoot_pct"] - direct["overshoot_pct"]
        es, ds = est["settling_time_s"], direct["settling_time_s"]
        d_set = None if es is None or ds is None else (es - ds) / ds
        ok = abs(d_os) <= OVERSHOOT_POINTS and d_set is not None and abs(d_set) <= SETTLING_SHARE
        hard_fail = abs(d_os) > OVERSHOOT_POINTS or d_set is None or abs(d_set) > SETTLING_WORST
        agreed += 1 if ok else 0
        hard_fails += 1 if hard_fail else 0
        rows.append((what, est, direct, d_os, d_set, ok))
        print(f"{'ok  ' if ok else 'FAIL'} {what}: overshoot {est['overshoot_pct']:.1f} % estimated "
              f"({est['windows_used']} windows) vs {direct['overshoot_pct']:.1f} % direct ({direct['steps']} steps), "
              f"{d_os:+.1f} points; settling {es} s vs {ds} s; final value {est['final_value']} vs {direct['final_value']} "
              f"(closed form {closed:.3f})"
              + ("" if d_set is None else f", {100 * d_set:+.0f} %"))

if "--table" in sys.argv:  # the table of docs/tuning.md
    print("\n| gains | seed | overshoot est. | direct | settling est. | direct |\n|---|---|---|---|---|---|")
    for what, est, direct, d_os, d_set, ok in rows:
        label, _, seed = what.split()
        print(f"| {label} | {seed} | {est['overshoot_pct']:.1f} % | {direct['overshoot_pct']:.1f} % | "
              f"{est['settling_time_s']:.3f} s | {direct['settling_time_s']:.3f} s |")
print(f"{agreed} of {len(GAINS) * len(SEEDS)} agree within {OVERSHOOT_POINTS:g} points and {100 * SETTLING_SHARE:g} %; "
      f"{hard_fails} beyond {OVERSHOOT_POINTS:g} points or {100 * SETTLING_WORST:g} %")
sys.exit(1 if hard_fails or agreed * 15 < SETTLING_AGREE * len(GAINS) * len(SEEDS) else 0)
