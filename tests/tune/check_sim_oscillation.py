#!/usr/bin/python3
"""An oscillation made on the simulated robot, found where it is (issue 36): with Kd ten times the shipped one (100
500 30 and 100 500 40 against 100 500 3) BALANCE's loop chatters near 50 Hz, half its 100 Hz motor command rate: the
D term answers each command's step in the next one. `saulctl tune record --sim` traces it at 1 kHz (simulated time)
and `tune report` must name the oscillation within 0.5 Hz of where scipy finds it in the same records (converted to
CSV: `scipy.signal.welch` on the output, and a 0.1 Hz periodogram of the whole trace, neither from saulctl), and
the shipped gains on the same seed must show none. The same run traced at 10 Hz (`--divider 100`: a record every
100th iteration) must refuse the spectra, saying why, rather than report an aliased line, and must not count the
99 iterations between records as lost (it did: "9801 iterations missing", fixed with `loop_divider`).
Run: /usr/bin/python3 tests/tune/check_sim_oscillation.py SAULCTL"""
import atexit
import json
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import scipy.signal as sg

SAULCTL = sys.argv[1]
TMP = tempfile.mkdtemp(prefix="tune_osc_")
atexit.register(shutil.rmtree, TMP, ignore_errors=True)
TOLERANCE_HZ = 0.5
failures = 0


def check(what, ok, detail=""):
    global failures
    print(f"{'ok  ' if ok else 'FAIL'} {what}" + (f"  ({detail})" if detail != "" else ""))
    failures += 0 if ok else 1


def run(*args):
    p = subprocess.run([SAULCTL, *args], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"FAIL saulctl {' '.join(args)}: {p.stdout}{p.stderr}")
    return p.stdout


def record(name, seed, gains, *more):
    path = f"{TMP}/{name}.trace"
    run("tune", "record", "--sim", "--seed", str(seed), "--duration", "10s", "--gains", *gains, "-o", path, *more)
    return path, json.loads(run("tune", "report", "--json", path))


def scipy_peaks(trace):
    """The output's strongest line between 1 and 100 Hz, by scipy alone: Welch (2048 samples, as the tools use)
    and one periodogram of the whole trace (0.1 Hz bins; the line's power-weighted mean within 2 Hz of its highest
    bin, as a limit cycle's amplitude beats and splits its line into sidebands 0.4 Hz either side)."""
    csv = trace + ".csv"
    run("convert", trace, csv)
    names = open(csv).readline().strip().split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    t, out = data[:, names.index("time_s")], data[:, names.index("output")]
    fs = 1.0 / np.median(np.diff(t))
    band = lambda f: (f >= 1.0) & (f <= 100.0)  # noqa: E731
    f, p = sg.welch(out, fs=fs, nperseg=2048)
    welch_hz = float(f[band(f)][np.argmax(p[band(f)])])
    f, p = sg.periodogram(out, fs=fs, window="hann")
    top = f[band(f)][np.argmax(p[band(f)])]
    near = np.abs(f - top) <= 2.0
    return fs, (welch_hz, float((f[near] * p[near]).sum() / p[near].sum()))


for seed in (1, 2):
    for kd in ("30", "40"):
        trace, j = record(f"kd{kd}_{seed}", seed, ["100", "500", kd])
        osc = j["oscillation"]
        fs, (welch_hz, whole_hz) = scipy_peaks(trace)
        check(f"seed {seed}, Kd {kd}: an oscillation is found", osc is not None, j.get("oscillation_reason"))
        if osc is None:
            continue
        f = osc["frequency_hz"]
        check(f"seed {seed}, Kd {kd}: at {f} Hz, scipy's Welch {welch_hz:.3f} Hz and periodogram {whole_hz:.3f} Hz "
              f"within {TOLERANCE_HZ} Hz (1 kHz: {fs:.1f} Hz)",
              abs(f - welch_hz) <= TOLERANCE_HZ and abs(f - whole_hz) <= TOLERANCE_HZ and abs(fs - 1000) < 1)
        check(f"seed {seed}, Kd {kd}: the line stands >= 40x above its octave's median", osc["ratio_to_median"] >= 40,
              osc["ratio_to_median"])
    _, shipped = record(f"shipped_{seed}", seed, ["100", "500", "3"])
    check(f"seed {seed}, the shipped gains 100 500 3: no oscillation", shipped["oscillation"] is None,
          shipped["oscillation"])

    # The same chattering loop at 10 Hz: a 50 Hz line would alias (to 0 Hz here); refused instead, with the reason.
    _, slow = record(f"kd40_{seed}_10hz", seed, ["100", "500", "40"], "--divider", "100")
    check(f"seed {seed}, Kd 40 at 10 Hz: no oscillation and no spectra, the reason says aliased",
          slow["oscillation"] is None and slow["spectra"] == [] and "alias" in (slow.get("oscillation_reason") or ""),
          slow.get("oscillation_reason"))
    check(f"seed {seed}, Kd 40 at 10 Hz: a record every 100th iteration, nothing counted lost, the loop's own period",
          slow["loop_divider"] == 100 and slow["seq_missing"] == 0 and slow["gaps"] == 0
          and abs(slow["loop_period_us"]["p50"] - 1000) < 50,
          {k: slow[k] for k in ("loop_divider", "seq_missing", "gaps", "loop_period_us")})

print(f"{'FAIL' if failures else 'ok'}: {failures} failed")
sys.exit(1 if failures else 0)
