#!/usr/bin/env python3
"""The simulated robot driven from outside with seeded random inputs from every source; the rules checked on the bus.

  sim_random.py SAULCTL [--seed N[,N...]] [--duration SECONDS] [--keep DIR]
  sim_random.py --self-test      the rules below on records written by hand (each must fire on its violation)

Several seeds run at once, each a simulator, a sniff and a driver of its own (a run takes ~10 % of a core: most of
it is waiting for real time), and the outputs are printed seed by seed; the exit status is 1 when any failed.

`saulctl sim` runs in real time behind its pseudo-terminals, as a bench engineer's robot would: this script is the
engineer (and the Orin, and a clumsy colleague). Through the control pty it moves the radio's channels (CH2 throttle,
CH5 ARM, CH6 ESTOP), presses the arming button for random lengths, flips the kill switch, loses the radio, pulls
the IMU, kills a VESC, hangs BALANCE, pushes and tilts the body; through both boards' USB consoles it types arm,
disarm, estop, status; as the Orin it runs `saulctl mode`, `saulctl config` and `saulctl estop` through the shared
link, while `saulctl sniff --json` holds the virtual CANable and records every frame (two and more saulctl
processes on one adapter).

Afterwards the record is checked against docs/protocol.md sections 4 and 5, with the latency allowances below
(the pty and the processes between the script and the firmware take a few ms; the firmware's own figures are
the explorer's business, tests/firmware/explorer.hpp):
  latch     a latched state (ESTOP, TILT_CUTOFF, FAULT) is never followed by BALANCE/MANUAL in the next 0x400
            (a latch is left only to OFF; the script never types an arming within MIN_GAP of a disarm, so a
            disarm-and-arm cannot hide between two 0x400 frames);
  arming    every arming seen in 0x400 has a console `arm` just before it, or a button press held 3 s whose start
            came after every stop or disarm input of any source (rule 1: a stop that changes nothing still
            cancels the hold);
  stop      after an ESTOP input (kill switch, CH6, either console's estop, the Orin's mode 3) no SET_RPM other than
            0 later than STOP_MS, until a new arming; and the next 0x400 after STATE_MS shows ESTOP unless the
            board was hung or reset meanwhile or a disarm followed;
  motion    no SET_RPM other than 0 between two 0x400 frames that both show a disarmed or latched state.
A violation prints the rule, the frames, and the inputs of the 10 s before it; the exit status is 1.

Times are the host's: sniff stamps a frame when it reads it, the script an input when it writes it. `saulctl sim`
keeps simulated time with the wall clock by catching up in bursts, so a machine that starves it (a loaded CI
host) bunches frames. The simulator, sniff and this script run at a raised priority where allowed (root), and a
stretch of the record where two 0x400 frames (10 Hz) are more than STARVED s apart is left out of the checks,
with a margin, and counted; a run that had to leave out more than a fifth of its time fails as untested.
The script paces its inputs with sleeps (that is the scenario: a person's timing), never to synchronise: it
waits for the simulator and sniff by reading their output.
"""
import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

STOP_MS = 60     # SET_RPM 0 on the bus this soon after a stop input is written (seen: 1-6 ms), plus the rule's
# own time where it has one: RC loss and the inter-board link 100 ms, a hang the 50 ms watchdog, a VESC 500 ms
RULE_MS = {"control rc loss": 100, "control link cut": 100, "control hang balance": 50, "control imu off": 10,
           "control vesc left dead": 500}
STATE_MS = 120   # the first 0x400 (10 Hz) after this shows ESTOP
MIN_GAP = 0.25   # seconds between two inputs of the script
STARVED = 0.2    # two 0x400 frames further apart than this: the simulator or sniff was starved
MARGIN = 0.6     # seconds left out on either side of such a gap
ARMED = {"BALANCE", "MANUAL"}
LATCHED = {"ESTOP", "TILT_CUTOFF", "FAULT"}


class Pty:
    """A pty of the simulator, opened for writing; a thread drains what the board prints (the replies)."""

    def __init__(self, path):
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self):
        try:
            while os.read(self.fd, 4096):
                pass
        except OSError:
            pass

    def line(self, text):
        os.write(self.fd, (text + "\n").encode())


def raise_priority():
    """Runs before exec in the children (and once for this script): a starved simulator bunches its frames."""
    try:
        os.nice(-10)
    except OSError:
        pass  # not root: as it is


class Driver:
    def __init__(self, saulctl, seed, duration, work):
        self.saulctl = saulctl
        self.rng = random.Random(seed)
        self.seed = seed
        self.duration = duration
        self.work = work
        self.env = dict(os.environ, SAUL_RUNTIME_DIR=os.path.join(work, "run"))
        os.makedirs(self.env["SAUL_RUNTIME_DIR"], mode=0o700)
        self.inputs = []      # (wall start, wall end, kind, text); kind: stop, disarm, arm_console, down, up, other
        self.button = False
        self.radio_on = True
        self.ch5_arm = True

    # ---- the world ----
    def start(self):
        paths = os.path.join(self.work, "sim.paths")
        self.sim = subprocess.Popen([self.saulctl, "sim", "--quiet", "--paths-file", paths, "--seed", str(self.seed),
                                     "--for", f"{self.duration + 30}s"], stdin=subprocess.DEVNULL,
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=self.env,
                                    preexec_fn=raise_priority)
        line = self.sim.stdout.readline().decode()  # "simulated SAUL-TEE is running ..." once the ptys exist
        if "running" not in line:
            raise SystemExit(f"sim_random: saulctl sim did not start: {line!r}")
        threading.Thread(target=lambda: self.sim.stdout.read(), daemon=True).start()
        p = dict(l.strip().split("=", 1) for l in open(paths) if "=" in l)
        self.can = p["can"]
        self.control, self.balance, self.io = Pty(p["control"]), Pty(p["balance"]), Pty(p["io"])
        self.record = os.path.join(self.work, "bus.jsonl")
        self.sniff = subprocess.Popen([self.saulctl, "sniff", "--link", f"slcan:{self.can}", "--json"],
                                      stdin=subprocess.DEVNULL, stdout=open(self.record, "w"),
                                      stderr=open(os.path.join(self.work, "sniff.err"), "w"), env=self.env,
                                      preexec_fn=raise_priority)
        end = time.monotonic() + 15
        while time.monotonic() < end:  # sniff is recording once the first 0x400 is in its file
            if os.path.exists(self.record) and "telemetry_a" in open(self.record).read():
                return
            if self.sniff.poll() is not None:
                break
            time.sleep(0.05)
        raise SystemExit("sim_random: sniff recorded no telemetry within 15 s: " +
                         open(os.path.join(self.work, "sniff.err")).read())

    def stop(self):
        self.sniff.send_signal(signal.SIGINT)
        self.sniff.wait(timeout=10)
        self.sim.send_signal(signal.SIGINT)
        try:
            self.sim.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.sim.kill()

    # ---- inputs ----
    def log(self, t0, kind, text):
        self.inputs.append((t0, time.time(), kind, text))

    def ctl(self, text, kind="other"):
        t0 = time.time()
        self.control.line(text)
        if text.startswith("button"):
            self.button = text.endswith("down")
        if text == "rc loss":
            self.radio_on = False
        if text == "rc ok":
            self.radio_on = True
        if text.startswith("radio 5 "):
            self.ch5_arm = int(text.split()[2]) > 1500
        self.log(t0, kind, "control " + text)

    def console(self, board, text):
        t0 = time.time()
        (self.balance if board == "balance" else self.io).line(text)
        kind = {"estop": "stop", "disarm": "disarm", "arm": "arm_console" if board == "balance" else "other"}
        self.log(t0, kind.get(text, "other"), f"console {board} {text}")

    def orin(self, *args, kind="other"):
        t0 = time.time()
        subprocess.run([self.saulctl, *args, "--link", f"slcan:{self.can}", "--timeout", "300ms"],
                       stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       env=self.env, timeout=10)
        self.log(t0, kind, "saulctl " + " ".join(args))

    def pause(self, lo, hi):
        time.sleep(max(MIN_GAP, self.rng.uniform(lo, hi)))

    def pulse(self, on, off, kind, lo, hi):
        """A control input and, lo..hi s later, its undoing (a kill switch flipped and back, a receiver lost)."""
        self.ctl(on, kind)
        self.pause(lo, hi)
        self.ctl(off)

    def stop_or_disarm(self):
        """One stop or disarm input of a random source."""
        r = self.rng
        choice = r.randrange(9)
        if choice == 0:
            self.console("balance", "estop")
        elif choice == 1:
            self.console("balance", "disarm")
        elif choice == 2:
            self.orin("mode", "estop", kind="stop")
        elif choice == 3:
            self.orin("mode", "off", kind="disarm")
        elif choice == 4:
            self.console("io", r.choice(["estop", "disarm"]))
        elif choice == 5:
            self.pulse("kill on", "kill off", "stop", 0.1, 0.8)
        elif choice == 6:
            self.pulse("radio 6 2000", "radio 6 1000", "stop" if self.radio_on else "other", 0.1, 0.8)
        elif choice == 7:
            self.pulse("radio 5 1000", "radio 5 2000", "disarm" if self.radio_on else "other", 0.1, 0.8)
        else:
            self.orin("estop", kind="stop")

    def step(self):
        r = self.rng
        w = r.randrange(100)
        if w < 18:  # a serious try at arming: stand it up, leave a latch, hold 3 s, ask for balance
            self.ctl("upright")
            self.pause(0.6, 1.2)
            if r.random() < 0.7:
                self.console("balance", "disarm")
                self.pause(0.3, 0.6)
            self.ctl("button down")
            time.sleep(r.uniform(3.15, 3.6))
            self.ctl("button up")
            self.pause(0.2, 0.5)
            self.orin("mode", "balance", "--yes")
        elif w < 30:  # the button held through a stop or disarm, then on past 3 s: rule 1's case
            self.ctl("button down")
            time.sleep(r.uniform(0.3, 2.7))
            self.stop_or_disarm()
            time.sleep(r.uniform(0.6, 2.5))
            self.ctl("button up")
        elif w < 36:  # a short press
            self.ctl("button down")
            time.sleep(r.uniform(0.05, 1.5))
            self.ctl("button up")
        elif w < 46:
            self.stop_or_disarm()
        elif w < 54:
            self.console("balance", r.choice(["arm", "arm", "status", "disarm"]))
        elif w < 60:
            self.orin("mode", r.choice(["balance", "manual", "off", "estop"]), "--yes",
                      kind="other")
            last = self.inputs[-1]
            kind = "stop" if "estop" in last[3] else "disarm" if " off" in last[3] else "other"
            self.inputs[-1] = (last[0], last[1], kind, last[3])
        elif w < 63:
            tilt = r.choice([5, 8, 12, 25, 30])
            self.orin("config", "--tilt-limit", str(tilt), "--max-speed", str(r.choice([300, 2000])))
        elif w < 70:
            self.ctl(r.choice(["push 40", "push -40", "push 150", "push -150", "tilt 12", "tilt -30", "upright"]))
        elif w < 75:
            self.ctl(r.choice(["radio 2 1500", "radio 2 1600", "radio 2 1500", "radio 1 1700", "radio 1 1500"]))
        elif w < 79:
            self.pulse("rc loss", "rc ok", "stop", 0.1, 1.2)
        elif w < 82:
            self.pulse("imu off", "imu on", "stop", 0.05, 0.4)
        elif w < 84:
            self.ctl("hang balance", "stop")
        elif w < 86:
            self.pulse("vesc left dead", "vesc left alive", "stop", 0.6, 1.0)
        elif w < 88:
            self.pulse("link cut", "link ok", "stop", 0.1, 0.4)
        else:
            self.ctl("status")
        self.pause(MIN_GAP, 1.0)

    def run(self):
        end = time.monotonic() + self.duration
        while time.monotonic() < end:
            self.step()
        if self.button:
            self.ctl("button up")
        time.sleep(0.5)  # the last frames of the last input reach the record


# ---- the checks, on the record ----
def load(record):
    tel, rpm = [], []
    for line in open(record):
        try:
            j = json.loads(line)
        except ValueError:
            continue
        m = j.get("message") or {}
        t = j["frame"]["timestamp_ns"] / 1e9
        if m.get("type") == "telemetry_a":
            tel.append((t, m["state"]))
        elif m.get("type") == "vesc_set_rpm":
            # With the number of 0x400 frames before it in the record: the order is the bus's, while the
            # timestamps are not enough (sniff stamps every frame of one read alike, and a loaded host makes
            # big reads: a 0x400 sent before an arming's first SET_RPM can carry that SET_RPM's time).
            rpm.append((t, m["erpm"], len(tel)))
    return tel, rpm


def starved_windows(tel):
    """The stretches around gaps between 0x400 frames longer than STARVED: times there are not the robot's."""
    return [(a - MARGIN, b + MARGIN) for (a, _), (b, _) in zip(tel, tel[1:]) if b - a > STARVED]


def check(inputs, tel, rpm):
    starved = starved_windows(tel)

    def judged(*ts):
        return not any(lo <= t <= hi for t in ts for lo, hi in starved)

    violations = []
    stops = [i for i in inputs if i[2] == "stop"]
    disarms = [i for i in inputs if i[2] == "disarm"]
    any_stop = sorted(stops + disarms)
    presses = []  # (down, up or None)
    for t0, t1, kind, text in inputs:
        if text == "control button down":
            presses.append([t1, None])
        elif text == "control button up" and presses and presses[-1][1] is None:
            presses[-1][1] = t0
    hangs = [i[0] for i in inputs if "hang balance" in i[3] or "imu off" in i[3]]
    link_cuts = [i for i in inputs if "link cut" in i[3]]

    def inputs_near(t):
        return [i for i in inputs if t - 10 <= i[0] <= t]

    armings = []
    for (ta, sa), (tb, sb) in zip(tel, tel[1:]):
        if not judged(ta, tb):
            if sa not in ARMED and sb in ARMED:
                armings.append((ta, tb))
            continue
        if sa in LATCHED and sb in ARMED:
            violations.append(("latch", tb, f"0x400 {sa} at {ta:.3f} then {sb} at {tb:.3f}: a latch left not to OFF"))
        if sa not in ARMED and sb in ARMED:
            armings.append((ta, tb))
            console_arm = any(i[2] == "arm_console" and ta - 0.05 <= i[0] <= tb for i in inputs)
            ok_press = False
            bad_press = None
            for down, up in presses:
                done = down + 3.0
                if not (done <= tb + 0.02 and (up is None or up >= done - 0.02)) or done < ta - 0.2:
                    continue
                # a stop or disarm input after the press began (with 30 ms for the pty on either side)
                between = [i for i in any_stop if down + 0.03 < i[0] < min(done, tb) - 0.03]
                if between:
                    bad_press = (down, between[0])
                else:
                    ok_press = True
            if not console_arm and not ok_press:
                why = (f"the press at {bad_press[0]:.3f} began before '{bad_press[1][3]}' at {bad_press[1][0]:.3f}"
                       if bad_press else "no console arm and no 3 s press")
                violations.append(("arming", tb, f"armed ({sb}) between {ta:.3f} and {tb:.3f}: {why}"))

    def armed_again_after(t):
        return next((tb for ta, tb in armings if ta >= t), float("inf"))

    for t0, t1, kind, text in stops:
        until = armed_again_after(t1)
        allowance = (STOP_MS + RULE_MS.get(text, 0)) / 1000
        late = [(t, e) for t, e, _ in rpm if t1 + allowance < t < until - 0.15 and e != 0]
        late = [(t, e) for t, e in late if judged(t, t1)]
        if late:
            violations.append(("stop", late[0][0], f"SET_RPM {late[0][1]} {1000 * (late[0][0] - t1):.0f} ms after "
                                                 f"'{text}'"))
        estop = "estop" in text or "kill on" in text or "radio 6 2000" in text
        if not estop:
            continue
        after = [(t, s) for t, s in tel if t > t1 + STATE_MS / 1000]
        if not after:
            continue
        t, s = after[0]
        excused = (any(t0 - 0.3 <= h <= t for h in hangs) or any(c[0] - 0.5 <= t <= c[1] + 0.5 for c in link_cuts)
                   or any(t0 <= d[0] <= t for d in disarms) or not radio_live_at(inputs, t0, text))
        if s != "ESTOP" and not excused and judged(t, t0):
            violations.append(("stop", t, f"0x400 shows {s} {1000 * (t - t1):.0f} ms after '{text}' (ESTOP expected)"))

    for t, e, k in rpm:
        if e == 0:
            continue
        before = tel[k - 1][1] if k > 0 else None  # the 0x400 frames around it in the record's order
        after = tel[k][1] if k < len(tel) else None
        if before is not None and after is not None and before not in ARMED and after not in ARMED and judged(t):
            violations.append(("motion", t, f"SET_RPM {e} between two 0x400 showing {before} and {after}"))
            break
    return violations, armings, inputs_near, starved


def radio_live_at(inputs, t0, text):
    """CH6 works only with a live radio: was the radio lost when CH6 moved?"""
    if "radio 6" not in text:
        return True
    on = True
    for i in inputs:
        if i[0] > t0:
            break
        if i[3] == "control rc loss":
            on = False
        elif i[3] == "control rc ok":
            on = True
    return on


def run_at_once(a, seeds):
    """Each seed in a process of its own, all at once; their outputs printed in seed order."""
    runs = []
    for seed in seeds:
        cmd = [sys.executable, os.path.abspath(__file__), a.saulctl, "--seed", str(seed), "--duration", str(a.duration)]
        if a.keep:
            cmd += ["--keep", os.path.join(a.keep, f"seed{seed}")]
        runs.append((seed, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)))
    failed = 0
    for seed, p in runs:
        out, _ = p.communicate()
        print(f"---- seed {seed}: exit {p.returncode}\n{out}", end="" if out.endswith("\n") else "\n")
        failed += p.returncode != 0
    print(f"seeds {','.join(map(str, seeds))}: {len(seeds) - failed} passed, {failed} failed")
    return 1 if failed else 0


def self_test():
    """The rules on records written by hand: each fires on its violation, and the motion rule stays quiet on the
    record that once failed CI at random (a rule that cannot fire, or fires on good records, is a defect)."""
    off_then_balance = [(0.0, "OFF"), (0.1, "OFF"), (0.2, "OFF"), (0.3, "BALANCE"), (0.4, "BALANCE")]
    console_arm = [(0.25, 0.25, "arm_console", "console balance arm")]
    cases = [
        ("a driving SET_RPM between two 0x400 showing OFF", off_then_balance, console_arm, [(0.15, 92, 2)],
         ["motion"]),
        # The arming's first SET_RPM follows BALANCE in the record, its stamp among the OFF frames' (the timestamps
        # of a starved host's reads): by time it sits between two OFF 0x400, by the bus's order it does not.
        ("a driving SET_RPM after BALANCE in the record, stamped before it", [(0.0, "OFF"), (0.1, "OFF"),
         (0.2, "OFF"), (0.2, "BALANCE"), (0.3, "BALANCE")], [(0.18, 0.18, "arm_console", "console balance arm")],
         [(0.15, 92, 4)], []),
        ("armed with no console arm and no 3 s press", off_then_balance, [], [], ["arming"]),
        ("ESTOP, then BALANCE in the next 0x400", [(0.0, "OFF"), (0.1, "ESTOP"), (0.2, "BALANCE")],
         [(0.15, 0.15, "arm_console", "console balance arm")], [], ["latch"]),
        ("a driving SET_RPM 200 ms after a console estop", off_then_balance,
         console_arm + [(0.35, 0.35, "stop", "console balance estop")], [(0.55, 92, 5)], ["stop"]),
    ]
    failed = 0
    for what, tel, inputs, rpm, expected in cases:
        got = sorted({rule for rule, _, _ in check(inputs, tel, rpm)[0]})
        ok = got == sorted(expected)
        failed += not ok
        print(f"{'ok  ' if ok else 'FAIL'} {what}: {', '.join(got) or 'no violation'}"
              f"{'' if ok else ' (expected: ' + (', '.join(expected) or 'none') + ')'}")
    return 1 if failed else 0


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("saulctl")
    ap.add_argument("--seed", default="1", help="a seed, or several separated by commas (run at once)")
    ap.add_argument("--duration", type=float, default=60, help="seconds of random inputs (real time)")
    ap.add_argument("--keep", help="keep the record and the input log in this directory")
    a = ap.parse_args()
    seeds = [int(x) for x in a.seed.split(",")]
    if len(seeds) > 1:
        return run_at_once(a, seeds)
    a.seed = seeds[0]
    raise_priority()
    work = tempfile.mkdtemp(prefix="saul-random-")
    d = Driver(a.saulctl, a.seed, a.duration, work)
    try:
        d.start()
        d.run()
    finally:
        try:
            d.stop()
        except Exception as e:  # noqa: BLE001 - the record is checked whatever happened to the processes
            print(f"sim_random: stopping: {e}", file=sys.stderr)
    tel, rpm = load(d.record)
    violations, armings, inputs_near, starved = check(d.inputs, tel, rpm)
    with open(os.path.join(work, "inputs.txt"), "w") as f:
        for t0, t1, kind, text in d.inputs:
            f.write(f"{t0:.3f} {t1:.3f} {kind:11s} {text}\n")
    frames = sum(1 for _ in open(d.record))
    span = (tel[-1][0] - tel[0][0]) if tel else 0
    latches = sum(1 for (ta, sa), (tb, sb) in zip(tel, tel[1:]) if sb in LATCHED and sa != sb)
    print(f"sim_random seed {a.seed}: {len(d.inputs)} inputs, {frames} frames over {span:.1f} s, "
          f"{len(armings)} armings, {latches} latches, {sum(1 for _, e, _ in rpm if e)} SET_RPM frames driving")
    left_out = sum(hi - lo for lo, hi in starved)
    if starved:
        print(f"sim_random: {len(starved)} stretches ({left_out:.1f} s) left out: the host starved the simulator")
    for rule, t, what in violations:
        print(f"VIOLATION {rule} at {t:.3f}: {what}\n  inputs of the 10 s before (wall time, kind, input):")
        for i in inputs_near(t):
            print(f"    {i[0]:.3f} {i[2]:11s} {i[3]}")
    if a.keep:
        os.makedirs(a.keep, exist_ok=True)
        for name in ("bus.jsonl", "inputs.txt", "sniff.err"):
            shutil.copy(os.path.join(work, name), a.keep)
    shutil.rmtree(work, ignore_errors=True)
    if len(armings) == 0 or not tel:
        print("sim_random: the run reached no arming: the inputs did not test the rules", file=sys.stderr)
        return 1
    if left_out > span / 5:
        print("sim_random: more than a fifth of the run left out: not tested (a machine too busy)", file=sys.stderr)
        return 1
    print(f"{0 if violations else 1} passed, {1 if violations else 0} failed")
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
