#!/usr/bin/python3
"""The capture formats of issue 16 against the tools that write and read them (tests/cli/formats_interop.sh):
python-can's own BLF, TRC, CSV and ASC writers and readers, SavvyCAN's CSV layout, can-utils' log2asc -f, text2pcap,
tshark, gzip and zstd; the bugs found with those files; and `record --compress` on a fake CANable.

Expected frames come from captures/robot_bus.log read by python-can's candump reader, never from saulctl. Times are
compared relative to the first frame: python-can's BLF writer rounds its start time to the millisecond and keeps
float seconds (so +-1 us), python-can 4.1's TRC writer puts the clock of the machine in $STARTTIME.

Usage: formats_interop.py SAULCTL ROOT      (Debian's /usr/bin/python3: python3-can)
"""
import gzip
import os
import shutil
import signal
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import Checks, Saulctl, finish  # noqa: E402

saulctl_path, root = sys.argv[1], sys.argv[2]
saulctl = Saulctl(saulctl_path)
checks = Checks()
check = checks.check
tmp = tempfile.mkdtemp(prefix="saul_formats_")
sample = os.path.join(root, "captures", "robot_bus.log")
os.environ["TZ"] = "UTC"  # python-can's BLF start time is local time; saulctl reads it as UTC


def skip(what, why):
    print(f"SKIP {what} ({why})")


def path(name):
    return os.path.join(tmp, name)


def run(*args, **kw):
    return saulctl.run(list(args), **kw)


def candump_frames(file):
    """(id, extended, remote, error, data hex, microseconds since the first frame) of a candump log, by text."""
    out, t0 = [], None
    for line in open(file):
        if not line.startswith("("):
            continue
        stamp, _, frame = line.split()[:3]
        sec, frac = stamp[1:-1].split(".")
        t = int(sec) * 1_000_000 + int(frac.ljust(6, "0")[:6])
        t0 = t if t0 is None else t0
        ident, data = frame.split("#", 1)
        value = int(ident, 16)
        error = len(ident) == 8 and bool(value & 0x20000000)
        remote = data.upper().startswith("R")
        out.append((value & 0x1FFFFFFF, len(ident) == 8 and not error, remote, error,
                    "" if remote else data.upper(), t - t0))
    return out


def pycan_frames(messages):
    out, t0 = [], None
    for m in messages:
        t = round(m.timestamp * 1_000_000)
        t0 = t if t0 is None else t0
        out.append((m.arbitration_id, m.is_extended_id and not m.is_error_frame, m.is_remote_frame, m.is_error_frame,
                    "" if m.is_remote_frame else bytes(m.data).hex().upper(), t - t0))
    return out


def same(got, want, time_slack_us=0, times=True):
    if len(got) != len(want):
        return False, f"{len(got)} frames, expected {len(want)}"
    for i, (g, w) in enumerate(zip(got, want)):
        if g[:5] != w[:5] or (times and abs(g[5] - w[5]) > time_slack_us):
            return False, f"frame {i}: {g} != {w}"
    return True, ""


expected = candump_frames(sample)

try:
    import can  # Debian's python3-can
except ImportError:
    can = None

# ---- python-can writes, saulctl reads ------------------------------------------------------------------------
if can is None:
    skip("python-can interop", "python3-can is not installed (scripts/setup.sh installs it)")
else:
    messages = list(can.LogReader(sample))
    check("python-can reads the sample as the expected frames", same(pycan_frames(messages), expected)[0])
    for ext, slack in (("blf", 1), ("trc", 0), ("csv", 0), ("asc", 0)):
        writer = can.Logger(path("py." + ext))
        for m in messages:
            writer.on_message_received(m)
        writer.stop()
        code, _, err = run("convert", path("py." + ext), path("py." + ext + ".log"))
        ok, why = (False, err) if code else same(candump_frames(path("py." + ext + ".log")), expected, slack)
        check(f"python-can's {ext.upper()} writer -> saulctl: every frame, times within {slack} us", ok, why)
        # the same file gzip-compressed and misnamed: the content decides
        with open(path("py." + ext), "rb") as f, gzip.open(path("py." + ext + ".data"), "wb") as g:
            g.write(f.read())
        code, _, err = run("convert", path("py." + ext + ".data"), path("py." + ext + ".gz.log"))
        check(f"... and the same {ext.upper()} gzip-compressed under another name",
              code == 0 and open(path("py." + ext + ".gz.log")).read() == open(path("py." + ext + ".log")).read(), err)

    # ---- saulctl writes, python-can reads ----------------------------------------------------------------------
    for ext in ("blf", "trc", "csv", "asc"):
        code, _, err = run("convert", sample, path("ours." + ext))
        got = pycan_frames(list(can.LogReader(path("ours." + ext)))) if code == 0 else []
        ok, why = same(got, expected)
        check(f"saulctl's {ext.upper()} -> python-can's reader: every frame, times to the microsecond", ok, why or err)
    # python-can's BLF reader takes the start from the header: absolute times too
    first = next(iter(can.BLFReader(path("ours.blf"))))
    check("python-can reads saulctl's BLF at the sample's absolute time", abs(first.timestamp - 1763800000.0009) < 1e-6,
          first.timestamp)

    # error frames and remote frames through BLF and CSV, both ways
    special = path("special.log")
    with open(special, "w") as f:
        f.write("(1700000000.000000) can0 20000004#0004000000000000\n(1700000000.001000) can1 123#R4\n"
                "(1700000000.002000) can1 7FF#\n")
    code, _, err = run("convert", special, path("special.csv"))
    back = list(can.CSVReader(path("special.csv")))
    check("CSV keeps a SocketCAN error frame's class and data for python-can",
          code == 0 and back[0].is_error_frame and back[0].arbitration_id == 4 and bytes(back[0].data)[1] == 4
          and back[1].is_remote_frame and back[1].dlc == 4, [str(m) for m in back])
    run("convert", special, path("special.blf"))
    back = list(can.BLFReader(path("special.blf")))
    check("BLF: the error frame and the remote frame reach python-can, channels 1 and 2",
          len(back) == 3 and back[0].is_error_frame and back[1].is_remote_frame and back[1].channel == 1,
          [str(m) for m in back])

# ---- SavvyCAN's CSV layout, written here with its writer's field order ----------------------------------------
with open(path("savvy.csv"), "w") as f:
    f.write("Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n")
    for ident, ext, remote, error, data, t in expected:
        raw = bytes.fromhex(data)
        f.write(f"{1763800000000900 + t},{ident:08X},{'true' if ext else 'false'},Rx,0,{len(raw)},"
                + "".join(f"{b:02X}," for b in raw.ljust(8, b'\0')) + "\n")
code, _, err = run("convert", path("savvy.csv"), path("savvy.log"))
ok, why = same(candump_frames(path("savvy.log")), expected) if code == 0 else (False, err)
check("SavvyCAN-style CSV -> saulctl: every frame", ok, why)
code, _, err = run("convert", sample, path("ours_savvy.csv"), "--format", "gvret-csv")
rows = open(path("ours_savvy.csv")).read().splitlines()
check("saulctl writes SavvyCAN's layout (header, 8 data columns, trailing comma)",
      code == 0 and rows[0] == "Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8"
      and rows[1] == "1763800000000900,00000400,false,Rx,0,7,00,00,00,00,00,00,00,00," and len(rows) == 1 + len(expected),
      rows[:2])

# ---- can-utils and Wireshark's tools -----------------------------------------------------------------------------
if shutil.which("log2asc"):
    asc = subprocess.run(["log2asc", "-f", "-I", sample, "can0"], capture_output=True, text=True).stdout
    open(path("canfd.asc"), "w").write(asc)
    code, _, err = run("convert", path("canfd.asc"), path("canfd.log"))
    ok, why = same(candump_frames(path("canfd.log")), expected) if code == 0 else (False, err)
    check(f"log2asc -f (classic frames on CANFD lines): all {len(expected)} frames read (was 0)", ok, why)
else:
    skip("log2asc -f", "can-utils missing")

if shutil.which("text2pcap"):
    open(path("t2p.txt"), "w").write("0000  00 00 03 00 02 00 00 00 11 22 00 00 00 00 00 00\n")
    subprocess.run(["text2pcap", "-q", "-l", "227", path("t2p.txt"), path("t2p.pcapng")], capture_output=True)
    code, out, err = run("decode", path("t2p.pcapng"))
    code2, _, err2 = run("convert", path("t2p.pcapng"), path("t2p.log"))
    words = open(path("t2p.log")).read().split() if code2 == 0 else []
    check("text2pcap's interface 'Fake IF, text2pcap': one word in decode's lines and in candump output",
          code == 0 and " Fake_IF,_text2pcap 300#1122 " in out and words[1:] == ["Fake_IF,_text2pcap", "300#1122"]
          and "reads back as 'Fake_IF,_text2pcap'" in err2, out + err + err2)
else:
    skip("text2pcap interface name", "tshark missing")

if shutil.which("tshark"):
    code, _, _ = run("convert", os.path.join(root, "captures", "glitches.log"), path("glitches.pcap"))
    fields = subprocess.run(["tshark", "-r", path("glitches.pcap"), "-Y", "can.flags.err == 1", "-T", "fields",
                             "-e", "can.len", "-e", "_ws.expert.severity"], capture_output=True, text=True).stdout
    rows = [line.split("\t") for line in fields.strip().splitlines()]
    check("an error frame in pcap has payload length 8 and no expert warning in tshark (was 0: malformed)",
          code == 0 and rows and all(r[0] == "8" and (len(r) < 2 or r[1] == "") for r in rows), fields)
else:
    skip("tshark error frames", "tshark missing")

# ---- gzip and zstd -----------------------------------------------------------------------------------------------
code, plain, _ = run("decode", sample)
for tool, ext in (("gzip", ".gz"), ("zstd", ".zst")):
    if not shutil.which(tool):
        skip(tool, "not installed")
        continue
    subprocess.run([tool, "-q", "-k", "-c", sample], stdout=open(path("bus.log" + ext), "wb"), check=True)
    code, out, err = run("decode", path("bus.log" + ext))
    check(f"decode of a {tool} file prints what it prints for the plain sample", code == 0 and out == plain, err)
    code, _, err = run("convert", sample, path("ours.blf" + ext))
    test = subprocess.run([tool, "-t", path("ours.blf" + ext)], capture_output=True)
    unpacked = subprocess.run([tool, "-d", "-c", path("ours.blf" + ext)], capture_output=True).stdout
    check(f"convert -o run.blf{ext} writes a file {tool} -t accepts, holding the BLF",
          code == 0 and test.returncode == 0 and unpacked[:4] == b"LOGG", err)
cut = open(path("bus.log.gz"), "rb").read()
open(path("cut.log.gz"), "wb").write(cut[: len(cut) // 2])
code, _, err = run("decode", path("cut.log.gz"))
check("a truncated .gz says so", "the gzip file ends before its end marker (truncated?) (reading stopped)" in err, err)

# ---- the bugs of other tools' files -----------------------------------------------------------------------------
open(path("busmaster.log"), "w").write("***BUSMASTER Ver 3.2.2***\n***PROTOCOL CAN***\n"
                                       "10:39:51:0105 Rx 1 0x0C1 s 8 00 00 00 00 00 00 00 00\n")
code, out, err = run("decode", path("busmaster.log"))
check("a BusMaster .log is refused by name, exit 1 (was an empty capture, exit 0)",
      code == 1 and "is not a candump log: it is a BusMaster log" in err, err)
open(path("corrupt.log"), "w").write("(1700000000.000000) can0 3G4#00\n(1700000000.000100) can0 123#0\n")
code, _, err = run("convert", path("corrupt.log"), path("corrupt.pcap"))
check("convert with nothing readable exits 1 and leaves no output", code == 1 and not os.path.exists(path("corrupt.pcap"))
      and "nothing could be read" in err, err)
open(path("len8.log"), "w").write("(1700000000.000000) can0 3FF#55AA010203040506_D\n(1700000000.000100) can0 123#R8_D\n")
code, out, err = run("decode", path("len8.log"))
check("candump lines with a raw DLC suffix (_D) are read", code == 0 and "3FF#55AA010203040506" in out
      and "123#R8" in out and " 0 corrupt" in err, out + err)
code, out, err = run("decode", "--input-format", "candump", path("busmaster.log"))
check("--input-format forces a format", code == 0 and "0 frames" in err, err)

# ---- record --compress on a fake CANable -------------------------------------------------------------------------
from ptyfake import Pty  # noqa: E402

p = Pty()
proc = saulctl.start(["record", "slcan:" + p.path, "-o", path("rec.log"), "--rotate-size", "60", "--compress", "gz"])
p.read_until(lambda b: b.endswith(b"C\rS6\rO\r"))
p.send(b"t3004E8030CFE\rt40070AFF2C012C0101\rT0000034440000008F\rt4023020000\r")
proc.send_signal(signal.SIGINT)
code, _, err = finish(proc, timeout=15)
names = sorted(os.listdir(tmp))
recorded = [n for n in names if n.startswith("rec-")]
frames = []
for n in recorded:
    frames += [l for l in gzip.open(path(n), "rt").read().splitlines() if l.startswith("(")] if n.endswith(".gz") else []
check("record --rotate-size --compress gz: every finished file is compressed, none left plain, all 4 frames",
      code == 0 and recorded and all(n.endswith(".log.gz") for n in recorded) and len(recorded) >= 2
      and len(frames) == 4 and recorded[-1] in err, f"{code} {recorded} {err}")
p.close()

shutil.rmtree(tmp)
checks.exit()
