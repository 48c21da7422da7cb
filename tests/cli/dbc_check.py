#!/usr/bin/env python3
"""Decodes the worked examples of docs/protocol.md (sections 3 and 6) with the DBC that `saulctl dbc` wrote and
compares every signal with the value read off by hand in that document.

  dbc_check.py saul.dbc mini       a small DBC reader written here (Intel and Motorola bit numbering, multiplexing,
                                   SIG_VALTYPE_ floats): independent of libsaulproto and of cantools
  dbc_check.py saul.dbc cantools   the same frames through cantools (exit 77 when it is not installed)
Prints "ok"/"FAIL" per frame; exit 0 when all match, 1 otherwise.
"""
import re
import struct
import sys

# candump frame -> (message name, {signal: physical value}); every signal of the message (of the active
# multiplexed group) is listed. Values from the "reading" columns of docs/protocol.md's worked examples.
GOLDEN = [
    ("300#E8030CFE", "velocity_cmd", {"speed_mmps": 1000, "steer_mrad": -500}),
    ("301#000700000000C03F", "pid_gain", {"gain": 0, "sequence": 7, "kp": 1.5}),
    ("301#010700000000803E", "pid_gain", {"gain": 1, "sequence": 7, "ki": 0.25}),
    ("301#02070000CDCC4C3D", "pid_gain", {"gain": 2, "sequence": 7, "kd": 0.05}),
    ("302#01", "mode_cmd", {"mode": 1}),
    ("303#D007DC05", "config_cmd", {"tilt_limit": 20.0, "max_speed_mmps": 1500}),
    ("400#06FFA4012C0101", "telemetry_a", {"pitch": -2.5, "pid_out": 420, "speed_mmps": 300, "state": 1}),
    ("401#B00464FBB09A11", "telemetry_b",
     {"vesc_l_rpm": 1200, "vesc_r_rpm": -1180, "battery": 39.6, "fault_rc_loss": 1, "fault_motor_fault": 0,
      "fault_estop": 0, "fault_tilt_cutoff": 0, "fault_orin_timeout": 1, "fault_watchdog_reset": 0,
      "fault_io_link_loss": 0, "fault_low_battery": 0}),
    ("402#010703", "command_ack", {"command": 1, "sequence": 7, "result": 3}),
    ("00000344#000005DC", "vesc_set_rpm_68", {"erpm": 1500}),
    ("00000338#FFFFFA24", "vesc_set_rpm_56", {"erpm": -1500}),
    ("00000938#FFFFFB50002300FA", "vesc_status_1_56", {"erpm": -1200, "current": 3.5, "duty": 0.25}),
    ("00000944#00000093000C000B", "vesc_status_1_68", {"erpm": 147, "current": 1.2, "duty": 0.011}),
    ("00000E38#0000303900000064", "vesc_status_2_56", {"amp_hours": 1.2345, "amp_hours_charged": 0.01}),
    ("00000F38#0006F85500000000", "vesc_status_3_56", {"watt_hours": 45.6789, "watt_hours_charged": 0}),
    ("00001038#01600190000C1194", "vesc_status_4_56",
     {"temp_fet": 35.2, "temp_motor": 40.0, "current_in": 1.2, "pid_pos": 90}),
    ("00001B38#0001E240016D0000", "vesc_status_5_56", {"tachometer": 123456, "voltage_in": 36.5}),
    ("00003A38#04D200000CE4FE0C", "vesc_status_6_56", {"adc1": 1.234, "adc2": 0, "adc3": 3.3, "ppm": -0.5}),
]


def parse_frame(text):
    ident, data = text.split("#")
    return int(ident, 16), len(ident) == 8, bytes.fromhex(data)


class MiniDbc:
    SG = re.compile(r'^\s*SG_ (\w+)(?: (M|m\d+))? : (\d+)\|(\d+)@([01])([+-]) \(([^,]+),([^)]+)\) '
                    r'\[([^|]+)\|([^\]]+)\] "([^"]*)" (.+)$')

    def __init__(self, path):
        self.messages = {}
        current = None
        floats = set()
        for line in open(path):
            if line.startswith("BO_ "):
                m = re.match(r"BO_ (\d+) (\w+): (\d+) (\w+)", line)
                current = {"name": m.group(2), "signals": []}
                self.messages[int(m.group(1))] = current
            elif line.strip().startswith("SG_"):
                m = self.SG.match(line)
                if not m:
                    raise ValueError("bad SG_ line: " + line)
                current["signals"].append({
                    "name": m.group(1), "mux": m.group(2), "start": int(m.group(3)), "length": int(m.group(4)),
                    "intel": m.group(5) == "1", "signed": m.group(6) == "-", "factor": float(m.group(7)),
                    "offset": float(m.group(8))})
            elif line.startswith("SIG_VALTYPE_"):
                m = re.match(r"SIG_VALTYPE_ (\d+) (\w+) : ([12]);", line)
                floats.add((int(m.group(1)), m.group(2)))
        for ident, msg in self.messages.items():
            for s in msg["signals"]:
                s["float"] = (ident, s["name"]) in floats

    @staticmethod
    def raw(s, data):
        n = len(data) * 8
        if s["intel"]:
            value = (int.from_bytes(data, "little") >> s["start"]) & ((1 << s["length"]) - 1)
        else:  # Motorola: start is the MSB in DBC's sawtooth numbering (bit 7 of byte 0 is 7, bit 0 of byte 1 is 8)
            msb = (s["start"] // 8) * 8 + (7 - s["start"] % 8)  # position counted from the first bit on the wire
            value = (int.from_bytes(data, "big") >> (n - msb - s["length"])) & ((1 << s["length"]) - 1)
        if s["float"]:
            return struct.unpack("<f", value.to_bytes(4, "little"))[0]
        if s["signed"] and value >> (s["length"] - 1):
            value -= 1 << s["length"]
        return value

    def decode(self, ident, extended, data):
        msg = self.messages[ident | (0x80000000 if extended else 0)]
        signals = msg["signals"]
        selector = next((self.raw(s, data) for s in signals if s["mux"] == "M"), None)
        out = {}
        for s in signals:
            if s["mux"] and s["mux"] != "M" and int(s["mux"][1:]) != selector:
                continue
            raw = self.raw(s, data)
            out[s["name"]] = raw if s["float"] else raw * s["factor"] + s["offset"]
        return msg["name"], out


def main():
    path, decoder = sys.argv[1], sys.argv[2]
    if decoder == "cantools":
        try:
            import cantools
        except ImportError:
            print("SKIP cantools is not installed (pip install cantools; Debian 12 does not package it)")
            return 77
        db = cantools.database.load_file(path)

        def decode(ident, extended, data):
            msg = db.get_message_by_frame_id(ident)
            assert msg.is_extended_frame == extended
            return msg.name, dict(msg.decode(data, decode_choices=False))
    else:
        decode = MiniDbc(path).decode
    fails = 0
    for text, name, expected in GOLDEN:
        try:
            got_name, got = decode(*parse_frame(text))
        except Exception as e:  # a frame the DBC does not describe
            print(f"FAIL {text}: {e!r}")
            fails += 1
            continue
        ok = got_name == name and set(got) == set(expected) and all(
            abs(float(got[k]) - v) <= 1e-6 * max(1.0, abs(v)) for k, v in expected.items())
        print(f"{'ok  ' if ok else 'FAIL'} {text:28} {got_name} {got}" + ("" if ok else f" expected {name} {expected}"))
        fails += not ok
    print(f"{fails} failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
