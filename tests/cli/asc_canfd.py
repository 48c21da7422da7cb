#!/usr/bin/python3
"""CANFD lines of Vector ASC, one rule for all (docs/captures.md): a line is CAN FD, reported with the one FD note
and skipped, when anything on it says FD (the EDL flag 0x1000, BRS or ESI set, a DLC above 8, more than 8 bytes);
otherwise it is a classic frame logged on an FD channel and read as one; an ErrorFrame on a CANFD line is a bus
error, as on a CAN line.

1. python-can's ASCWriter at test time: classic frames and FD ones of 0, 8, 12 and 64 bytes, with and without
   BRS/ESI. Expected: exactly the frames python-can wrote as classic (is_fd False), one FD note per FD frame.
2. The CANFD lines of python-can's test/data/logfile.asc (github.com/hardbyte/python-can, copied by hand: the 8-byte
   FD frame 300, the classic remote frame 50005x its flags mark so, the 64-byte 4EE whose flags column is 0, the FD
   error frame). Expected: 50005x and the error frame read, 300 and 4EE reported as FD (4EE was a "classic frame
   with more than 8 data bytes" before the rule).

Usage: asc_canfd.py SAULCTL      (Debian's /usr/bin/python3: python3-can)
"""
import os
import shutil
import sys
import tempfile

import can

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import Checks, Saulctl  # noqa: E402

saulctl = Saulctl(sys.argv[1])
checks = Checks()
tmp = tempfile.mkdtemp(prefix="saul_asc_canfd_")
FD_NOTE = "CAN FD frame: the robot's bus is classic CAN, FD is not supported"


def convert(asc):
    """saulctl convert ASC -> candump: (exit code, [(id, remote, error, data hex)], FD notes, other stderr lines)."""
    log = asc + ".log"
    code, _, err = saulctl.run(["convert", asc, log])
    frames = []
    if code == 0:
        for line in open(log):
            ident, data = line.split()[2].split("#", 1)
            value = int(ident, 16)
            error = len(ident) == 8 and bool(value & 0x20000000)
            frames.append((value & 0x1FFFFFFF, data.upper().startswith("R"), error, "" if data[:1] in "Rr" else data))
    lines = [l for l in err.splitlines() if "corrupt records skipped" not in l and "note:" not in l]
    notes = [l for l in lines if FD_NOTE in l]
    return code, frames, len(notes), [l for l in lines if FD_NOTE not in l]


# ---- 1. python-can's writer ----------------------------------------------------------------------------------
messages = [
    can.Message(timestamp=1.0, arbitration_id=0x300, data=bytes.fromhex("E8030CFE"), is_extended_id=False),
    can.Message(timestamp=1.1, arbitration_id=0x123, data=bytes(range(8)), is_extended_id=False, is_fd=True),
    can.Message(timestamp=1.2, arbitration_id=0x124, data=bytes(range(8)), is_extended_id=False, is_fd=True,
                bitrate_switch=True),
    can.Message(timestamp=1.3, arbitration_id=0x125, data=bytes(range(12)), is_extended_id=False, is_fd=True),
    can.Message(timestamp=1.4, arbitration_id=0x1ABCDEF, data=bytes(64), is_extended_id=True, is_fd=True,
                bitrate_switch=True, error_state_indicator=True),
    can.Message(timestamp=1.5, arbitration_id=0x126, data=b"", is_extended_id=False, is_fd=True),
    can.Message(timestamp=1.6, arbitration_id=0x400, data=bytes.fromhex("D2047800900101"), is_extended_id=False),
    can.Message(timestamp=1.7, arbitration_id=0x601, dlc=4, is_remote_frame=True, is_extended_id=False),
]
written = os.path.join(tmp, "pycan.asc")
with can.ASCWriter(written) as w:
    for m in messages:
        w.on_message_received(m)
want = [(m.arbitration_id, m.is_remote_frame, False, "" if m.is_remote_frame else m.data.hex().upper())
        for m in messages if not m.is_fd]
code, got, notes, other = convert(written)
checks.check("python-can's ASCWriter: exactly its classic frames are read", code == 0 and got == want,
             f"{code} {got} want {want} {other}")
fd = sum(m.is_fd for m in messages)
checks.check(f"... and each of its {fd} FD frames is reported with the one FD note", notes == fd and not other,
             f"{notes} notes; other lines: {other}")

# ---- 2. python-can's logfile.asc, its CANFD lines -------------------------------------------------------------
zeros = " ".join(["00"] * 60)
canfd = f"""date Sam Sep 30 15:06:13.191 2017
base hex  timestamps absolute
internal events logged
Begin Triggerblock Sam Sep 30 15:06:13.191 2017
   0.000000 Start of measurement
  17.876708 1  6F9             Rx   d 8 05 0C 00 00 00 00 00 00  Length = 240015 BitCount = 124 ID = 1785
  30.005071 CANFD   2 Rx        300  Generic_Name_12                  1 0 8  8 01 02 03 04 05 06 07 08   102203  133   303000 e0006659 46500250 4b140250 20011736 2001040d
  30.300981 CANFD   3 Tx     50005x                                0 0 5 0 140000 73 200050 7a60 46500250 460a0250 20011736 20010205
  30.506898 CANFD   4 Rx        4EE                                   0 0 f 64 01 02 03 04 {zeros}   1331984 11 0 46500250 460a0250 20011736 20010205
  30.806898 CANFD   5 Tx ErrorFrame Not Acknowledge error, dominant error flag fffe c7 31ca Arb. 556 44 0 0 f 64 00 00 00 00 {zeros} 1331984 11 0 46500250 460a0250 20011736 20010205
End TriggerBlock
"""
path = os.path.join(tmp, "logfile_canfd.asc")
open(path, "w").write(canfd)
code, got, notes, other = convert(path)
want = [(0x6F9, False, False, "050C000000000000"), (0x50005, True, False, ""), (0x80, False, True, "0000000000000000")]
checks.check("logfile.asc's CANFD lines: the classic remote frame 50005x and the FD error frame read, beside 6F9",
             code == 0 and got == want, f"{code} {got} want {want} {other}")
checks.check("... the 8-byte FD frame 300 and the 64-byte 4EE (flags 0) both reported with the one FD note",
             notes == 2 and not other, f"{notes} notes; other lines: {other}")

shutil.rmtree(tmp)
checks.exit()
