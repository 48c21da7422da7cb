#!/usr/bin/env python3
"""Regenerates the seed corpora in tests/fuzz/corpus/<target>/ from the golden vectors of the unit tests and from
captures/. Needs a built saulctl for the pcap/pcapng/asc seeds: make_corpus.py [path/to/saulctl]."""
import os, re, struct, subprocess, sys, tempfile

root = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
out = os.path.join(root, "tests", "fuzz", "corpus")


def put(target, name, data):
    d = os.path.join(out, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def read(path):
    with open(os.path.join(root, path), "rb") as f:
        return f.read()


def byte_arrays(test, limit=12):
    """Brace lists of 0xNN bytes in a unit test, as written by hand there."""
    text = read("tests/unit/" + test).decode()
    arrays = [bytes(int(b, 16) for b in re.findall(r"0x([0-9A-Fa-f]{2})\b", m))
              for m in re.findall(r"\{\s*(?:0x[0-9A-Fa-f]{2}\s*,\s*){3,}0x[0-9A-Fa-f]{2}\s*,?\s*\}", text)]
    return arrays[:limit]


def strings(test, pattern, limit=24):
    text = read("tests/unit/" + test).decode()
    found = [s.encode().decode("unicode_escape") for s in re.findall(r'"((?:[^"\\]|\\.)*)"', text)]
    return [s for s in found if re.match(pattern, s)][:limit]


def serial_bytes(path):
    """The hex bytes of a saulctl serial log, concatenated."""
    data = b""
    for line in read(path).decode().splitlines():
        words = line.split()
        if len(words) >= 4:
            try:
                data += bytes.fromhex(words[-1])
            except ValueError:
                pass
    return data


for i, a in enumerate(byte_arrays("test_interboard.cpp")):
    put("interboard", f"unit{i}", a)
put("interboard", "capture", serial_bytes("captures/interboard_uart.serial"))
# The BALANCE console: text lines around the worked example of docs/protocol.md section 10 (a loop trace record).
trace_record = bytes.fromhex("AA2320" "40420F00E803000085FFC801CEFFC800F1FFE2FF9B0090019A01B400000001020264" "0086")
put("trace", "text_and_record", b"trace on\nok\n" + trace_record + trace_record + b"report=status x=1\n")
put("trace", "cut_record", b"ok\n" + trace_record[:20] + trace_record)
for i, a in enumerate(byte_arrays("test_pride.cpp")):
    put("pride", f"unit{i}", a)
put("pride", "capture", serial_bytes("captures/pride_uart.serial"))
for i, a in enumerate(byte_arrays("test_crsf.cpp")):
    put("crsf", f"unit{i}", a)
for i, a in enumerate(byte_arrays("test_esp_loader.cpp")):
    put("esp_slip", f"unit{i}", a)
for i, s in enumerate(strings("test_console.cpp", r"^[a-z]")):
    put("console", f"unit{i}", s + "\n")
for i, s in enumerate(strings("test_slcan.cpp", r"^[TtRrFfVvNZ]")):
    put("slcan", f"unit{i}", s + "\r")

# CAN dispatch: the frames of the robot bus capture, 13 bytes each (id LE, flags|dlc, 8 data).
frames = b""
for line in read("captures/robot_bus.log").decode().splitlines()[:200]:
    m = re.match(r"\(\S+\) \S+ ([0-9A-Fa-f]+)#(R?)([0-9A-Fa-f]*)", line)
    if not m:
        continue
    ident, data = int(m.group(1), 16), bytes.fromhex(m.group(3))
    flags = (0x80 if len(m.group(1)) > 3 else 0x10) | (0x40 if m.group(2) else 0) | len(data)
    frames += struct.pack("<IB", ident, flags) + data.ljust(8, b"\0")
for i in range(0, min(len(frames), 13 * 80), 13 * 16):
    put("dispatch", f"bus{i // 13}", frames[i:i + 13 * 16])

bus = read("captures/robot_bus.log").decode().splitlines()
put("capture_candump", "robot_bus_head", "\n".join(bus[:40]) + "\n")
put("capture_candump", "glitches", read("captures/glitches.log"))
saulctl = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build", "saulctl", "saulctl")
with tempfile.TemporaryDirectory() as tmp:
    head = os.path.join(tmp, "head.log")
    with open(head, "w") as f:
        f.write("\n".join(bus[:20]) + "\n")
    for fmt, ext in (("pcap", "pcap"), ("pcapng", "pcapng"), ("asc", "asc"), ("blf", "blf"), ("trc", "trc"),
                     ("csv", "csv"), ("gvret_csv", "gvret.csv"), ("mcap", "mcap")):
        dst = os.path.join(tmp, "head." + ext)
        cmd = [saulctl, "convert", head, dst] + (["--format", "gvret-csv"] if fmt == "gvret_csv" else [])
        if subprocess.run(cmd, capture_output=True).returncode == 0:
            with open(dst, "rb") as f:
                put("capture_" + fmt, "robot_bus_head", f.read())
    for compression in ("lz4", "none"):  # MCAP's other chunk compressions (zstd is the default, above)
        dst = os.path.join(tmp, "head_" + compression + ".mcap")
        if subprocess.run([saulctl, "convert", head, dst, "--compression", compression], capture_output=True).returncode == 0:
            with open(dst, "rb") as f:
                put("capture_mcap", "robot_bus_head_" + compression, f.read())
    for method, ext in (("gzip", "log.gz"), ("zstd", "blf.zst")):
        dst = os.path.join(tmp, "head." + ext)
        if subprocess.run([saulctl, "convert", head, dst], capture_output=True).returncode == 0:
            with open(dst, "rb") as f:
                put("compressed_" + method, "robot_bus_head", f.read())
    # The same frames as python-can writes them (BLF with its containers, TRC 2.1, CSV), when it is installed.
    pycan = (
        "import can, sys\n"
        "msgs = list(can.LogReader(sys.argv[1]))\n"
        "for path in sys.argv[2:]:\n"
        "    w = can.Logger(path)\n"
        "    for m in msgs: w.on_message_received(m)\n"
        "    w.stop()\n")
    outs = [os.path.join(tmp, "py." + ext) for ext in ("blf", "trc", "csv")]
    if subprocess.run(["/usr/bin/python3", "-c", pycan, head] + outs, capture_output=True,
                      env=dict(os.environ, TZ="UTC")).returncode == 0:
        for path, fmt in zip(outs, ("blf", "trc", "csv")):
            with open(path, "rb") as f:
                put("capture_" + fmt, "python_can", f.read())

# PEAK trace versions written by hand after PEAK's format description (1.1, 1.3 and 2.0 layouts).
put("capture_trc", "v1_1", ";$FILEVERSION=1.1\r\n;$STARTTIME=45000.5\r\n"
    "     1)         1.5  Rx         0300  4  E8 03 0C FE \r\n     2)         2.0  Tx     00000344  4  00 00 05 DC \r\n"
    "     3)         2.5  Warng  FFFFFFFF  4  00 00 00 08  BUSHEAVY \r\n     4)         3.0  Rx         0123  2  RTR \r\n")
put("capture_trc", "v1_3", ";$FILEVERSION=1.3\r\n;$STARTTIME=45000.5\r\n"
    "     1)         1.5 1  Rx         0300 -  4    E8 03 0C FE\r\n     2)         2.0 2  Error  00000000 -  0\r\n")
put("capture_trc", "v2_0", ";$FILEVERSION=2.0\r\n;$STARTTIME=45000.5\r\n;$COLUMNS=N,O,T,I,d,l,D\r\n"
    "      1         1.500 DT     0300 Rx 4  E8 03 0C FE\r\n      2         1.600 ST          Rx    00 00 00 08\r\n"
    "      3         1.700 RR     0123 Rx 2\r\n      4         1.800 FD     0400 Tx 12 00 00 00 00 00 00 00 00 00 00 00 00\r\n")
put("capture_gvret_csv", "v1", "Time Stamp,ID,Extended,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n"
    "1500,00000300,false,0,4,E8,03,0C,FE,00,00,00,00,\n")

put("serial_serial", "interboard", read("captures/interboard_uart.serial"))
put("serial_serial", "pride", read("captures/pride_uart.serial"))
put("serial_sigrok", "interboard", read("captures/interboard_uart.sigrok.txt"))
put("serial_sigrok", "pride", read("captures/pride_uart.sigrok.txt"))
put("serial_sigrok_json", "pride", read("captures/pride_uart.sigrok.json"))
text = read("tests/host/capture/test_serial_capture.cpp").decode()
m = re.search(r'"(Sample,Time,Decoder[^"]*)"((?:\s*"[^"]*")*)', text)
if m:
    csv = m.group(1) + "".join(re.findall(r'"([^"]*)"', m.group(2)))
    put("serial_pulseview_csv", "unit", csv.encode().decode("unicode_escape"))
put("serial_pulseview_csv", "minimal", 'Sample,Time,Decoder,Ann Row,Ann Class,Value\n1,0.0001,UART,RX,RX data,AA\n')

for name in sorted(os.listdir(os.path.join(root, "tests", "suites"))):
    if name.endswith(".saul"):
        put("suite", name[:-5], read("tests/suites/" + name))
