#!/usr/bin/env python3
"""saulctl against a fake CANable (slcan firmware) on a pseudo-terminal.

Each scenario starts saulctl with --link slcan:/dev/pts/N, reads exactly the bytes it writes, answers like the
robot would (0x402 acknowledgements, telemetry), and checks the output and exit code. Expected bytes are written
out by hand from docs/protocol.md, never produced by saulctl. Waiting is always for a condition (bytes arriving,
the process ending) with a bounded timeout; nothing sleeps to synchronise.

Usage: fake_canable.py SAULCTL
"""
import os
import sys

from clitest import Checks, Saulctl, finish
from ptyfake import Pty

SAULCTL = sys.argv[1]
start = Saulctl(SAULCTL).start
checks = Checks()
check = checks.check


OPEN = b"C\rS6\rO\r"


def ack(command, seq, result):
    return b"t4023%02X%02X%02X\r" % (command, seq, result)


# 1. mode off: exact bytes, applied.
p = Pty()
proc = start(["mode", "off", "--link", "slcan:" + p.path, "--timeout", "2s"])
got = p.read_until(lambda b: b.endswith(b"t302100\r"))
check("mode off writes C S6 O then 302#00", got == OPEN + b"t302100\r", repr(got))
p.send(ack(0x02, 0, 0))
code, out, err = finish(proc)
check("mode off applied exits 0", code == 0 and "mode off: applied" in out, f"{code} {out} {err}")
p.close()

# 2. mode balance without --yes in a script: refused before anything is written.
p = Pty()
proc = start(["mode", "balance", "--link", "slcan:" + p.path])
code, out, err = finish(proc)
got = p.read_until(lambda b: False, timeout=0.2)
check("mode balance without --yes exits 2 and writes nothing", code == 2 and got == b"" and "--yes" in err,
      f"{code} {got!r} {err}")
p.close()

# 3. mode balance --yes, robot not armed: rejected_not_allowed -> exit 1 with the hint.
p = Pty()
proc = start(["mode", "balance", "--yes", "--link", "slcan:" + p.path, "--timeout", "2s"])
got = p.read_until(lambda b: b.endswith(b"t302101\r"))
check("mode balance writes 302#01", got == OPEN + b"t302101\r", repr(got))
p.send(ack(0x02, 0, 2))
code, out, err = finish(proc)
check("mode balance rejected exits 1 and says to arm first", code == 1 and "armed" in err, f"{code} {out} {err}")
p.close()

# 4. pid: three 0x301 frames of one sequence number, then the ack of that sequence.
p = Pty()
proc = start(["pid", "1.5", "0.25", "0.05", "--link", "slcan:" + p.path, "--timeout", "2s", "--json"])
got = p.read_until(lambda b: b.count(b"t3018") == 3 and b.endswith(b"\r"))
lines = got[len(OPEN):].split(b"\r")[:-1]
seqs = {l[7:9] for l in lines}
ok = (got.startswith(OPEN) and len(lines) == 3 and len(seqs) == 1 and
      lines[0][:7] + lines[0][9:] == b"t301800" + b"00000000C03F" and
      lines[1][:7] + lines[1][9:] == b"t301801" + b"00000000803E" and
      lines[2][:7] + lines[2][9:] == b"t301802" + b"0000CDCC4C3D")
check("pid writes Kp 1.5, Ki 0.25, Kd 0.05 with one sequence number", ok, repr(got))
seq = int(next(iter(seqs)), 16) if len(seqs) == 1 else 0
p.send(ack(0x01, (seq + 1) & 0xFF, 0))  # an ack for another set must be ignored
p.send(ack(0x01, seq, 0))
code, out, err = finish(proc)
check("pid waits for the ack of its own sequence and exits 0", code == 0 and '"status":"applied"' in out,
      f"{code} {out} {err}")
p.close()

# 5. config 20 deg / 1200 mm/s.
p = Pty()
proc = start(["config", "--tilt-limit", "20", "--max-speed", "1200", "--link", "slcan:" + p.path, "--timeout", "2s"])
got = p.read_until(lambda b: b.endswith(b"t3034D007B004\r"))
check("config writes 303#D007B004", got == OPEN + b"t3034D007B004\r", repr(got))
p.send(ack(0x03, 0, 1))
code, out, err = finish(proc)
check("config rejected out of range exits 1", code == 1 and "rejected_out_of_range" in err, f"{code} {err}")
p.close()

# 6. config out of the 5..25 degree range is refused before anything is sent.
code, out, err = finish(start(["config", "--tilt-limit", "30", "--max-speed", "100", "--link", "slcan:/dev/null"]))
check("config --tilt-limit 30 is a usage error (exit 2)", code == 2 and "5..25" in err, f"{code} {err}")

# 7. estop with nobody answering: the frame goes out at once, then exit 3.
p = Pty()
proc = start(["estop", "--link", "slcan:" + p.path, "--timeout", "300ms"])
got = p.read_until(lambda b: b.endswith(b"t302103\r"))
check("estop writes 302#03 right after opening", got == OPEN + b"t302103\r", repr(got))
code, out, err = finish(proc)
check("estop without acknowledgement exits 3 and says so", code == 3 and "no acknowledgement" in err, f"{code} {err}")
p.close()

# 8. mode off with no answer: exit 3.
p = Pty()
proc = start(["mode", "off", "--link", "slcan:" + p.path, "--timeout", "200ms"])
code, out, err = finish(proc)
check("mode off without acknowledgement exits 3", code == 3, f"{code} {err}")
p.close()

# 9. drive: 0x300 frames of 200 mm/s, then a zero-speed frame last; the robot's telemetry does not disturb it.
p = Pty()
proc = start(["drive", "--yes", "--speed", "200", "--steer", "-100", "--for", "300ms", "--link", "slcan:" + p.path])
p.read_until(lambda b: b.count(b"t3004C8009CFF\r") >= 1)
p.send(b"t4007000000000C80001\r")
code, out, err = finish(proc)
got = p.read_until(lambda b: b.endswith(b"t300400000000\rC\r"), timeout=1)
frames = got[len(OPEN):].split(b"\r")[:-1]
moving = [f for f in frames if f == b"t3004C8009CFF"]
check("drive streams 300#C8009CFF, then 300#00000000, then closes the channel (C)",
      got.startswith(OPEN) and frames[-2:] == [b"t300400000000", b"C"] and len(moving) == len(frames) - 2 and
      len(moving) == 6, repr(got))  # k = 0..5 on 50 ms deadlines within 300 ms: exactly 6
check("drive exits 0 and reports the frames", code == 0 and "zero speed" in out, f"{code} {out} {err}")
p.close()

# 10. drive refuses without --yes, and above the speed cap.
code, out, err = finish(start(["drive", "--speed", "100", "--for", "1s", "--link", "slcan:/dev/null"]))
check("drive without --yes exits 2", code == 2, f"{code} {err}")
code, out, err = finish(start(["drive", "--yes", "--speed", "900", "--for", "1s", "--link", "slcan:/dev/null"]))
check("drive above the 500 mm/s cap exits 2 and names --speed-cap", code == 2 and "--speed-cap" in err, f"{code} {err}")

# 11. sniff decodes what the adapter reports.
p = Pty()
proc = start(["sniff", "slcan:" + p.path, "--count", "3"])
p.read_until(lambda b: b.endswith(OPEN))
p.send(b"t40070AFF2C012C0101\rT000009388FFFFFB50002300FA\rt3014000700000000C03F\r")
code, out, err = finish(proc)
lines = out.strip().split("\n")
check("sniff prints 3 decoded lines and exits 0",
      code == 0 and len(lines) == 3 and "telemetry_a pitch=-2.46° pid_out=300 speed_mmps=300 state=BALANCE" in lines[0]
      and "vesc_status_1 controller_id=56 erpm=-1200 current=3.5 duty=0.25" in lines[1]
      and "!wrong_dlc" in lines[2], f"{code} {out} {err}")
p.close()

# 12. The adapter vanishes mid-command: a clear one-line error, exit 1, no hang.
p = Pty()
proc = start(["sniff", "slcan:" + p.path])
p.read_until(lambda b: b.endswith(OPEN))
p.send(b"t302100\r")
p.close_master()
code, out, err = finish(proc, timeout=5)
check("sniff ends with 'disappeared' when the adapter goes away", code == 1 and "disappeared" in err, f"{code} {err}")
p.close()

# 13. monitor --json: one line per telemetry update once both frames are known.
p = Pty()
proc = start(["monitor", "--json", "--link", "slcan:" + p.path, "--duration", "3s"])
p.read_until(lambda b: b.endswith(OPEN))
p.send(b"t40070AFF2C012C0101\rt4017B00464FBB09A11\r")
# The line for the second frame is printed as soon as it arrives; end the run by closing the adapter.
out_line = proc.stdout.readline().decode()
p.close_master()
code, out, err = finish(proc)
check("monitor --json reports state, pitch, battery and fault names",
      '"state":"BALANCE"' in out_line and '"pitch":-2.46' in out_line and '"battery":39.6' in out_line
      and '"fault":"rc_loss,orin_timeout"' in out_line, out_line + err)
p.close()

# 14. A device that does not exist, and one we may not open.
code, out, err = finish(start(["mode", "off", "--link", "slcan:/dev/ttyACM97"]))
check("missing adapter: exit 1, names the device and 'saulctl ports'",
      code == 1 and "/dev/ttyACM97" in err and "saulctl ports" in err, f"{code} {err}")
if os.geteuid() == 0 and os.path.exists("/usr/bin/setpriv"):
    p = Pty()
    os.chmod(p.path, 0o600)
    proc = Saulctl("setpriv").start(["--reuid=65534", "--regid=65534", "--clear-groups", SAULCTL, "mode", "off",
                                     "--link", "slcan:" + p.path])
    code, out, err = finish(proc)
    check("permission denied: exit 1 and the dialout hint", code == 1 and "dialout" in err, f"{code} {err}")
    p.close()
else:
    print("skip permission test (needs root and setpriv to drop privileges)")

code, out, err = finish(start(["mode", "off", "--link", "bogus:thing"]))
check("a malformed link is a usage error listing the forms", code == 2 and "slcan:/dev/ttyACM0" in err, f"{code} {err}")

checks.exit()
