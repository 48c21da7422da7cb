#!/usr/bin/env python3
"""saulctl record -o x.mcap on a serial link (a pseudo-terminal), read by @mcap/core (tests/npm/mcap_check.mjs).

Ctrl-C: the file is whole (summary, indexes) and holds the channels `saulctl convert` writes for the same bytes as a
serial log: its /serial/bytes messages, written back as a serial log and decoded by `saulctl decode --json`, equal
the bytes sent, and every decoded message equals decode's line (value, link, time), each valid against its schema.
kill -9: the streaming reader reads the chunks closed before the kill (each flush closes one), with no error.
Golden bytes: inter-board RC_CMD and STATE frames of tests/unit. Waiting is always for a condition (the file's
contents as the streaming reader sees them, a line on stderr), with a bounded timeout; nothing sleeps to synchronise.

Usage: mcap_record_serial.py SAULCTL ROOT
"""
import json
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
npm_dir = os.path.join(sys.argv[2], "tests", "npm")
checks = Checks()
check = checks.check
tmp = tempfile.mkdtemp(prefix="saul_mcap_serial_")
FRAMES = bytes.fromhex("AA0501F40106FF010F" "AA05102EFB2C010151")  # rc_cmd, state


def node(*args):
    """mcap_check.mjs's output (--single-threaded: see tests/cli/mcap.sh); None when it failed."""
    r = subprocess.run(["node", "--single-threaded", os.path.join(npm_dir, "mcap_check.mjs"), *args],
                       capture_output=True, text=True, timeout=120)
    return r.stdout if r.returncode == 0 else None


def streamed(path):
    """The recording as far as the streaming reader reads it: serial-log lines, messages per topic, its error."""
    out = node("serial_stream", path) if os.path.exists(path) else None
    return json.loads(out) if out else {"log": [], "topics": {}, "error": "unreadable"}


def sent_bytes(log):
    return bytes.fromhex("".join(line.split()[3] for line in log))


def wait_for_bytes(path, n, timeout=20.0):
    """Polls the file (not a fixed sleep) until the reader finds n bytes on /serial/bytes; what it read last."""
    end = time.monotonic() + timeout
    while True:
        s = streamed(path)
        if len(sent_bytes(s["log"])) >= n or time.monotonic() > end:
            return s


def record(path):
    p = Pty()
    proc = saulctl.start(["record", f"serial:{p.path}@460800", "-o", path])
    seen = wait_stderr_line(proc, "Ctrl-C to stop")
    return p, proc, seen


# ---- Ctrl-C: the whole file -----------------------------------------------------------------------------------------
whole = os.path.join(tmp, "uart.mcap")
p, proc, seen = record(whole)
check("record -o x.mcap on a serial link says it writes MCAP", "(MCAP)" in seen, seen)
p.send(FRAMES)
first = wait_for_bytes(whole, len(FRAMES))
check("the first bytes are in the file (a chunk closed when the link went quiet), before Ctrl-C",
      sent_bytes(first["log"]) == FRAMES, first)
p.send(FRAMES)
wait_for_bytes(whole, 2 * len(FRAMES))
proc.send_signal(signal.SIGINT)
code, out, err = finish(proc, timeout=15)
check("Ctrl-C: exit 0, 36 bytes recorded", code == 0 and "record: 36 bytes" in err, f"{code} {err}")
p.close()
s = streamed(whole)
check("the file's /serial/bytes hold exactly the bytes sent", sent_bytes(s["log"]) == 2 * FRAMES, s)
log = os.path.join(tmp, "uart.serial")
with open(log, "w") as f:
    f.write("\n".join(s["log"]) + "\n")
code, dout, derr = saulctl.run(["decode", "--json", log])
jsonl = os.path.join(tmp, "d.jsonl")
with open(jsonl, "w") as f:
    f.write(dout)
counts = node("serial", whole, jsonl, "999")  # log times in ns, the serial log's in us
check("@mcap/core reads it whole (indexed and streamed), schemas, each message = decode --json's (4 messages)",
      counts is not None and dout.count("\n") == 4, f"{counts} {dout} {derr}")
topics = json.loads(counts or "{}")
check("channels /serial/interboard/rc_cmd and /state (2 each), every chunk on /serial/bytes",
      topics.get("/serial/interboard/rc_cmd") == 2 and topics.get("/serial/interboard/state") == 2
      and topics.get("/serial/bytes") == len(s["log"]), topics)
converted = os.path.join(tmp, "c.mcap")
saulctl.run(["convert", log, converted])
check("the same channels and counts as saulctl convert of the same bytes as a serial log",
      streamed(converted)["topics"] == s["topics"], f"{streamed(converted)['topics']} {s['topics']}")

# ---- kill -9: up to the last closed chunk -------------------------------------------------------------------------
killed = os.path.join(tmp, "killed.mcap")
p, proc, seen = record(killed)
p.send(FRAMES)
wait_for_bytes(killed, len(FRAMES))
p.send(FRAMES)
before = wait_for_bytes(killed, 2 * len(FRAMES))
p.send(FRAMES)  # may reach the file before the kill or not: what is read is whole chunks either way
proc.send_signal(signal.SIGKILL)
finish(proc, timeout=15)
p.close()
s = streamed(killed)
got = sent_bytes(s["log"])
check("kill -9: both chunks written before it were in the file", sent_bytes(before["log"]) == 2 * FRAMES, before)
rc = sum(1 for i in range(0, len(got), len(FRAMES)) if len(got) - i >= 9)  # whole frames: RC_CMD is 9 bytes
st = len(got) // len(FRAMES)
check("kill -9: the streaming reader reads whole chunks with no error: a prefix of the bytes sent, >= 36",
      s["error"] is None and len(got) >= 2 * len(FRAMES) and got == (3 * FRAMES)[:len(got)], s)
check(f"kill -9: the decoded messages of those bytes ({rc} rc_cmd, {st} state)",
      s["topics"].get("/serial/interboard/rc_cmd") == rc and s["topics"].get("/serial/interboard/state") == st, s)

shutil.rmtree(tmp, ignore_errors=True)
checks.exit()
