#!/usr/bin/python3
"""The scipy/numpy oracle of tests/tune doing what saulctl tune report does to a 10-minute 1 kHz trace (the step
response over 8 s windows every 0.5 s, Welch spectra of three signals and their peak search), timed, for the ratio
with BM_TuneAnalyse600k (bench/README.md). Run: /usr/bin/python3 bench/tune_oracle.py [RECORDS]"""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "tune"))
import traces  # noqa: E402

n = int(sys.argv[1]) if len(sys.argv) > 1 else 600_000
cols = traces.trace(0.5, 3.0, "prbs", seconds=n / 1000.0, sine_hz=17.3, sine_dps=4.0)
best = cpu_best = float("inf")
for _ in range(3):
    t0, c0 = time.perf_counter(), time.process_time()
    traces.oracle_step(cols["setpoint_deg"], cols["pitch_deg"], 1000.0)
    for name in ("rate_dps", "d_term", "output"):
        f, p = traces.oracle_welch(cols[name], 1000.0)
        traces.oracle_peak(f, p)
    best = min(best, time.perf_counter() - t0)
    cpu_best = min(cpu_best, time.process_time() - c0)
# CPU time beside wall time: on a shared machine the wall clock counts other work, and BM_TuneAnalyse600k's CPU
# column is the figure to divide by.
print(f"scipy/numpy oracle: {n} records analysed in {best * 1e3:.0f} ms wall, {cpu_best * 1e3:.0f} ms CPU (best of 3)")
