#!/usr/bin/env python3
"""saulctl record and replay against a fake CANable (slcan) and a fake serial link, each on a pseudo-terminal.

record: saulctl opens the pty, we send slcan frames (or raw inter-board bytes), then Ctrl-C (SIGINT); the file must
hold every frame and be complete (saulctl decode reads it without a corrupt record).
replay: saulctl opens the pty and sends the capture's frames; we read them and check the exact bytes, their order,
--map, --no-motion, motion left out without --yes (--allow-motion), --id, --loop, --step, and that timing gaps survive (loose bounds).

Expected bytes are written out by hand from the slcan syntax (t<id:3><len><data>, T<id:8><len><data>). Waiting is
always for a condition (bytes arriving, a line on stderr, the process ending) with a bounded timeout; nothing
sleeps to synchronise.

Usage: fake_recording.py SAULCTL
"""
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from clitest import Checks, Saulctl, finish, wait_stderr_line
from ptyfake import Pty

saulctl = Saulctl(sys.argv[1])
start = saulctl.start
checks = Checks()
check = checks.check
OPEN = b"C\rS6\rO\r"
tmp = tempfile.mkdtemp(prefix="saul_rec_")


def decode(path):
    return saulctl.run(["decode", path])


# ---- record ---------------------------------------------------------------------------------------------------------
# What the fake adapter reports: a velocity command, telemetry A, a VESC SET_RPM (29-bit) and an acknowledgement.
SLCAN_IN = b"t3004E8030CFE\rt40070AFF2C012C0101\rT0000034440000008F\rt4023020000\r"
EXPECT_LINES = ["300#E8030CFE", "400#0AFF2C012C0101", "00000344#0000008F", "402#020000"]

for ext in ("log", "pcapng", "asc", "mcap"):
    out_file = os.path.join(tmp, "rec." + ext)
    p = Pty()
    proc = start(["record", "slcan:" + p.path, "-o", out_file])
    p.read_until(lambda b: b.endswith(OPEN))
    p.send(SLCAN_IN)
    proc.send_signal(signal.SIGINT)  # Ctrl-C right after the frames: nothing may be lost
    code, out, err = finish(proc, timeout=15)
    check(f"record to .{ext}: Ctrl-C exits 0 and reports 4 frames", code == 0 and "record: 4 frames" in err,
          f"{code} {err}")
    dcode, dout, derr = decode(out_file)
    lines = [l for l in dout.splitlines() if l]
    ok = dcode == 0 and len(lines) == 4 and all(e in l for e, l in zip(EXPECT_LINES, lines)) \
        and " 0 corrupt lines" in derr
    check(f"the .{ext} file is complete: decode reads the 4 frames in order, none corrupt", ok, dout + derr)
    if ext == "log":
        check("the recorded 0x300 decodes", "velocity_cmd speed_mmps=1000 steer_mrad=-500" in dout, dout)
        check("the recording's interface is can0 (for canplayer)", all(" can0 " in l for l in lines), dout)
    p.close()

# a serial link: raw inter-board bytes, written as a serial log
p = Pty()
serial_file = os.path.join(tmp, "uart.serial")
proc = start(["record", "serial:" + p.path + "@460800", "-o", serial_file])
seen = wait_stderr_line(proc, "Ctrl-C to stop")
p.send(bytes.fromhex("AA0501F40106FF010F" "AA05102EFB2C010151"))  # rc_cmd and state (tests/unit golden bytes)
proc.send_signal(signal.SIGINT)
code, out, err = finish(proc, timeout=15)
check("record of a serial link: Ctrl-C exits 0 with 18 bytes", code == 0 and "record: 18 bytes" in err,
      f"{code} {seen} {err}")
dcode, dout, derr = decode(serial_file)
check("the serial log decodes with the inter-board decoder (named by the 460800 baud rate)",
      dcode == 0 and "rc_cmd throttle=500 steer=-250 flags=1" in dout
      and "state pitch=-12.34° pid_out=300 error_state=1" in dout
      and "(interboard): 2 frames, 0 crc errors" in derr, dout + derr)
p.close()

# ---- replay ---------------------------------------------------------------------------------------------------------
capture = os.path.join(tmp, "bus.log")
with open(capture, "w") as f:
    f.write("(1700000000.000000) can0 400#0AFF2C012C0101\n"    # telemetry
            "(1700000000.100000) can0 300#E8030CFE\n"          # velocity: can move motors
            "(1700000000.200000) can0 401#B00464FBB09A11\n"    # telemetry B
            "(1700000000.250000) can0 302#01\n"                # mode balance: can move motors
            "(1700000000.300000) can0 00000344#0000008F\n"     # VESC SET_RPM: can move motors
            "(1700000000.400000) can0 402#020000\n")           # ack
T400 = b"t40070AFF2C012C0101\r"
T300 = b"t3004E8030CFE\r"
T310 = b"t3104E8030CFE\r"
T401 = b"t4017B00464FBB09A11\r"
T302 = b"t302101\r"
T344 = b"T0000034440000008F\r"
T402 = b"t4023020000\r"


def replay(args, expect, stdin=subprocess.DEVNULL, feed=None):
    """Runs saulctl replay onto a fresh pty; returns (code, err, bytes after OPEN, arrival times per frame)."""
    p = Pty()
    proc = start(["replay", capture, "--to", "slcan:" + p.path] + args, stdin=stdin)
    if feed is not None:
        proc.stdin.write(feed)
        proc.stdin.close()
        proc.stdin = None  # already closed: communicate() must not flush it
    got = p.read_until(lambda b: b.startswith(OPEN) and b[len(OPEN):].startswith(expect) and b.endswith(b"C\r")
                       and len(b) >= len(OPEN) + len(expect) + 2, timeout=10)
    code, out, err = finish(proc, timeout=15)
    got = p.read_until(lambda b: False, timeout=0.05) if code is None else got
    # arrival time of each frame's last byte
    times, pos, total = [], 0, b""
    for t, chunk in p.arrivals:
        total += chunk
        while True:
            end = total.find(b"\r", pos)
            if end < 0:
                break
            times.append(t)
            pos = end + 1
    p.close()
    return code, err, got[len(OPEN):] if got.startswith(OPEN) else got, times[3:]  # the first 3 CRs close OPEN


code, err, got, times = replay(["--no-motion"], T400 + T401 + T402)
check("replay --no-motion sends exactly 400, 401, 402 in order, then closes the channel",
      code == 0 and got == T400 + T401 + T402 + b"C\r", f"{code} {got!r} {err}")
check("replay --no-motion says how many frames it dropped", "3 that can move motors (--allow-motion sends them)" in err, err)
check("replay reports its lateness (p50, p99, max, later than 1 ms)",
      "lateness p50" in err and "p99" in err and "later than 1 ms" in err, err)
if len(times) >= 3:
    gap1, gap2 = times[1] - times[0], times[2] - times[1]  # logged 200 ms and 200 ms apart
    check("timing survives: gaps of 200 ms arrive 150..600 ms apart", 0.15 <= gap1 <= 0.6 and 0.15 <= gap2 <= 0.6,
          f"{gap1:.3f} {gap2:.3f}")
else:
    check("timing survives: gaps of 200 ms arrive 150..600 ms apart", False, repr(times))

code, err, got, _ = replay(["--map", "300=310", "--no-motion"], T400 + T310 + T401 + T402)
check("--map 300=310 sends the velocity frame as 0x310 (which moves nothing) in its place",
      code == 0 and got == T400 + T310 + T401 + T402 + b"C\r", f"{code} {got!r} {err}")

code, err, got, _ = replay(["--yes"], T400 + T300 + T401 + T302 + T344 + T402)
check("replay --yes sends all six frames, motion included, in order",
      code == 0 and got == T400 + T300 + T401 + T302 + T344 + T402 + b"C\r", f"{code} {got!r} {err}")

code, err, got, _ = replay([], T400 + T401 + T402)
check("without --allow-motion the motion frames are left out by default, and counted before and after",
      code == 0 and got == T400 + T401 + T402 + b"C\r"
      and "replay: dropping 3 frame(s) that can move motors" in err
      and "3 that can move motors (--allow-motion sends them)" in err, f"{code} {got!r} {err}")

code, err, got, times = replay(["--id", "400,401", "--speed", "2"], T400 + T401)
check("--id 400,401 sends only those (no motion frame, so no question)",
      code == 0 and got == T400 + T401 + b"C\r", f"{code} {got!r} {err}")
if len(times) >= 2:
    check("--speed 2 halves the 200 ms gap (arrives 60..400 ms apart)", 0.06 <= times[1] - times[0] <= 0.4,
          f"{times[1] - times[0]:.3f}")

code, err, got, _ = replay(["--no-motion", "--loop", "2", "--speed", "4"], (T400 + T401 + T402) * 2)
check("--loop 2 sends the file twice", code == 0 and got == (T400 + T401 + T402) * 2 + b"C\r",
      f"{code} {got!r} {err}")

code, err, got, _ = replay(["--no-motion", "--step"], T400 + T401, stdin=subprocess.PIPE, feed=b"\n\nq\n")
check("--step sends one frame per Enter and stops at q", code == 0 and got == T400 + T401 + b"C\r"
      and "stopped early" in err, f"{code} {got!r} {err}")

code, out, err = finish(start(["replay", capture, "--to", "slcan:/dev/null", "--map", "300", "--no-motion"]))
check("a malformed --map is a usage error (exit 2)", code == 2 and "FROM=TO" in err, f"{code} {err}")
code, out, err = finish(start(["replay", os.path.join(tmp, "missing.log"), "--to", "slcan:/dev/null"]))
check("a missing capture exits 1 and names it", code == 1 and "missing.log" in err, f"{code} {err}")

shutil.rmtree(tmp)
checks.exit()
