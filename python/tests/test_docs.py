"""docs/python.md's examples run as written: the analysis block on captures/robot_bus.log must print exactly the
output shown under it; the bus loop runs on a python-can virtual bus (instead of can0, for 0.5 s instead of 2)
against a fake BALANCE that acknowledges a whole PID set and answers each velocity command with telemetry."""
import contextlib
import io
import os
import re
import threading

import can

import saulproto


def doc_blocks(source):
    """(marker, code, next block) for each block after a '<!-- tested:' comment."""
    text = (source / "docs" / "python.md").read_text()
    blocks = re.findall(r"```(\w*)\n(.*?)```", text, re.S)
    out = []
    for marker in re.finditer(r"<!-- tested: (.*?) -->\n```python\n(.*?)```", text, re.S):
        index = next(i for i, (_, code) in enumerate(blocks) if code == marker.group(2))
        following = blocks[index + 1][1] if index + 1 < len(blocks) else ""
        out.append((marker.group(1), marker.group(2), following))
    return out


def run(code, cwd):
    out = io.StringIO()
    old = os.getcwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(code, "docs/python.md", "exec"), {"__name__": "docs"})
    finally:
        os.chdir(old)
    return out.getvalue()


def test_analysis_prints_what_the_page_shows(source):
    (analysis,) = [b for b in doc_blocks(source) if "from the source tree" in b[0]]
    _, code, shown = analysis
    assert run(code, source) == shown


class FakeBalance(threading.Thread):
    """Answers on the virtual bus: 0x402 for a complete 0x301 set, 0x400 (and 0x401 once) per 0x300."""

    def __init__(self, channel):
        super().__init__(daemon=True)
        self.bus = can.Bus(interface="virtual", channel=channel)
        self.stop = threading.Event()
        self.velocities = []
        self.gains = {}

    def run(self):
        pitch = 0
        while not self.stop.is_set():
            msg = self.bus.recv(timeout=0.05)
            if msg is None:
                continue
            m = saulproto.decode(msg)
            if m["type"] == "pid_gain":
                self.gains[m["gain"]] = m["value"]
                if len(self.gains) == 3:
                    self.bus.send(can.Message(arbitration_id=0x402, data=[1, m["sequence"], 0], is_extended_id=False))
            elif m["type"] == "velocity_cmd":
                self.velocities.append(m["speed_mmps"])
                pitch += 7
                ident, data = 0x400, pitch.to_bytes(2, "little", signed=True) + bytes([0, 0, 0x2C, 0x01, 1])
                self.bus.send(can.Message(arbitration_id=ident, data=data, is_extended_id=False))
                if len(self.velocities) == 1:
                    self.bus.send(can.Message(arbitration_id=0x401, data=bytes.fromhex("00000000B09A10"),
                                              is_extended_id=False))
        self.bus.shutdown()


def test_bus_loop_on_a_virtual_bus(source):
    (loop,) = [b for b in doc_blocks(source) if "virtual bus" in b[0]]
    code = loop[1]
    assert 'can.Bus(interface="socketcan", channel="can0")' in code and "SECONDS = 2.0" in code
    code = code.replace('can.Bus(interface="socketcan", channel="can0")',
                        'can.Bus(interface="virtual", channel="saul-doc-test")').replace("SECONDS = 2.0", "SECONDS = 0.5")
    balance = FakeBalance("saul-doc-test")
    balance.start()
    try:
        out = run(code, source)
    finally:
        balance.stop.set()
        balance.join()
    lines = out.splitlines()
    assert lines[0] == "PID set: applied"
    assert balance.gains == {"kp": 1.5, "ki": 0.25, "kd": 0.05000000074505806}
    assert lines[1] == "pitch +0.07 deg  speed 300 mm/s  BALANCE"
    assert "faults 0x10, battery 39.6 V" in lines
    assert len(balance.velocities) >= 5 and balance.velocities[-1] == 0 and set(balance.velocities[:-1]) == {300}
