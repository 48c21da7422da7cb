#!/usr/bin/env python3
"""saulctl console, pride vcu, doctor and sniff --top against fakes on pseudo-terminals.

A fake board console answers command lines; a fake Pride controller on the one wire echoes every byte back and
answers with controller frames; the fake CANable sends telemetry for sniff --top. Expected bytes are worked out by
hand in the comments. Waiting is always for a condition (bytes arriving, the process ending) with a bounded
timeout; nothing sleeps to synchronise.

Usage: fake_live.py SAULCTL
"""
import json
import sys
import time

from clitest import Checks, Saulctl, finish
from ptyfake import Pty

start = Saulctl(sys.argv[1]).start
checks = Checks()
check = checks.check


# ---- console -----------------------------------------------------------------------------------------------------

STATUS_LINE = (b"report=status board=balance state=BALANCE pitch_x100=-123 pid_out=45 kp=1.5 ki=0.25 kd=0.05 "
               b"tilt_limit_x100=2000 speed_limit_pct=30 faults=0 battery_mv=24800 uptime_ms=5000\r\n")

# 1. status --json: the command line arrives, the report line is parsed into fields, exit 0.
p = Pty()
proc = start(["console", p.path, "status", "--json", "--timeout", "3s"])
got = p.read_until(lambda b: b"\n" in b)
check("console writes 'status' and a line end", got in (b"status\r\n", b"status\n"), repr(got))
p.send(b"pitch -1.23 deg, pid_out 45 permille\r\n" + STATUS_LINE + b"ok\r\n")
code, out, err = finish(proc)
try:
    j = json.loads(out)
except ValueError:
    j = {}
rep = j.get("report", {})
check("console status --json exits 0 with the report's fields",
      code == 0 and j.get("status") == "ok" and rep.get("board") == "balance" and rep.get("state") == "BALANCE"
      and rep.get("pitch_x100") == -123 and rep.get("kp") == 1.5 and rep.get("battery_mv") == 24800
      and rep.get("speed_limit_pct") == 30, f"{code} {out} {err}")
p.close()

# 2. plain text: the reply lines are printed, ok last.
p = Pty()
proc = start(["console", p.path, "status", "--timeout", "3s"])
p.read_until(lambda b: b"\n" in b)
p.send(STATUS_LINE + b"ok\r\n")
code, out, err = finish(proc)
check("console status prints the reply and exits 0", code == 0 and "report=status" in out and out.rstrip().endswith("ok"),
      f"{code} {out} {err}")
p.close()

# 3. an error reply: exit 1, the error shown.
p = Pty()
proc = start(["console", p.path, "tilt_limit", "30", "--timeout", "3s"])
got = p.read_until(lambda b: b"\n" in b)
check("console writes 'tilt_limit 30'", got.rstrip(b"\r\n") == b"tilt_limit 30", repr(got))
p.send(b"error: tilt limit must be 5 to 25 degrees (argument 1; usage: tilt_limit <deg>) [out_of_range]\r\n")
code, out, err = finish(proc)
check("console error reply exits 1 and shows it", code == 1 and "tilt limit must be 5 to 25" in err, f"{code} {out} {err}")
p.close()

# 4. no answer: exit 3 after --timeout.
p = Pty()
proc = start(["console", p.path, "status", "--timeout", "300ms"])
code, out, err = finish(proc)
check("console without an answer exits 3", code == 3 and "no 'ok'" in err, f"{code} {out} {err}")
p.close()

# ---- pride vcu ---------------------------------------------------------------------------------------------------
# VCU frame, speed level 3, FB +20 (0x14), LR -10 (0xF6):
#   FE + 54 + 03 + 14 + F6 = 0x25F, low byte 0x5F, checksum = ~0x5F = 0xA0
# neutral at speed level 3: FE + 54 + 03 = 0x155, low byte 0x55, checksum = ~0x55 = 0xAA
# controller frame, ready (0x02), battery 0x5A: 4A + 01 + 02 + 5A + 00 = 0xA7, checksum = ~0xA7 = 0x58
DRIVE = bytes([0xFE, 0x54, 0x03, 0x14, 0xF6, 0xA0])
NEUTRAL = bytes([0xFE, 0x54, 0x03, 0x00, 0x00, 0xAA])
CONTROLLER = bytes([0x4A, 0x01, 0x02, 0x5A, 0x00, 0x58])

# 5. motion without --yes in a script: refused, nothing written.
p = Pty()
proc = start(["pride", "vcu", p.path, "--fb", "20", "--lr", "-10", "--speed-level", "3", "--for", "200ms"])
code, out, err = finish(proc)
got = p.read_until(lambda b: False, timeout=0.2)
check("pride vcu motion without --yes exits 2 and writes nothing", code == 2 and got == b"" and "--yes" in err,
      f"{code} {got!r} {err}")
p.close()

# 6. the one wire: echo every byte at once; after every whole VCU frame, answer with a controller frame.
p = Pty()
proc = start(["pride", "vcu", p.path, "--fb", "20", "--lr", "-10", "--speed-level", "3", "--for", "400ms", "--yes",
              "--json"])
written = b""
end = time.monotonic() + 10
while time.monotonic() < end and proc.poll() is None:
    chunk = p.read_some(0.2)
    if not chunk:
        continue
    written += chunk
    reply = chunk
    if len(written) % 6 == 0:
        reply += CONTROLLER  # the controller's slot comes after the VCU's frame
    p.send(reply)
code, out, err = finish(proc)
while p.read_some(0.1):  # whatever was written before the exit and not yet read
    pass
written = p.buf
frames = [written[i:i + 6] for i in range(0, len(written), 6)]
lines = [json.loads(l) for l in out.splitlines() if l.startswith("{")]
last = lines[-1] if lines else {}
check("pride vcu exits 0", code == 0, f"{code} {out} {err}")
check("pride vcu writes whole frames, the first FE 54 03 14 F6 A0", len(written) % 6 == 0 and frames
      and frames[0] == DRIVE, written[:24].hex(" "))
check("pride vcu writes only drive frames, then only neutral ones",
      all(f in (DRIVE, NEUTRAL) for f in frames) and NEUTRAL in frames
      and all(f == NEUTRAL for f in frames[frames.index(NEUTRAL):]), written.hex(" "))
check("pride vcu ends with 100 ms of neutral frames (20 x FE 54 03 00 00 AA)",
      len(frames) >= 20 and frames[-20:] == [NEUTRAL] * 20 and frames.count(NEUTRAL) == 20, f"{len(frames)} frames")
check("pride vcu sent a plausible number of frames for 400 ms at 5 ms", 30 <= len(frames) <= 110, f"{len(frames)}")
check("pride vcu reports the controller (ready, battery 90) and no echo as a received frame",
      last.get("final") is True and last.get("controller", {}).get("error_byte") == 2
      and last.get("controller", {}).get("battery_charge") == 0x5A and last.get("foreign_vcu_frames") == 0
      and last.get("controller_frames", 0) > 0 and len(written) - 12 <= last.get("echo_dropped", -99) + 6 * last.get("late_echoes", 0) <= len(written)
      and last.get("frames_sent") == len(frames), f"{out} {err}")
check("pride vcu reports about 5 times a second", 1 <= len([l for l in lines if not l.get("final")]) <= 4, out)
p.close()

# ---- doctor ------------------------------------------------------------------------------------------------------

# 7. a missing device: exit 1, the device and the fix named.
proc = start(["doctor", "--link", "slcan:/dev/saul-no-such-device"])
code, out, err = finish(proc)
check("doctor on a missing device exits 1, names it and the fix",
      code == 1 and "FAIL port exists: /dev/saul-no-such-device not found" in out and "saulctl ports" in out,
      f"{code} {out} {err}")

# 8. a fake CANable that talks: port, channel and traffic ok.
p = Pty()
proc = start(["doctor", "--link", "slcan:" + p.path, "--wait", "3s"])
p.read_until(lambda b: b.endswith(b"O\r"))
p.send(b"t4008" + b"00" * 8 + b"\r")
code, out, err = finish(proc)
check("doctor sees the slcan port, channel and bus traffic",
      "ok   port exists" in out and "ok   slcan channel" in out and "ok   bus traffic" in out, f"{code} {out} {err}")
p.close()

# ---- sniff --top -------------------------------------------------------------------------------------------------

# 9. two ids, one changing byte: final table once (stdout is a pipe).
p = Pty()
proc = start(["sniff", "slcan:" + p.path, "--top", "--duration", "1500ms"])
p.read_until(lambda b: b.endswith(b"O\r"))
frames = b"".join(b"t3002%02X00\r" % i for i in range(5)) + (b"t4018" + b"00" * 8 + b"\r") * 3
p.send(frames)
code, out, err = finish(proc)
rows = {l.split()[0]: l for l in out.splitlines() if l.strip() and l.split()[0] in ("300", "401")}
check("sniff --top prints one table with a row per id", code == 0 and out.count(" COUNT ") == 1
      and "300" in rows and "401" in rows, f"{code} {out} {err}")
check("sniff --top counts and marks the changed byte", "300" in rows and " 5 " in rows["300"]
      and "04*" in rows["300"] and "401" in rows and " 3 " in rows["401"] and "*" not in rows["401"], out)
check("sniff --top shows the bus load", "bus load" in out, out)
p.close()

checks.exit()
