#!/usr/bin/env python3
"""saulctl's full-screen views (monitor, sniff --top) in a real terminal: tmux, at 80x24 and 120x40.

tmux runs saulctl in a pane of a private server; capture-pane shows what a user sees: -J joins wrapped lines (so a
line longer than the pane is a line that wrapped), -e keeps the colours. The adapter is a fake CANable on a
pseudo-terminal (tests/cli/ptyfake.py): the test sends telemetry as the robot would and reads every byte saulctl
writes, so a key press is checked on the wire (e = exactly one 302#03). Waits are for a condition (text on the
screen, bytes on the wire, the pane's process ending), bounded; nothing sleeps to synchronise.

Usage: views.py SAULCTL
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

from clitest import Checks
from ptyfake import Pty

SAULCTL = sys.argv[1]
checks = Checks()
check = checks.check

if not shutil.which("tmux"):
    print("SKIP tmux is not installed (apt-get install tmux; scripts/setup.sh installs it)")
    checks.exit()

RUNTIME = tempfile.mkdtemp(prefix="saul-views-")
SERVER = ""  # a tmux server of its own for each view (named below), so one ending cannot race the next starting
servers = []
OPEN = b"C\rS6\rO\r"
ESTOP = b"t302103\r"
ACK_MODE = b"t4023020000\r"
TEL_A_BALANCE = b"t4007F4010A00C80001\r"   # pitch 5.00, pid 10, speed 200, BALANCE
TEL_A_ESTOP = b"t4007F4010A00000003\r"     # ... speed 0, ESTOP
TEL_B = b"t4017B00464FBB09A11\r"           # 1200 / -1180 rpm, 39.6 V, faults rc_loss + orin_timeout
# VESC 68 (0x44) STATUS_1 (command 9): ERPM 12000 (00002EE0), current 3.5 A (0023), duty 0.250 (00FA)
VESC_L_1 = b"T000009448" + b"00002EE0" + b"0023" + b"00FA" + b"\r"
# VESC 68 STATUS_4 (16 = 0x10): FET 35.0 C (015E), motor 40.0 C (0190), input current 1.2 A (000C), pid pos 0
VESC_L_4 = b"T000010448" + b"015E" + b"0190" + b"000C" + b"0000" + b"\r"
# VESC 68 STATUS_5 (27 = 0x1B): tachometer 0, input voltage 39.6 V (018C), reserved
VESC_L_5 = b"T00001B448" + b"00000000" + b"018C" + b"0000" + b"\r"
ESC = "\x1b"


def tmux(*args, check_rc=True):
    r = subprocess.run(["tmux", "-L", SERVER, "-f", "/dev/null"] + list(args), capture_output=True, text=True)
    if check_rc and r.returncode != 0:
        raise RuntimeError(f"tmux {args}: {r.stderr}")
    return r.stdout


def start_pane(width, height, args):
    """A new session running saulctl ARGS in a WIDTHxHEIGHT pane; the pane stays after saulctl ends, and the shell
    around it writes saulctl's exit status to RUNTIME/rc (tmux itself may take long to reap a process)."""
    global SERVER
    if SERVER:
        tmux("kill-server", check_rc=False)
    SERVER = f"saulviews{os.getpid()}-{len(servers)}"
    servers.append(SERVER)
    rc = os.path.join(RUNTIME, "rc")
    if os.path.exists(rc):
        os.unlink(rc)
    cmd = " ".join(["env", f"SAUL_RUNTIME_DIR={RUNTIME}", SAULCTL] + args)
    tmux("new-session", "-d", "-s", "v", "-x", str(width), "-y", str(height),
         f"sh -c '{cmd}; echo $? > {rc}.tmp; mv {rc}.tmp {rc}; sleep 3600'")


def screen(colours=False, history=False):
    return tmux("capture-pane", "-p", "-J", "-t", "v", *(["-e"] if colours else []), *(["-S", "-100"] if history else []))


def wait_screen(pattern, timeout=10, colours=False):
    """The screen once pattern (a regular expression) is on it, else None."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        s = screen(colours)
        if re.search(pattern, s):
            return s
        time.sleep(0.05)  # polls the terminal's contents for the condition
    return None


def pane_exit(timeout=10):
    """saulctl's exit status once it has ended, else None."""
    rc = os.path.join(RUNTIME, "rc")
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if os.path.exists(rc):
            return int(open(rc).read().strip())
        time.sleep(0.05)
    return None


def wait_wire(p, predicate, timeout=10):
    """Reads the adapter's side until predicate(all bytes saulctl wrote) holds."""
    return predicate(p.read_until(predicate, timeout))


def fits(text, width):
    long = [l for l in text.splitlines() if len(l) > width]
    return not long, long


def coloured(text, words, sgr):
    """True when one of words appears right after an escape sequence that sets SGR parameter sgr (31 red, ...)."""
    return any(re.search(ESC + r"\[([0-9;]*;)?" + sgr + r"(;[0-9;]*)?m(" + ESC + r"\[[0-9;]*m)*" + w, text)
               for w in words)


def monitor_view(width, height):
    tag = f"{width}x{height}"
    p = Pty()  # read in this thread (read_until): closing the master must hang the adapter up at once
    start_pane(width, height, ["monitor", "--link", "slcan:" + p.path])
    check(f"monitor {tag}: opens the adapter", wait_wire(p, lambda b: b == OPEN), repr(p.buf))
    p.send(TEL_A_BALANCE + TEL_B + VESC_L_1 + VESC_L_4 + VESC_L_5)
    s = wait_screen(r"BALANCE(.|\n)*39\.60 V(.|\n)*12000", colours=False)
    check(f"monitor {tag}: state, battery and the left VESC's ERPM on screen", s is not None, screen())
    s = screen(colours=False)
    ok, long = fits(s, width)
    check(f"monitor {tag}: no line wider than {width} (capture-pane -J joins wrapped lines)", ok, long)
    check(f"monitor {tag}: VESC current, duty, temperatures, input voltage",
          re.search(r"L\s+68\s+\+12000\s+\+3\.5A\s+\+0\.25\s+35\.0\s+40\.0\s+39\.6", s) is not None, s)
    check(f"monitor {tag}: the keys are on the last line", s.rstrip("\n").splitlines()[-1].strip().startswith("e/space ESTOP"),
          s)
    c = screen(colours=True)
    check(f"monitor {tag}: colours: BALANCE green, fault bits red", coloured(c, ["BALANCE"], "32")
          and coloured(c, ["rc_loss"], "31"), repr(c[:2000]))
    # Stale: no telemetry for more than three 0x400 periods.
    check(f"monitor {tag}: a stream older than three periods is marked STALE", wait_screen(r"0x400 .*STALE") is not None,
          screen())
    # e: ESTOP at once, exactly once on the wire, acknowledged.
    tmux("send-keys", "-t", "v", "e")
    check(f"monitor {tag}: e writes exactly one 302#03", wait_wire(p, lambda b: b == OPEN + ESTOP), repr(p.buf))
    p.send(ACK_MODE + TEL_A_ESTOP + TEL_B)
    s = wait_screen(r"ESTOP: acknowledged")
    check(f"monitor {tag}: the acknowledgement is shown", s is not None, screen())
    c = wait_screen(r"STATE\s+ESTOP")
    check(f"monitor {tag}: state ESTOP in red", c is not None and coloured(screen(True), ["ESTOP "], "31"),
          repr(screen(True)[:1500]))
    # o: mode off, once.
    tmux("send-keys", "-t", "v", "o")
    check(f"monitor {tag}: o writes exactly one 302#00", wait_wire(p, lambda b: b == OPEN + ESTOP + b"t302100\r"),
          repr(p.buf))
    p.send(ACK_MODE)
    check(f"monitor {tag}: its acknowledgement is shown", wait_screen(r"mode off: acknowledged") is not None, screen())
    # Link lost: the adapter goes away; the view says so instead of freezing.
    p.close_master()
    check(f"monitor {tag}: 'LINK LOST' when the adapter goes", wait_screen(r"LINK LOST: .*disappeared") is not None,
          screen())
    tmux("send-keys", "-t", "v", "q")
    code = pane_exit()
    s = screen(history=True)
    check(f"monitor {tag}: q quits with a summary, exit 1 (the link was lost)",
          code == 1 and re.search(r"monitor: .* s on slcan:.*last state ESTOP\nmonitor: 0x400 2 frames", s) is not None
          and "1 ESTOP sent from the keyboard; last: mode off: acknowledged" in s, f"{code}\n{s}")
    check(f"monitor {tag}: exactly one 302#03 in the whole run", p.buf.count(ESTOP) == 1, repr(p.buf))
    p.close()


def top_view(width, height):
    tag = f"{width}x{height}"
    p = Pty()
    start_pane(width, height, ["sniff", "slcan:" + p.path, "--top"])
    wait_wire(p, lambda b: b == OPEN)
    frames = b"".join(b"t3002%02X00\r" % i for i in range(3)) + TEL_A_BALANCE + TEL_B + VESC_L_1
    frames += b"".join(b"t%03X1%02X\r" % (0x500 + i, i) for i in range(30))  # more ids than an 80x24 screen holds
    p.send(frames)
    s = wait_screen(r"\b300 .* 3 ")
    check(f"sniff --top {tag}: the table is up", s is not None, screen())
    s = screen()
    ok, long = fits(s, width)
    check(f"sniff --top {tag}: no line wider than {width}", ok, long)
    check(f"sniff --top {tag}: 0x300 counted 3 times", re.search(r"\b300 .*\b3\b", s) is not None, s)
    if height < 30:
        check(f"sniff --top {tag}: ids beyond the screen are counted, not wrapped",
              re.search(r"\.\.\. \d+ more ids", s) is not None, s)
    c = screen(colours=True)
    check(f"sniff --top {tag}: the changed byte of 0x300 in reverse video",
          re.search(ESC + r"\[[0-9;]*7[0-9;]*m02", c) is not None, repr(c[:1500]))
    tmux("send-keys", "-t", "v", " ")
    check(f"sniff --top {tag}: space writes exactly one 302#03", wait_wire(p, lambda b: b == OPEN + ESTOP), repr(p.buf))
    tmux("send-keys", "-t", "v", "q")
    code = pane_exit()
    check(f"sniff --top {tag}: q quits, exit 0, the table printed once more",
          code == 0 and " COUNT " in screen(history=True) and "00000944" in screen(history=True), f"{code} {screen()}")
    while p.read_some(0):  # what saulctl wrote before it ended
        pass
    check(f"sniff --top {tag}: exactly one 302#03 in the whole run", p.buf.count(ESTOP) == 1 and p.buf.endswith(b"C\r"),
          repr(p.buf))
    p.close()


try:
    for w, h in ((80, 24), (120, 40)):
        monitor_view(w, h)
        top_view(w, h)
    # Not a terminal: plain lines, one a second and on each state change.
    p = Pty()
    proc = subprocess.Popen([SAULCTL, "monitor", "--link", "slcan:" + p.path, "--duration", "3s"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                            env=dict(os.environ, SAUL_RUNTIME_DIR=RUNTIME))
    wait_wire(p, lambda b: b == OPEN)
    p.send(TEL_A_BALANCE + TEL_B)
    out, err = proc.communicate(timeout=15)
    lines = out.decode().splitlines()
    check("monitor without a terminal: plain lines with a time, no escape codes",
          proc.returncode == 0 and lines and all(re.match(r"\d+\.\d{3} ", l) for l in lines) and ESC not in out.decode()
          and any("state=BALANCE" in l and "battery=39.60V" in l for l in lines), out.decode() + err.decode())
    p.close()
finally:
    for SERVER in servers:
        tmux("kill-server", check_rc=False)
    shutil.rmtree(RUNTIME, ignore_errors=True)
checks.exit()
