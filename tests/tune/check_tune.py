#!/usr/bin/python3
"""saulctl tune report against things it did not compute (issue 36): closed-form second-order loops, scipy's
exact step responses, scipy.signal.welch and a numpy deconvolution of our own, a sinusoid planted at a known
frequency, a 10 Hz trace that must be refused, and bad CSVs that must be told with their lines.
Run: /usr/bin/python3 tests/tune/check_tune.py SAULCTL ROOT   (Debian's python3-numpy and python3-scipy)"""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import traces  # noqa: E402

SAULCTL, ROOT = sys.argv[1], sys.argv[2]
TMP = tempfile.mkdtemp(prefix="tune_check_")
fails = 0


def check(what, ok, detail=""):
    global fails
    print(("ok   " if ok else "FAIL ") + what + ("" if ok else f"  [{detail}]"))
    fails += 0 if ok else 1


def report(path, *extra):
    p = subprocess.run([SAULCTL, "tune", "report", "--json", path, *extra], capture_output=True, text=True)
    return p.returncode, (json.loads(p.stdout) if p.returncode == 0 and p.stdout.strip() else None), p.stderr


def written(name, cols, **kw):
    path = os.path.join(TMP, name)
    traces.write_csv(path, cols, **kw)
    return path


# (a) known second-order closed loops: the overshoot within +-3 points of exp(-pi zeta / sqrt(1 - zeta^2)), the
# resonance at fn sqrt(1 - 2 zeta^2), rise and settling within 10 % / 15 % of scipy's exact step response.
for zeta, fn in [(0.4, 4.0), (0.5, 3.0), (0.6, 2.5)]:
    expected = 100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta * zeta))
    exact = traces.figures(traces.exact_step(zeta, fn), 1e-3)
    for kind in ["prbs", "chirp", "steps"]:
        name = f"z{zeta}_f{fn}_{kind}"
        path = written(name + ".csv", traces.trace(zeta, fn, kind, seed=int(zeta * 10 + fn)))
        code, j, err = report(path)
        cols = traces.read_csv(path)  # the oracle reads the same digits as saulctl
        if j is None or j["step"] is None:
            check(f"{name}: a step response", False, err or (j or {}).get("step_reason"))
            continue
        s = j["step"]
        check(f"{name}: 1000 Hz, 60000 records, gains read", j["sample_rate_hz"] == 1000.0 and j["records"] == 60000
              and j["gains"] == {"kp": 40.0, "ki": 0.0, "kd": 1.5}, (j["sample_rate_hz"], j["records"], j["gains"]))
        check(f"{name}: overshoot {s['overshoot_pct']:.1f} % within 3 points of {expected:.1f}",
              abs(s["overshoot_pct"] - expected) <= 3.0)
        check(f"{name}: rise time {s['rise_time_s']:.3f} s within 10 % of the exact {exact['rise_time_s']:.3f}",
              abs(s["rise_time_s"] / exact["rise_time_s"] - 1) <= 0.10)
        check(f"{name}: settling {s['settling_time_s']} s within 15 % of the exact {exact['settling_time_s']:.3f}",
              s["settling_time_s"] is not None and abs(s["settling_time_s"] / exact["settling_time_s"] - 1) <= 0.15)
        check(f"{name}: steady-state error {s['steady_state_error_pct']:.1f} % within 5 %",
              abs(s["steady_state_error_pct"]) <= 5)
        if zeta <= 0.5:
            fr = fn * math.sqrt(1 - 2 * zeta * zeta)
            check(f"{name}: resonance {s['resonance_hz']} Hz within 10 % of fn sqrt(1-2 zeta^2) = {fr:.2f}",
                  s["resonance_hz"] is not None and abs(s["resonance_hz"] / fr - 1) <= 0.10)
        check(f"{name}: no oscillation in a healthy loop", j["oscillation"] is None, j["oscillation"])
        if kind == "steps":
            d = j["step_direct"]
            check(f"{name}: measured at the setpoint's steps: 19 steps, overshoot {d and d['overshoot_pct']} within 3 "
                  f"points", d is not None and d["steps"] == 19 and abs(d["overshoot_pct"] - expected) <= 3.0, d)
        # (c) the same method written again with numpy: the C++ step response and its figures agree.
        if kind != "steps":
            resp, used = traces.oracle_step(cols["setpoint_deg"], cols["pitch_deg"], 1000.0)
            ours = np.array(s["response"])
            diff = float(np.max(np.abs(ours - resp))) if len(ours) == len(resp) else math.inf
            check(f"{name}: numpy deconvolution: same windows ({used}) and response within 1e-6 (max diff {diff:.1e})",
                  used == s["windows_used"] and diff <= 1e-6)
            f, p = traces.oracle_welch(cols["rate_dps"], 1000.0)
            cpp = np.array(j["spectra"][0]["psd"])
            ref = p[: len(cpp)]
            rel = float(np.max(np.abs(cpp - ref) / np.maximum(ref, 1e-12 * ref.max())))
            check(f"{name}: scipy.signal.welch of rate_dps: the same density to 1e-6 (max relative diff {rel:.1e})",
                  j["spectra"][0]["signal"] == "rate_dps" and rel <= 1e-6)

# (b) an oscillation planted in the rate (a sinusoid off the bins) is found within +-0.5 Hz, as scipy finds it
for hz in [7.3, 17.3, 41.7]:
    path = written(f"osc{hz}.csv", traces.trace(0.5, 3.0, "prbs", sine_hz=hz, sine_dps=4.0, seed=7))
    code, j, err = report(path)
    cols = traces.read_csv(path)
    o = j and j["oscillation"]
    check(f"oscillation at {hz} Hz: found at {o and o['frequency_hz']} Hz ({o and o['ratio_to_median']}x), within 0.5",
          o is not None and abs(o["frequency_hz"] - hz) <= 0.5 and o["ratio_to_median"] >= 40, o)
    f, p = traces.oracle_welch(cols["rate_dps"], 1000.0)
    peak, ratio = traces.oracle_peak(f, p)
    sp = j["spectra"][0]
    check(f"oscillation at {hz} Hz: scipy's peak {peak:.2f} Hz ratio {ratio:.0f} is the C++ bin and ratio",
          sp["peak_hz"] is not None and abs(sp["peak_hz"] - peak) <= f[1] / 2 and abs(sp["peak_ratio"] / ratio - 1) < 1e-3,
          sp["peak_hz"])

# (d) from 10 Hz: a 12 Hz oscillation would alias to 2 Hz: refused, with the reason, nothing aliased reported
cols = traces.trace(0.5, 3.0, "prbs", sine_hz=12.0, sine_dps=30.0, fs=1000.0, seed=3)
slow = {k: v[::100] for k, v in cols.items()}
code, j, err = report(written("slow10hz.csv", slow))
check("10 Hz: exit 0, 10 Hz seen", code == 0 and j["sample_rate_hz"] == 10.0, err)
check("10 Hz: no step response, the reason names the rate", j["step"] is None and "10 Hz" in j["step_reason"],
      j.get("step_reason"))
check("10 Hz: no oscillation and no spectra (no aliased 2 Hz), the reason says aliasing",
      j["oscillation"] is None and j["spectra"] == [] and "alias" in j["oscillation_reason"], j.get("spectra_reason"))
check("10 Hz: what it can say is there (pitch RMS, saturation)", j["pitch_rms_deg"] > 0 and j["saturation_pct"] is not None)
code, j, err = report(os.path.join(ROOT, "captures", "robot_bus.log"))
check("a CAN capture: telemetry at 10 Hz, no step, no spectra, pitch RMS and saturation given",
      code == 0 and j["source"] == "telemetry" and j["sample_rate_hz"] == 10.0 and j["step"] is None
      and j["oscillation"] is None and j["pitch_rms_deg"] > 0 and j["saturation_pct"] is not None, (code, err))

# Bad input: told with file:line, what can be computed still is
good = traces.trace(0.5, 3.0, "prbs", seconds=20, seed=5)
path = written("nocol.csv", {k: v for k, v in good.items() if k != "setpoint_deg"}, comment=None)
p = subprocess.run([SAULCTL, "tune", "report", path], capture_output=True, text=True)
check("a CSV without setpoint_deg: exit 1, names the file, line 1 and the column",
      p.returncode == 1 and f"{path}:1:" in p.stderr and "setpoint_deg" in p.stderr, p.stderr)
path = written("bad.csv", good, comment=None)
lines = open(path).read().splitlines()
lines[101] = lines[101].replace(lines[101].split(",")[2], "abc", 1)      # line 102: a word for pitch
lines[201] = "5.0," + ",".join(lines[201].split(",")[1:])               # line 202: a time far ahead
lines[301] = lines[150].split(",")[0] + "," + ",".join(lines[301].split(",")[1:])  # line 302: back to line 151's
del lines[5001:5051]                                                     # 50 rows missing before line 5002: a gap
open(path, "w").write("\n".join(lines) + "\n")
code, j, err = report(path)
probs = " | ".join(j["problems"]) if j else err
check("a bad row: 'pitch_deg 'abc' is not a number' at bad.csv:102", f"bad.csv:102: pitch_deg 'abc' is not a number" in probs, probs)
check("a time far ahead: that row told at bad.csv:202, not every row after it",
      "bad.csv:202: time_s 5 jumps ahead of the rows around it" in probs, probs)
check("a time going back: told at bad.csv:302", "bad.csv:302: time_s 0.149 does not move forward from 0.299" in probs, probs)
check("three problems counted", j and j["problems_total"] == 3, j and j["problems_total"])
check("the rows left out are gaps of 1 iteration at lines 103, 203, 303; the 50 missing rows one of 50 before line 5002",
      j and j["gaps"] == 4 and [(g["line"], g["missed"]) for g in j["gap_list"]] == [(103, 1), (203, 1), (303, 1), (5002, 50)],
      j and j["gap_list"])
check("... and the step response still computed", j and j["step"] is not None)
quiet = dict(good, setpoint_deg=np.zeros_like(good["setpoint_deg"]))
code, j, err = report(written("quiet.csv", quiet))
check("no excitation: step null with the reason 'too little excitation' and the windows counted",
      j["step"] is None and "too little excitation: 0 of" in j["step_reason"], j.get("step_reason"))

print(f"{fails} failed")
sys.exit(1 if fails else 0)
