"""Synthetic traces of the balance loop for saulctl tune's independent checks: a known second-order closed loop
(damping ratio zeta, natural frequency fn) driven by a PRBS, a chirp or steps of the setpoint, noise added, written
as the CSV saulctl tune report reads. Nothing here comes from saulctl: the truth is the closed form and scipy."""
import numpy as np
import scipy.signal as sg


def setpoint(kind, n, fs, rng, amp=1.0):
    t = np.arange(n) / fs
    if kind == "prbs":  # a random binary sequence, 0.2 s bits
        bits = rng.integers(0, 2, size=n // int(0.2 * fs) + 2)
        return amp * (np.repeat(bits, int(0.2 * fs))[:n] - 0.5)
    if kind == "chirp":  # 0.2 -> 20 Hz log sweeps of 20 s
        return 0.5 * amp * sg.chirp(t % 20.0, 0.2, 20.0, 20.0, method="logarithmic")
    if kind == "steps":  # +-amp/2 held 3 s
        return amp * (((t // 3.0) % 2) - 0.5)
    raise ValueError(kind)


def closed_loop(zeta, fn, dc_gain=1.0):
    """dc_gain: where pitch settles for a unit step (1: it follows; 0.8: a type-0 loop, 20 % short)."""
    wn = 2 * np.pi * fn
    # x = [pitch, pitch rate]; pitch'' = wn^2 (dc_gain sp - pitch) - 2 zeta wn pitch'
    a = np.array([[0.0, 1.0], [-wn * wn, -2 * zeta * wn]])
    b = np.array([[0.0], [dc_gain * wn * wn]])
    return sg.StateSpace(a, b, np.eye(2), np.zeros((2, 1)))


def trace(zeta, fn, kind, seconds=60.0, fs=1000.0, noise_deg=0.02, seed=1, sine_hz=None, sine_dps=0.0, dc_gain=1.0):
    """A dict of columns. sine_hz adds a sinusoid of sine_dps to the rate (an oscillation the loop does not
    explain: a gyro resonance, a limit cycle)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * fs)
    t = np.arange(n) / fs
    sp = setpoint(kind, n, fs, rng)
    _, y, _ = sg.lsim(closed_loop(zeta, fn, dc_gain), sp, t)
    pitch = y[:, 0] + rng.normal(0, noise_deg, n)
    rate = y[:, 1] + rng.normal(0, 20 * noise_deg, n)
    if sine_hz:
        rate = rate + sine_dps * np.sin(2 * np.pi * sine_hz * t + 0.3)
    kd, kp = 1.5, 40.0
    d = -kd * rate
    out = np.clip(kp * (sp - pitch) + d, -1000, 1000)
    return {"time_s": t, "setpoint_deg": sp, "pitch_deg": pitch, "rate_dps": rate, "d_term": d, "output": out,
            "excite": np.ones(n, dtype=int)}


def write_csv(path, cols, comment="# kp=40 ki=0 kd=1.5"):
    names = list(cols)
    data = np.column_stack([cols[k] for k in names])
    fmt = ["%.6f" if k == "time_s" else ("%d" if k in ("excite", "state") else "%.6g") for k in names]
    with open(path, "w") as f:
        if comment:
            f.write(comment + "\n")
        np.savetxt(f, data, fmt=fmt, delimiter=",", header=",".join(names), comments="")


def read_csv(path):
    """The columns of a CSV written by write_csv, as the file holds them."""
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    names = lines[0].strip().split(",")
    data = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    return {k: data[:, i] for i, k in enumerate(names)}


def figures(response, dt):
    """Rise time (10-90 %), overshoot, settling (5 %), from a step response: our own few lines."""
    r = np.asarray(response)
    tail = len(r) - len(r) // 5
    final = r[tail:].mean()

    def reach(level):
        k = int(np.argmax(r >= level * final))
        if k == 0:
            return 0.0
        return (k - 1 + (level * final - r[k - 1]) / (r[k] - r[k - 1])) * dt

    out = np.nonzero(np.abs(r - final) > 0.05 * final)[0]
    settle = (out[-1] + 1) * dt if len(out) else 0.0
    return {"final": final, "overshoot_pct": max(0.0, (r.max() - final) / final * 100), "rise_time_s": reach(0.9) - reach(0.1),
            "settling_time_s": settle}


def exact_step(zeta, fn, seconds=1.5, fs=1000.0):
    t = np.arange(int(seconds * fs)) / fs
    _, y = sg.step(sg.lti([(2 * np.pi * fn) ** 2], [1, 2 * zeta * 2 * np.pi * fn, (2 * np.pi * fn) ** 2]), T=t)
    return y


# --- the oracle: the same method written again with numpy and scipy, from the description in docs/tuning.md ---

def next_fast_size(m):
    """The smallest 2^a 3^b 5^c >= m (docs/tuning.md: the FFT length of the deconvolution)."""
    while True:
        r = m
        for f in (2, 3, 5):
            while r % f == 0:
                r //= f
        if r == 1:
            return m
        m += 1


def oracle_step(sp, pitch, fs, window_s=8.0, hop_s=0.5, response_s=1.5, min_input=0.3, reg=0.01):
    L, hop, R = round(window_s * fs), round(hop_s * fs), round(response_s * fs)
    n = next_fast_size(L + R)
    w = sg.get_window("hann", L)
    sxy = np.zeros(n // 2 + 1, complex)
    sxx = np.zeros(n // 2 + 1)
    used = 0
    for b in range(0, len(sp) - L + 1, hop):
        x, y = sp[b:b + L], pitch[b:b + L]
        if np.ptp(x) < min_input:
            continue
        X = np.fft.rfft((x - x.mean()) * w, n)
        Y = np.fft.rfft((y - y.mean()) * w, n)
        sxy += Y * np.conj(X)
        sxx += np.abs(X) ** 2
        used += 1
    h = sxy / (sxx + reg * sxx.mean())
    h[0] = h[1].real
    return np.cumsum(np.fft.irfft(h, n)[:R]), used


def oracle_welch(x, fs, segment_s=2.0):
    nper = 1 << int(np.ceil(np.log2(round(segment_s * fs))))
    return sg.welch(x, fs=fs, window="hann", nperseg=nper, noverlap=nper // 2, detrend="constant", scaling="density")


def oracle_peak(f, p, lo=1.0, hi=100.0):
    """(frequency, ratio) of the local maximum in lo..hi standing highest above the median of its octave."""
    best = (None, 0.0)
    df = f[1] - f[0]
    hi = min(hi, 0.45 * f[-1] * 2)
    for k in range(1, len(p) - 1):
        if not (lo <= f[k] <= hi) or p[k] < p[k - 1] or p[k] < p[k + 1]:
            continue
        a = max(1, int(np.ceil(f[k] / np.sqrt(2) / df)))
        b = min(len(p) - 1, int(np.floor(f[k] * np.sqrt(2) / df)))
        oc = np.sort(p[a:b + 1])
        med = oc[len(oc) // 2]
        if med > 0 and p[k] / med > best[1]:
            best = (f[k], p[k] / med)
    return best
