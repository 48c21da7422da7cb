"""saulproto.tune_report: the figures saulctl tune report --json gives, for Python. A known second-order closed loop
(zeta 0.5, written here with numpy, no saulproto involved) overshoots exp(-pi zeta / sqrt(1 - zeta^2)) = 16.3 %; a
file that cannot be analysed raises ValueError naming it; a CAN capture (10 Hz telemetry) refuses the step
response with the reason."""
import math

import numpy as np
import pytest
import scipy.signal as sg

import saulproto


def second_order_csv(path, zeta=0.5, fn=3.0, seconds=40.0, fs=1000.0):
    t = np.arange(int(seconds * fs)) / fs
    rng = np.random.default_rng(1)
    setpoint = np.repeat(rng.integers(0, 2, size=int(seconds / 0.2) + 1), int(0.2 * fs))[: len(t)] - 0.5
    wn = 2 * math.pi * fn
    loop = sg.lti([wn * wn], [1, 2 * zeta * wn, wn * wn])
    _, pitch, _ = sg.lsim(loop, setpoint, t)
    with open(path, "w") as f:
        f.write("time_s,setpoint_deg,pitch_deg\n")
        for row in zip(t, setpoint, pitch):
            f.write("%.6f,%.4f,%.6f\n" % row)


def test_overshoot_of_a_known_loop(tmp_path):
    path = tmp_path / "loop.csv"
    second_order_csv(path)
    r = saulproto.tune_report(path)
    assert r["sample_rate_hz"] == 1000.0 and r["records"] == 40000
    expected = 100 * math.exp(-math.pi * 0.5 / math.sqrt(1 - 0.25))
    assert abs(r["step"]["overshoot_pct"] - expected) <= 3.0
    assert r["step"]["windows_used"] >= 5 and r["oscillation"] is None


def test_a_file_that_cannot_be_analysed_names_itself(tmp_path):
    path = tmp_path / "no_columns.csv"
    path.write_text("time_s,speed\n0.0,1\n")
    with pytest.raises(ValueError, match="no_columns.csv"):
        saulproto.tune_report(path)


def test_a_can_capture_refuses_the_step_response(source):
    r = saulproto.tune_report(source / "captures" / "robot_bus.log")
    assert r["source"] == "telemetry" and r["step"] is None and r["step_reason"]
