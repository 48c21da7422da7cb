#!/usr/bin/python3
"""The step response estimated from an excitation trace against the one measured by a direct step test (issue 36):
on the simulated robot (simulated time, no sleeps), for three gain sets and seeds 1-5, `saulctl tune record --sim`
records a chirp trace and a step trace with the same gains; `tune report` estimates the step response from the
chirp by deconvolution (`step`) and measures it at the steps of the other trace (`step_direct`). The overshoot
must agree within 5 percentage points in all 15 cases; the settling time within 15 % in at least 14 of them and
within 20 % in all (measured: overshoot 0.1-3.6 points apart, settling 14 of 15 within 12 %, soft seed 1 +18 %;
settling is the fragile figure, the last crossing of a 5 % band around a response that creeps for seconds:
docs/tuning.md). Both see the pitch loop alone: while a test signal runs BALANCE holds the speed loop's lean
(docs/tuning.md, "Estimate and direct step"). What makes the two comparable (docs/tuning.md, "Where the difference
was"): the direct steps meet BALANCE's 10 ms motor command at every phase (tune record: 1 ms later each), BALANCE's
drive model follows the command the VESCs got, and the chirps are 5 s apart (the speed loop's return from half the
cap settled, not saturated). Without any one of them this check fails (13, 13, 10 of 15 agree, and cases beyond 5
points or 20 %).
Run: /usr/bin/python3 tests/tune/check_sim_agreement.py SAULCTL [--table]
The first seed of each gain set also checks the estimator alone: the chirp trace's setpoint through the direct step's impulse response (a
linear system whose step response is known: the direct step's, figures worked out here at the sim's 1 ms), noise
added, estimated by saulctl: overshoot within 2 points, rise 5 %, settling 10 %, final value 3 % (measured: 0.1-0.9
points low, rise within 1 %, settling 2-6 % short, final within 0.6 %). So a miss above is the simulated robot
answering a chirp differently from a step, not the estimator (docs/tuning.md, "Where the difference was"); and the
sample period 10 % off (SAUL_TUNE_MUTANT 1), which scales both sides of the comparison alike, fails every case here.
For experiments (docs/tuning.md, "The chirp's band"): AGREE_SEEDS="1 2 ... 15" other seeds, AGREE_F0 / AGREE_F1 the
chirp's band, AGREE_KIND / AGREE_AMPLITUDE the signal; the settling share asserted is then 14/15 of the cases."""
import atexit
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import scipy.signal as sg

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import traces  # noqa: E402

SAULCTL = sys.argv[1]
TMP = tempfile.mkdtemp(prefix="tune_agree_")
atexit.register(shutil.rmtree, TMP, ignore_errors=True)

GAINS = {"soft": ["70", "350", "2"], "shipped": [], "stiff": ["140", "700", "4"]}  # shipped: the sim's 100 500 3
SEEDS = [int(seed) for seed in os.environ.get("AGREE_SEEDS", "1 2 3 4 5").split()]
OVERSHOOT_POINTS = 5.0
SETTLING_SHARE = 0.15  # in at least SETTLING_AGREE of every 15 cases ...
SETTLING_AGREE = 14
SETTLING_WORST = 0.20  # ... and within this in all
# The estimator alone (below): the chirp trace's own setpoint through the direct step's impulse response, noise
# added, estimated again. Measured on seeds 1-5: overshoot 0.3-1.0 points low, rise within 3 %, settling 2-7 % short,
# final value 1-2 % high (the bins above the chirp's 15 Hz are regularised to 0).
LTI_POINTS, LTI_RISE, LTI_SETTLING, LTI_FINAL, LTI_NOISE_DEG = 2.0, 0.05, 0.10, 0.03, 0.02
# The direct step's final value against the held lean's closed form (measured: within 3.1 %; the soft set still
# creeps at 1.5 s and its mean over 13-19 steps moves by a few % with the steps' phases, seeds 6-15 up to 3.3 %).
FINAL_SHARE = 0.035
KIND, AMPLITUDE = os.environ.get("AGREE_KIND", "chirp"), os.environ.get("AGREE_AMPLITUDE", "1")
BAND = [arg for name in ("f0", "f1") if f"AGREE_{name.upper()}" in os.environ
        for arg in (f"--{name}", os.environ[f"AGREE_{name.upper()}"])]  # the chirp's band; tune record's default


def report(path):
    p = subprocess.run([SAULCTL, "tune", "report", "--json", path], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"FAIL tune report {path}: {p.stderr}")
    return json.loads(p.stdout)


def estimator_alone(trace, direct):
    """The figures saulctl estimates for a linear system whose step response is the direct step's: the chirp trace's
    setpoint (and state) through that response's impulse response, 0.02 deg of noise added. What the estimator
    gets wrong by itself, apart from how the simulated robot differs between a chirp and a step."""
    csv = trace + ".csv"
    p = subprocess.run([SAULCTL, "convert", trace, csv], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"FAIL saulctl convert {trace}: {p.stderr}")
    cols = traces.read_csv(csv)
    sp = cols["setpoint_deg"]
    impulse = np.diff(direct["response"], prepend=0.0)
    pitch = sg.lfilter(impulse, 1.0, sp - sp[0]) + sp[0] + np.random.default_rng(1).normal(0, LTI_NOISE_DEG, len(sp))
    path = trace + ".lti.csv"
    traces.write_csv(path, {"time_s": cols["time_s"], "setpoint_deg": sp, "pitch_deg": pitch, "state": cols["state"]},
                     comment=None)
    return report(path)["step"]


def record(name, gains, seed, duration, *excite):
    path = f"{TMP}/{name}.trace"
    cmd = [SAULCTL, "tune", "record", "--sim", "--seed", str(seed), "--duration", duration, "-o", path, *excite]
    if gains:
        cmd += ["--gains", *gains]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"FAIL {' '.join(cmd)}: {p.stdout}{p.stderr}")
    return path, report(path)


agreed = hard_fails = 0
rows = []
for label, gains in GAINS.items():
    for seed in SEEDS:
        chirp_trace, chirp = record(f"{label}_{seed}_{KIND}", gains, seed, "120s", "--excite", KIND, "--amplitude", AMPLITUDE, *BAND)
        _, step = record(f"{label}_{seed}_step", gains, seed, "120s", "--excite", "step", "--amplitude", "1")
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
        # The estimator alone against the direct step's own figures, worked out here at the simulator's 1 ms; on
        # the first seed of each gain set (converting a trace to CSV is most of a case's time under ASan).
        if seed != SEEDS[0]:
            continue
        alone, truth = estimator_alone(chirp_trace, direct), traces.figures(direct["response"], 1e-3)
        if alone is None:
            print(f"FAIL {what}: no estimate of the linear system built from the direct step")
            hard_fails += 1
        else:
            lti = (alone["overshoot_pct"] - truth["overshoot_pct"], alone["rise_time_s"] / truth["rise_time_s"] - 1,
                   None if alone["settling_time_s"] is None else alone["settling_time_s"] / truth["settling_time_s"] - 1,
                   alone["final_value"] / truth["final"] - 1)
            lti_ok = (abs(lti[0]) <= LTI_POINTS and abs(lti[1]) <= LTI_RISE and lti[2] is not None
                      and abs(lti[2]) <= LTI_SETTLING and abs(lti[3]) <= LTI_FINAL)
            hard_fails += 0 if lti_ok else 1
            print(f"{'ok  ' if lti_ok else 'FAIL'} {what}, the estimator alone (the direct step's response as a linear "
                  f"system, the chirp's setpoint): overshoot {lti[0]:+.1f} points, rise {100 * lti[1]:+.0f} %, settling "
                  f"{'-' if lti[2] is None else f'{100 * lti[2]:+.0f} %'}, final value {100 * lti[3]:+.1f} %")

if "--table" in sys.argv:  # the table of docs/tuning.md
    print("\n| gains | seed | overshoot est. | direct | settling est. | direct |\n|---|---|---|---|---|---|")
    for what, est, direct, d_os, d_set, ok in rows:
        label, _, seed = what.split()
        print(f"| {label} | {seed} | {est['overshoot_pct']:.1f} % | {direct['overshoot_pct']:.1f} % | "
              f"{est['settling_time_s']:.3f} s | {direct['settling_time_s']:.3f} s |")
print(f"{agreed} of {len(GAINS) * len(SEEDS)} agree within {OVERSHOOT_POINTS:g} points and {100 * SETTLING_SHARE:g} %; "
      f"{hard_fails} failed (beyond {OVERSHOOT_POINTS:g} points or {100 * SETTLING_WORST:g} %, or the estimator alone off)")
sys.exit(1 if hard_fails or agreed * 15 < SETTLING_AGREE * len(GAINS) * len(SEEDS) else 0)
