#!/usr/bin/env python3
"""saulctl replay of serial captures onto a pseudo-terminal: exact bytes, the motion rule, timing, usage errors.

saulctl writes to the slave side of a pty opened here; a thread reads the master side until the kernel says every
slave is closed (EIO, which Linux gives only after the buffered bytes have been read), so the bytes compared are all
the bytes saulctl wrote, with no waiting on time.

The expected bytes are computed here, independently of libsaulproto: the serial log is parsed with a regular
expression, each link's frames are found by a Python reading of docs/protocol.md (inter-board CRC-8/MAXIM frames,
CRSF CRC-8/DVB-S2 frames, Pride checksum frames; at each byte, a frame starts there or the byte is in no frame), and
the frames that can move motors (inter-board RC_CMD without the kill flag, CRSF RC channels without CH6 estop, every
Pride VCU command) are cut out. Every other byte must arrive as captured.

Usage: replay_serial_peer.py SAULCTL ROOT
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

from clitest import Checks, Saulctl, finish
from ptyfake import Pty

saulctl = Saulctl(sys.argv[1])
CAPTURES = os.path.join(sys.argv[2], "captures")
checks = Checks()
check = checks.check
tmp = tempfile.mkdtemp(prefix="saul_replay_serial_")


# ---- an independent reading of the three link protocols -------------------------------------------------------------

def crc8_maxim(data):  # reflected 0x31 = 0x8C, init 0
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8C if crc & 1 else crc >> 1
    return crc


def crc8_dvb_s2(data):  # 0xD5, MSB first, init 0
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0xD5) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


assert crc8_maxim(b"123456789") == 0xA1 and crc8_dvb_s2(b"123456789") == 0xBC  # the check values (protocol.md)

IB_LENGTHS = {0x01: 5, 0x02: 5, 0x03: 1, 0x10: 5, 0x11: 4, 0x12: 3}


def ib_frame_at(b, p):
    """(size, motion) of an inter-board frame starting at p, or None."""
    if b[p] != 0xAA or p + 3 > len(b):
        return None
    length, kind = b[p + 1], b[p + 2]
    if IB_LENGTHS.get(kind) != length or p + 4 + length > len(b):
        return None
    if crc8_maxim(b[p + 2:p + 3 + length]) != b[p + 3 + length]:
        return None
    motion = kind == 0x01 and not (b[p + 7] & 0x02)  # RC_CMD flags byte, bit 1 = kill
    return 4 + length, motion


def s8(v):
    return v - 256 if v > 127 else v


def pride_frame_at(b, p):
    if p + 6 > len(b) or (b[p], b[p + 1]) not in ((0xFE, 0x54), (0x4A, 0x01)):
        return None
    if sum(b[p:p + 6]) & 0xFF != 0xFF:
        return None
    if b[p] == 0xFE:  # VCU command: SP 0..0x0E, FB and LR -100..100
        if b[p + 2] > 0x0E or not -100 <= s8(b[p + 3]) <= 100 or not -100 <= s8(b[p + 4]) <= 100:
            return None
        return 6, True
    return 6, False


def crsf_ch_us(payload, ch):
    ticks = (int.from_bytes(payload[:22], "little") >> (11 * ch)) & 0x7FF
    d = int((ticks - 172) * 1024 * 2 / 1639)  # C division: toward zero
    return (d + 988 * 2 + 1) // 2


def crsf_frame_at(b, p):
    if b[p] not in (0xC8, 0x00, 0xEA, 0xEC, 0xEE) or p + 2 > len(b):
        return None
    length = b[p + 1]
    if not 2 <= length <= 62 or p + 2 + length > len(b):
        return None
    body = b[p + 2:p + 1 + length]
    if crc8_dvb_s2(body) != b[p + 1 + length]:
        return None
    motion = body[0] == 0x16 and not (len(body) - 1 >= 22 and crsf_ch_us(body[1:], 5) > 1500)
    return 2 + length, motion


FRAME_AT = {"interboard": ib_frame_at, "pride": pride_frame_at, "crsf": crsf_frame_at}


def keep_mask(data, protocol):
    """Per byte: True when it goes out without --allow-motion. Also returns the number of motion frames."""
    keep, p, motion = [True] * len(data), 0, 0
    at = FRAME_AT[protocol]
    while p < len(data):
        f = at(data, p)
        if f is None:
            p += 1
            continue
        size, is_motion = f
        if is_motion:
            motion += 1
            for i in range(p, p + size):
                keep[i] = False
        p += size
    return keep, motion


LINE = re.compile(r"^\((\d+)\.(\d+)\) (\S+) (\S+) ([0-9A-Fa-f]+|-)")


def read_serial_log(path):
    """[(time_s, link, protocol, bytes)] of a serial log."""
    chunks = []
    for line in open(path):
        m = LINE.match(line)
        if m:
            data = b"" if m.group(5) == "-" else bytes.fromhex(m.group(5))
            chunks.append((int(m.group(1)) + int(m.group(2)) / 10 ** len(m.group(2)), m.group(3), m.group(4), data))
    return chunks


def expected(path):
    """(all bytes, bytes without motion frames, motion frames, chunk times with something left) of a one-link log."""
    chunks = read_serial_log(path)
    data = b"".join(c[3] for c in chunks)
    keep, motion = keep_mask(data, chunks[0][2])
    kept, times, i = bytearray(), [], 0
    for t, _, _, b in chunks:
        part = bytes(b[j - i] for j in range(i, i + len(b)) if keep[j])
        if part:
            times.append(t)
        kept += part
        i += len(b)
    return data, bytes(kept), motion, times


# ---- the pty and saulctl ---------------------------------------------------------------------------------------------

def replay(capture, args, to_suffix="", feed=None):
    """saulctl replay CAPTURE --to serial:PTY[SUFFIX] ARGS; returns (exit code, stdout, stderr, bytes received, pty).

    The pty's bytes are collected by a thread and drained once saulctl has ended, so they are all it wrote."""
    p = Pty()
    p.collect_in_background()
    proc = saulctl.start(["replay", capture, "--to", "serial:" + p.path + to_suffix] + args,
                         stdin=subprocess.PIPE if feed is not None else subprocess.DEVNULL)
    code, out, err = finish(proc, timeout=60, feed=feed)
    return code, out, err, p.drain(), p


run = saulctl.run


# ---- inter-board: captures/interboard_uart.serial --------------------------------------------------------------------
# 8 chunks: rc_cmd (throttle 500, armed: motion), state, noise 00 55, sensor, fault, a fault with a bad CRC, led_cmd,
# buzzer.
ib = os.path.join(CAPTURES, "interboard_uart.serial")
ib_all, ib_kept, ib_motion, _ = expected(ib)
check("the expected inter-board stream (Python reading) leaves out the one rc_cmd",
      ib_motion == 1 and len(ib_all) - len(ib_kept) == 9 and ib_kept == ib_all[9:], ib_kept.hex())

code, out, err, got, _ = replay(ib, [])
check("inter-board replay exits 0", code == 0, err)
check("inter-board: the pty receives every byte but the rc_cmd's, byte for byte", got == ib_kept,
      f"got  {got.hex()}\nwant {ib_kept.hex()}")
check("inter-board: the port follows the captured link (460800 8N1) when --to names no rate",
      "-> serial:" in err and "@460800:8N1" in err, err)
check("inter-board: the dropped-count line", "replay: dropping 1 message(s) that can move motors (1 per pass: rc_cmd 1)"
      in err, err)
check("inter-board: the report counts the rc_cmd left out and the bytes written",
      f"7 chunks written of 8 read ({len(ib_kept)} of {len(ib_all)} bytes)" in err
      and "not sent: 1 message(s) that can move motors (rc_cmd 1; 9 bytes)" in err, err)
check("inter-board: the lateness report (p50, p99, max, later than 1 ms)",
      re.search(r"replay: lateness p50 \d+ us, p99 \d+ us, max \d+ us; \d+ of 7 chunks later than 1 ms", err), err)

code, out, err, got, _ = replay(ib, ["--allow-motion"])
check("--allow-motion: the whole capture, byte for byte", code == 0 and got == ib_all,
      f"{code} got {got.hex()}\n{err}")
check("--allow-motion: nothing dropped, the motion message counted as sent",
      "dropping" not in err and "1 message(s) that can move motors sent (--allow-motion)" in err, err)

code, out, err, got, _ = replay(ib, ["--json", "--loop", "3", "--speed", "2"])
try:
    j = json.loads(out)
except ValueError:
    j = {}
check("--json --loop 3 --speed 2: three passes of the kept bytes, and the report as JSON",
      code == 0 and got == ib_kept * 3 and j.get("passes") == 3 and j.get("motion_dropped") == 3
      and j.get("motion_dropped_by_type") == {"rc_cmd": 3} and j.get("bytes_sent") == 3 * len(ib_kept)
      and j.get("protocol") == "interboard" and j.get("lateness", {}).get("chunks") == 21,
      f"{code} {out} {err}")
if j.get("lateness"):
    l = j["lateness"]
    print(f"     lateness over {l['chunks']} chunks: p50 {l['p50_us']} us, p99 {l['p99_us']} us, "
          f"max {l['max_us']} us, {l['later_than_1ms']} later than 1 ms")

code, out, err, got, _ = replay(ib, ["--step"], feed=b"\n\nq\n")
check("--step: one chunk per Enter, q stops", code == 0 and got == ib_kept[:9 + 2] and "stopped early" in err,
      f"{code} {got.hex()} {err}")

# the same bytes through sigrok-cli's export of the logic capture: one chunk per byte, protocol guessed
code, out, err, got, _ = replay(os.path.join(CAPTURES, "interboard_uart.sigrok.txt"), ["--samplerate", "10M"])
check("sigrok-cli export of the same wire: protocol guessed, same bytes out at 460800 8N1",
      code == 0 and got == ib_kept and "interboard, guessed from the bytes" in err and "@460800:8N1" in err,
      f"{code} {got.hex()} {err}")

# ---- Pride: captures/pride_uart.serial, both directions of the one wire ---------------------------------------------
pride = os.path.join(CAPTURES, "pride_uart.serial")
pr_all, pr_kept, pr_motion, pr_times = expected(pride)
check("the expected Pride stream keeps the 4 controller_status frames only",
      pr_motion == 4 and pr_kept == bytes.fromhex("4A010264004E") * 4, pr_kept.hex())
code, out, err, got, pty = replay(pride, ["--speed", "0.05"])
check("Pride replay: only the controller_status bytes arrive, byte for byte", code == 0 and got == pr_kept,
      f"{code} {got.hex()} {err}")
check("Pride: the port runs 38400 8E1 (the captured link)", "@38400:8E1" in err, err)
check("Pride: the dropped-count line names vcu_command",
      "dropping 4 message(s) that can move motors (4 per pass: vcu_command 4)" in err, err)
# timing: the kept chunks are 5 ms apart in the file (15 ms from first to last), 300 ms at --speed 0.05
span = pty.arrivals[-1][0] - pty.arrivals[0][0] if len(pty.arrivals) >= 2 else 0
want = (pr_times[-1] - pr_times[0]) / 0.05
check(f"Pride: the original timing survives --speed 0.05 (first to last byte {span:.3f} s, file says {want:.3f} s)",
      0.6 * want <= span <= want + 1.0, f"{span:.3f}")

code, out, err, got, _ = replay(pride, ["--allow-motion", "--speed", "max"], to_suffix="@38400")
check("Pride --allow-motion --speed max, --to with a rate only: all bytes, framing still 8E1",
      code == 0 and got == pr_all and "@38400:8E1" in err, f"{code} {got.hex()} {err}")

# ---- CRSF: a capture made here (captures/ has no CRSF sample) ------------------------------------------------------

def crsf_frame(kind, payload):
    body = bytes([kind]) + payload
    return bytes([0xC8, len(body) + 1]) + body + bytes([crc8_dvb_s2(body)])


def rc_frame(ticks):
    return crsf_frame(0x16, sum(t << (11 * i) for i, t in enumerate(ticks)).to_bytes(22, "little"))


centred = rc_frame([992] * 16)
assert centred.hex().upper() == ("C81816E0031FF8C0073EF0810F7CE0031FF8C0073EF0810F7CAD"), centred.hex()  # T1 golden
drive = rc_frame([992, 1811] + [992] * 14)                      # full throttle: motion
estop = rc_frame([992, 1811, 992, 992, 1811, 1811] + [992] * 10)  # CH6 high: estop, goes out
stats = bytes.fromhex("C80C143C3E640900040337620895")            # LINK_STATISTICS (T3)
crsf_log = os.path.join(tmp, "crsf.serial")
with open(crsf_log, "w") as f:
    f.write("# CRSF receiver -> IO board, made by replay_serial_peer.py\n")
    rows = [(0.000, centred), (0.004, stats), (0.008, b"\x55" + drive[:10]), (0.009, drive[10:] + estop),
            (0.012, bytes.fromhex("C83E") + centred), (0.016, stats), (0.020, drive)]
    for t, b in rows:
        f.write(f"(1700000000.{int(t * 1e6):06d}) serial:/dev/ttyUSB2@420000:8N1 crsf {b.hex().upper()}\n")
cr_all, cr_kept, cr_motion, _ = expected(crsf_log)
check("the expected CRSF stream leaves out 4 RC frames and keeps the estop one", cr_motion == 4
      and cr_kept == stats + b"\x55" + estop + bytes.fromhex("C83E") + stats, cr_kept.hex())
code, out, err, got, _ = replay(crsf_log, [])
check("CRSF replay at 420000 baud: RC frames left out, the rest byte for byte",
      code == 0 and got == cr_kept and "@420000:8N1" in err and "(4 per pass: rc_channels 4)" in err,
      f"{code} got {got.hex()}\nwant {cr_kept.hex()}\n{err}")

# ---- usage errors: a capture of one kind onto a link of the other ----------------------------------------------------
def usage_lines(err):
    """The error lines of a usage error: saulctl ends every one with a pointer to the verb's --help
    ("saulctl replay: see 'saulctl replay --help'"), which is not part of the one-line message itself."""
    lines = err.strip().splitlines()
    return lines[:-1] if len(lines) > 1 and lines[-1].endswith("--help'") else lines


code, out, err = run(["replay", os.path.join(CAPTURES, "robot_bus.log"), "--to", "serial:/dev/ttyUSB0"])
lines = usage_lines(err)
check("a CAN capture onto a serial link: exit 2, one line naming the fix",
      code == 2 and len(lines) == 1 and "CAN frames" in lines[0] and "--link can0" in lines[0], f"{code} {err}")
for link in ("can0", "slcan:/dev/ttyACM0"):
    code, out, err = run(["replay", ib, "--to", link])
    lines = usage_lines(err)
    check(f"a serial capture onto {link}: exit 2, one line naming the fix",
          code == 2 and len(lines) == 1 and "serial bytes" in lines[0] and "--link serial:" in lines[0], f"{code} {err}")
code, out, err = run(["replay", os.path.join(CAPTURES, "interboard_uart.sigrok.txt"), "--protocol", "raw",
                      "--to", "serial:/dev/ttyUSB0@460800"])
check("a raw link replayed without motion: exit 2, asks for --protocol or --allow-motion",
      code == 2 and "--protocol" in err and "--allow-motion" in err, f"{code} {err}")
code, out, err = run(["replay", ib, "--id", "300", "--to", "serial:/dev/ttyUSB0"])
check("--id on a serial capture: exit 2", code == 2 and "--from" in err, f"{code} {err}")
code, out, err = run(["replay", "--help"])
check("--help lists the serial messages that are left out",
      "inter-board rc_cmd" in out and "CRSF rc_channels" in out and "Pride vcu_command" in out, out)

shutil.rmtree(tmp)
checks.exit()
