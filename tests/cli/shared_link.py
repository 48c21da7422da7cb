#!/usr/bin/env python3
"""Several saulctl processes on one adapter (libsaulproto/include/saulproto/host/link/shared_link.hpp).

  shared_link.py SAULCTL fake   on a fake CANable (slcan) on a pseudo-terminal: exact bytes on the wire
  shared_link.py SAULCTL sim    on the simulated robot's virtual CANable (saulctl sim)

The first saulctl to open the adapter holds it and serves the others over a socket in a private directory (here a
temporary one, SAUL_RUNTIME_DIR). Checked: the bytes on the wire (one ESTOP, exactly once, whoever sends it), exit
codes, what each process sees (frames sent by one are seen by the others), the owner leaving while clients run,
the adapter disappearing, a program that is not saulctl holding the port, another user refused, a serial port
shared the same way. Expected bytes are written out by hand from docs/protocol.md (slcan: t<id><len><data>\\r).

Every wait is for a condition (bytes on the pty, a line of a process's output, a process ending), bounded; nothing
sleeps to synchronise. The ESTOP figures printed at the end (command start -> the frame written to the adapter)
are measurements, not assertions.
"""
import ctypes
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

from clitest import Checks, finish
from ptyfake import Pty

SAULCTL = sys.argv[1]
MODE = sys.argv[2] if len(sys.argv) > 2 else "fake"
checks = Checks()
check = checks.check

RUNTIME = tempfile.mkdtemp(prefix="saul-share-")  # 0700 already (mkdtemp)
ENV = dict(os.environ, SAUL_RUNTIME_DIR=RUNTIME)

OPEN = b"C\rS6\rO\r"
ESTOP = b"t302103\r"                       # 0x302, 1 byte, mode 3
ACK_MODE = b"t4023020000\r"                # 0x402: command 0x02, sequence 0, applied
TEL_A_BALANCE = b"t4007F4010A00C80001\r"   # 0x400: pitch 500, pid 10, speed 200, state 1 BALANCE
TEL_A_ESTOP = b"t4007F4010A00000003\r"     # 0x400: pitch 500, pid 10, speed 0, state 3 ESTOP
TEL_B = b"t4017B00464FBB09A11\r"           # 0x401: as in fake_canable.py (39.6 V, faults rc_loss,orin_timeout)


class Live:
    """A saulctl that keeps running; threads collect its stdout and stderr, tests wait for a pattern in them."""

    def __init__(self, args, env=None, prefix=()):
        self.started = time.monotonic()
        self.proc = subprocess.Popen(list(prefix) + [SAULCTL] + args, stdin=subprocess.DEVNULL,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env or ENV)
        self.pid = self.proc.pid
        self.text = {"out": "", "err": ""}
        self.cond = threading.Condition()
        self.readers = [threading.Thread(target=self._read, args=(s, k), daemon=True)
                        for s, k in ((self.proc.stdout, "out"), (self.proc.stderr, "err"))]
        for t in self.readers:
            t.start()

    def _read(self, stream, key):
        for raw in iter(lambda: stream.readline(), b""):
            with self.cond:
                self.text[key] += raw.decode(errors="replace")
                self.cond.notify_all()

    @property
    def out(self):
        return self.text["out"]

    @property
    def err(self):
        return self.text["err"]

    def wait_for(self, key, pattern, timeout=10):
        """True once pattern (a regular expression) is found in stdout ("out") or stderr ("err")."""
        end = time.monotonic() + timeout
        with self.cond:
            while not re.search(pattern, self.text[key]):
                left = end - time.monotonic()
                ended = self.proc.poll() is not None and not any(t.is_alive() for t in self.readers)
                if left <= 0 or ended:
                    return False
                self.cond.wait(min(left, 0.5))  # woken by every line; the bound only notices the process ending
        return True

    def wait(self, timeout=15):
        """Exit code, or None when it did not end in time (then it is killed)."""
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            code = None
        for t in self.readers:
            t.join(timeout=5)
        return code

    def stop(self, sig=signal.SIGINT, timeout=15):
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        return self.wait(timeout)


def run(args, env=None, prefix=(), timeout=20):
    p = Live(args, env=env, prefix=prefix)
    code = p.wait(timeout)
    return code, p.out, p.err


def arrival(pty, needle):
    """When (time.monotonic()) the chunk that completed `needle` arrived on the pty's master."""
    seen = b""
    for t, chunk in pty.arrivals:
        seen += chunk
        if needle in seen:
            return t
    return None


def written_ms(err):
    """The figures estop prints: total, opening, sending (ms)."""
    m = re.search(r"written to the adapter ([0-9.]+) ms after the command started \(([0-9.]+) ms opening, "
                  r"([0-9.]+) ms sending", err)
    return tuple(float(x) for x in m.groups()) if m else None


def sniff_frames(out):
    """The frame column of sniff's lines: '(time) iface FRAME description'."""
    return [line.split()[2] for line in out.splitlines() if len(line.split()) > 2]


# A program that is not saulctl holding a port: opens it and names itself "minicom" (PR_SET_NAME).
HOLDER = r"""
import ctypes, os, sys
ctypes.CDLL(None).prctl(15, b"minicom", 0, 0, 0)
fd = os.open(sys.argv[1], os.O_RDWR | os.O_NOCTTY)
print("ready", flush=True)
sys.stdin.read()
"""

figures = []  # (total ms, opening ms, sending ms, process start -> bytes on the adapter ms)


def fake_scenarios():
    # 1. Two processes: sniff holds the adapter, estop goes through it.
    p = Pty()
    p.collect_in_background()
    owner = Live(["sniff", "slcan:" + p.path])
    check("sniff opens the adapter and holds it (C S6 O)", owner.wait_for("err", "listening on") and
          wait_bytes(p, lambda b: b == OPEN), repr(p.buf) + owner.err)
    est = Live(["estop", "--link", "slcan:" + p.path, "--timeout", "3s"])
    wait_bytes(p, lambda b: b.endswith(ESTOP))
    p.send(ACK_MODE)
    code = est.wait()
    check("estop through the sniff that holds the adapter: exactly C S6 O then 302#03 on the wire",
          p.buf == OPEN + ESTOP, repr(p.buf))
    check("estop exits 0 on the acknowledgement and says it went through the sniff",
          code == 0 and "estop: applied" in est.out and f"through saulctl sniff (pid {owner.pid})" in est.err,
          f"{code} {est.out} {est.err}")
    check("the sniff sees the client's 302#03 (loopback) and then the 402#020000",
          owner.wait_for("out", r"302#03 .*\n.*402#020000"), owner.out)
    record_figure(est, p)
    stop_owner(p, owner, "sniff exits 0 on Ctrl-C and closes the channel: the wire is C S6 O, 302#03, C")

    # 2. Three processes: monitor holds it, sniff and estop go through it; monitor keeps updating, shows ESTOP.
    p, mon = holding(["monitor", "--json"], ready=None)
    p.send(TEL_A_BALANCE + TEL_B)
    check("monitor (the owner) shows BALANCE", mon.wait_for("out", '"state":"BALANCE"'), mon.out + mon.err)
    sn = Live(["sniff", "slcan:" + p.path, "--count", "4"])
    check("a second process, sniff, joins the monitor", sn.wait_for("err", rf"through saulctl monitor \(pid {mon.pid}\)"),
          sn.err)
    est = Live(["estop", "--link", "slcan:" + p.path, "--timeout", "3s"])
    wait_bytes(p, lambda b: b.endswith(ESTOP))
    p.send(ACK_MODE + TEL_A_ESTOP + TEL_B)
    code = est.wait()
    check("a third process, estop, exits 0 on its acknowledgement", code == 0, f"{code} {est.out} {est.err}")
    check("monitor keeps updating and shows ESTOP", mon.wait_for("out", '"state":"ESTOP"'), mon.out[-400:] + mon.err)
    code = sn.wait()
    frames = sniff_frames(sn.out)
    check("sniff (a client) sees the estop of another client, the acknowledgement and the telemetry",
          code == 0 and frames == ["302#03", "402#020000", "400#F4010A00000003", "401#B00464FBB09A11"],
          f"{code} {frames} {sn.err}")
    record_figure(est, p)
    stop_owner(p, mon, "monitor exits 0; on the wire: C S6 O, one 302#03, C - nothing from sniff or monitor")

    # 3. The owner leaves while a client runs: the client takes the adapter over and says so in one line.
    p, a = holding(["sniff"])
    b = Live(["sniff", "slcan:" + p.path])
    b.wait_for("err", "listening on")
    p.send(b"t1001AA\r")
    a.wait_for("out", "100#AA")
    b.wait_for("out", "100#AA")
    code_a = a.stop()
    took = b.wait_for("err", rf"saulctl sniff \(pid {a.pid}\) stopped; saulctl sniff \(pid {b.pid}\) now holds "
                             rf"{re.escape(p.path)} and shares it")
    wait_bytes(p, lambda buf: buf == OPEN + b"C\r" + OPEN)
    check("owner sniff exits 0; the client sniff takes over (one line) and reopens: C S6 O, C, C S6 O",
          code_a == 0 and took and p.buf == OPEN + b"C\r" + OPEN, f"{code_a} {p.buf!r} {b.err}")
    est = Live(["estop", "--link", "slcan:" + p.path, "--timeout", "3s"])
    wait_bytes(p, lambda buf: buf.endswith(ESTOP))
    p.send(ACK_MODE + b"t1001BB\r")
    code = est.wait()
    check("an estop after the handover goes through the new owner",
          code == 0 and f"through saulctl sniff (pid {b.pid})" in est.err, f"{code} {est.err}")
    check("the new owner keeps printing the bus", b.wait_for("out", r"302#03 .*\n.*402#020000 .*\n.*100#BB"), b.out)
    code = b.stop()
    check("the new owner exits 0 and closes the channel", code == 0 and wait_bytes(p, lambda buf: buf.endswith(b"C\r")),
          f"{code} {p.buf!r}")
    finish_pty(p)

    # 4. The adapter disappears under an owner and a client: both end with one clear line, exit 1.
    p = Pty()
    a = Live(["sniff", "slcan:" + p.path])
    a.wait_for("err", "listening on")
    b = Live(["sniff", "slcan:" + p.path])
    b.wait_for("err", "through saulctl sniff")
    p.close_master()
    code_a, code_b = a.wait(), b.wait()
    lines_b = [l for l in b.err.splitlines() if l.startswith("saulctl sniff:")]
    check("adapter gone: the owner ends with 'disappeared', exit 1", code_a == 1 and "disappeared" in a.err,
          f"{code_a} {a.err}")
    check("adapter gone: the client ends with one line saying so, exit 1",
          code_b == 1 and len(lines_b) == 1 and "disappeared" in lines_b[0], f"{code_b} {b.err}")
    p.close()

    # 5. A program that is not saulctl holds the port: named with its pid, nothing written, doctor says the same.
    p = Pty()
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, p.path], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    holder.stdout.readline()
    code, out, err = run(["mode", "off", "--link", "slcan:" + p.path])
    check("a port held by another program: exit 1, '<port> is held by minicom (pid N)', nothing written",
          code == 1 and f"{p.path} is held by minicom (pid {holder.pid})" in err and p.read_some(0) == b"",
          f"{code} {err} {p.buf!r}")
    code, out, err = run(["doctor", "--link", "slcan:" + p.path, "--wait", "200ms"])
    check("doctor names the holder and how to free the port",
          code == 1 and f"FAIL not busy: {p.path} is held by minicom (pid {holder.pid})" in out
          and f"quit minicom (or: kill {holder.pid})" in out, f"{code} {out} {err}")
    holder.stdin.close()
    holder.wait()
    p.close()

    # 6. What a client may not do: another bitrate; a motion command without confirmation; another user.
    p, owner = holding(["sniff"])
    code, out, err = run(["sniff", "slcan:" + p.path + "@250000", "--count", "1"])
    check("another bitrate is refused by the owner: exit 1, the owner and its rate named",
          code == 1 and f"held by saulctl sniff (pid {owner.pid}) at 500000 bit/s, not 250000 bit/s" in err,
          f"{code} {err}")
    code, out, err = run(["mode", "balance", "--link", "slcan:" + p.path])
    check("mode balance through the shared link still needs --yes: exit 2, nothing sent",
          code == 2 and "--yes" in err and p.buf == OPEN, f"{code} {err} {p.buf!r}")
    stimulus = threading.Event()
    doctor = Live(["doctor", "--link", "slcan:" + p.path, "--wait", "5s"])
    while doctor.proc.poll() is None and not stimulus.wait(0.05):
        p.send(TEL_A_BALANCE)  # traffic until doctor has seen some and ended
    code = doctor.wait()
    check("doctor: the port is held by saulctl sniff and shared; the checks go through it, the robot is there",
          code == 0 and re.search(rf"ok   not busy: {re.escape(p.path)} is held by saulctl sniff \(pid {owner.pid}\) "
                                  r"as slcan:.*shared", doctor.out) and "ok   bus traffic" in doctor.out
          and "ok   robot: BALANCE sends telemetry (0x400), state BALANCE" in doctor.out,
          f"{code} {doctor.out} {doctor.err}")
    if os.geteuid() == 0 and shutil.which("setpriv"):
        sock = os.path.join(RUNTIME, p.path[len("/dev/"):].replace("/", "-") + ".sock")
        os.chmod(RUNTIME, 0o755)  # as if the directory's protection had failed
        os.chmod(sock, 0o777)
        code, out, err = run(["estop", "--link", "slcan:" + p.path],
                             prefix=["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"])
        os.chmod(RUNTIME, 0o700)
        check("another user (uid 65534) is not let through: exit 1, the socket's owner named, nothing sent",
              code == 1 and "served by uid 0" in err and "not by this user (uid 65534)" in err and p.buf == OPEN,
              f"{code} {err} {p.buf!r}")
    else:
        print("skip another-user test (needs root and setpriv)")
    owner.stop()
    finish_pty(p)

    # 7. A serial port shared the same way: console through a sniff that holds a board's console.
    p = Pty()
    p.collect_in_background()
    owner = Live(["sniff", "serial:" + p.path + "@115200"])
    owner.wait_for("err", "bytes on")
    con = Live(["console", p.path, "status", "--timeout", "3s"])
    wait_bytes(p, lambda b: b.endswith(b"\n"))
    p.send(b"report=status board=balance state=OFF\r\nok\r\n")
    code = con.wait()
    check("console through a sniff that holds the port: 'status' on the wire, the reply read, exit 0",
          code == 0 and p.buf in (b"status\r\n", b"status\n") and "report=status" in con.out, f"{code} {p.buf!r} {con.err}")
    owner.stop()
    finish_pty(p)

    # 8. What the robot did, not only what it acknowledged: balance acknowledged, 0x400 then says TILT_CUTOFF.
    p, owner = holding(["sniff"])
    est = Live(["mode", "balance", "--yes", "--link", "slcan:" + p.path, "--timeout", "2s"])
    wait_bytes(p, lambda b: b.endswith(b"t302101\r"))
    p.send(ACK_MODE + b"t4007F4010A00000004\r")  # 0x400 state 4 TILT_CUTOFF
    code = est.wait()
    check("mode balance acknowledged but 0x400 shows TILT_CUTOFF: exit 1, what happened and what to do",
          code == 1 and "reports TILT_CUTOFF instead of BALANCE" in est.err and "stand it upright" in est.err,
          f"{code} {est.out} {est.err}")
    owner.stop()
    finish_pty(p)

    # 9. ESTOP under load, many times: the owner monitor reads telemetry at 1 kHz while estops go through it.
    p, mon = holding(["monitor", "--json"], ready=None)
    stop = threading.Event()

    def flood():
        while not stop.wait(0.001):  # load, not synchronisation
            p.send(TEL_A_BALANCE + TEL_B)

    loader = threading.Thread(target=flood, daemon=True)
    loader.start()
    mon.wait_for("out", '"state":"BALANCE"')
    codes = []
    for i in range(10):
        est = Live(["estop", "--link", "slcan:" + p.path, "--timeout", "100ms"])
        wait_bytes(p, lambda b, n=i + 1: b.count(ESTOP) == n)
        codes.append(est.wait())
        record_figure(est, p, count=i + 1)
    stop.set()
    loader.join()
    check("10 estops through a monitor reading 2000 frames/s: each written exactly once, each exits 3 (no ack)",
          p.buf.count(ESTOP) == 10 and codes == [3] * 10, f"{codes} {p.buf.count(ESTOP)}")
    mon.stop()
    finish_pty(p)


def holding(verb, ready="listening on"):
    """A fake CANable collecting what is written to it, and a saulctl VERB that holds it (C S6 O written)."""
    p = Pty()
    p.collect_in_background()
    owner = Live(verb + ["slcan:" + p.path] if verb[0] == "sniff" else verb + ["--link", "slcan:" + p.path])
    if ready:
        owner.wait_for("err", ready)
    wait_bytes(p, lambda b: b == OPEN)
    return p, owner


def stop_owner(p, owner, name):
    """Ctrl-C to the owner; it must exit 0 having written exactly C S6 O, one 302#03 and C."""
    code = owner.stop()
    wait_bytes(p, lambda b: b.endswith(b"C\r"))
    check(name, code == 0 and p.buf == OPEN + ESTOP + b"C\r", f"{code} {p.buf!r} {owner.err}")
    finish_pty(p)


def finish_pty(p):
    """Ends a collecting Pty the way ptyfake wants it (drain: its reader thread has stopped before the descriptors
    are closed; closing under a running reader would let it read a new Pty that reuses the descriptor numbers)."""
    p.drain()


def wait_bytes(p, predicate, timeout=10):
    """For a Pty collecting in the background: true once predicate(bytes so far) holds."""
    end = time.monotonic() + timeout
    while not predicate(p.buf):
        if time.monotonic() > end:
            return False
        time.sleep(0.002)  # the collector thread appends; this only polls its buffer
    return True


def record_figure(est, p, count=1):
    w = written_ms(est.err)
    seen = None
    total = b""
    for t, chunk in list(p.arrivals):
        total += chunk
        if total.count(ESTOP) >= count:
            seen = t
            break
    if w and seen is not None:
        figures.append(w + ((seen - est.started) * 1000.0,))


def sim_scenarios():
    paths = os.path.join(RUNTIME, "sim.paths")
    sim = Live(["sim", "--quiet", "--paths-file", paths, "--for", "120s"])
    sim.wait_for("out", "simulated SAUL-TEE is running")
    can = open(paths).read().split("can=")[1].split()[0]
    mon = Live(["monitor", "--json", "--link", "slcan:" + can])
    check("monitor on the simulator shows telemetry (state OFF)", mon.wait_for("out", '"state":"OFF"'), mon.err)
    sn = Live(["sniff", "slcan:" + can, "--id", "302", "--id", "402"])
    check("sniff joins the monitor", sn.wait_for("err", rf"through saulctl monitor \(pid {mon.pid}\)"), sn.err)
    code, out, err = run(["estop", "--link", "slcan:" + can, "--timeout", "2s"])
    check("estop through the monitor: acknowledged by the simulated robot, its 0x400 shows ESTOP, exit 0",
          code == 0 and re.search(r"estop: applied \([0-9.]+ ms\); robot state ESTOP \([0-9]+ ms later in 0x400\)", out)
          and f"through saulctl monitor (pid {mon.pid})" in err, f"{code} {out} {err}")
    check("monitor keeps updating and shows ESTOP", mon.wait_for("out", '"state":"ESTOP"'), mon.out[-300:])
    check("sniff sees the estop and the robot's acknowledgement", sn.wait_for("out", r"302#03 .*\n.*402#020000"), sn.out)
    code, out, err = run(["mode", "off", "--link", "slcan:" + can, "--timeout", "2s"])
    # docs/protocol.md, Safety decisions 6: mode off leaves ESTOP for OFF once no estop input is active.
    check("mode off after the estop: acknowledged and 0x400 shows OFF (the latch left for OFF, arming still needed)",
          code == 0 and re.search(r"mode off: applied \([0-9.]+ ms\); robot state OFF", out), f"{code} {out} {err}")
    code_sn = sn.stop()
    check("exactly one 302#03 on the bus in the whole run (as sniff saw it)",
          code_sn == 0 and sniff_frames(sn.out).count("302#03") == 1, sn.out)
    code = mon.stop()
    check("monitor exits 0", code == 0, mon.err)
    sim.stop()


try:
    if MODE == "sim":
        sim_scenarios()
    else:
        fake_scenarios()
finally:
    shutil.rmtree(RUNTIME, ignore_errors=True)

if figures:
    def stat(i):
        v = sorted(f[i] for f in figures)
        return f"median {statistics.median(v):.2f} ms, max {v[-1]:.2f} ms"
    print(f"ESTOP through a shared link, {len(figures)} runs (measured, not asserted):")
    print(f"  estop's send -> the owner's write to the adapter: {stat(2)}")
    print(f"  command start -> the write (connect + send):      {stat(0)}")
    print(f"  process start -> the bytes on the adapter:        {stat(3)}")
checks.exit()
