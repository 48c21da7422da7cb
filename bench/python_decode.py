#!/usr/bin/python3
"""Reading and decoding a long robot-bus log from Python: saulproto against python-can's LogReader plus a decoder
written in Python (struct), on the same candump log of the robot's bus (bench/make_bus.py, as bench/compare makes
it: velocity stream, telemetry, VESC SET_RPM / STATUS / STATUS_5, PID and config with acks).

Both sides read every frame and decode the SAUL and VESC frames into physical values (pitch in degrees, battery in
volts, VESC currents in amperes, ...). The Python decoder is written for speed (one precompiled struct.Struct per
message, a dict lookup by id), not for checking: it is the floor of what a pure-Python analysis costs.

  PYTHONPATH=build-package/python bench/python_decode.py [FRAMES] [LOG]
      FRAMES default 1000000; LOG: an existing candump log (else one is generated in a temporary folder).
Prints frames/s of each way and the ratio; the goal is saulproto >= 10x. Not run in CI (a minute of CPU).
"""
import os
import struct
import subprocess
import sys
import tempfile
import time

import can

import saulproto

HERE = os.path.dirname(os.path.abspath(__file__))


# ---- the pure-Python decoder (docs/protocol.md sections 3 and 6) ---------------------------------------------------
STATES = ("OFF", "BALANCE", "MANUAL", "ESTOP", "TILT_CUTOFF", "FAULT")
MODES = ("off", "balance", "manual", "estop")
GAINS = ("kp", "ki", "kd")
RESULTS = ("applied", "rejected_out_of_range", "rejected_not_allowed", "rejected_incomplete")
S_HH, S_BBxxf, S_HHu, S_hhhB, S_hhHB, S_BBB = (struct.Struct(f) for f in ("<hh", "<BBxxf", "<HH", "<hhhB", "<hhHB",
                                                                          "<BBB"))
S_i, S_ihh, S_ii, S_hhhh, S_ihxx = (struct.Struct(f) for f in (">i", ">ihh", ">ii", ">hhhh", ">ihxx"))


def saul_velocity(d):
    s, r = S_HH.unpack(d)
    return {"type": "velocity_cmd", "speed_mmps": s, "steer_mrad": r}


def saul_pid(d):
    i, seq, v = S_BBxxf.unpack(d)
    return {"type": "pid_gain", "gain": GAINS[i], "sequence": seq, "value": v}


def saul_mode(d):
    return {"type": "mode_cmd", "mode": MODES[d[0]]}


def saul_config(d):
    t, v = S_HHu.unpack(d)
    return {"type": "config_cmd", "tilt_limit": t / 100, "max_speed_mmps": v}


def saul_tele_a(d):
    p, o, s, st = S_hhhB.unpack(d)
    return {"type": "telemetry_a", "pitch": p / 100, "pid_out": o, "speed_mmps": s, "state": STATES[st]}


def saul_tele_b(d):
    l, r, b, f = S_hhHB.unpack(d)
    return {"type": "telemetry_b", "vesc_l_rpm": l, "vesc_r_rpm": r, "battery": b / 1000, "fault": f}


def saul_ack(d):
    c, s, r = S_BBB.unpack(d)
    return {"type": "command_ack", "command": c, "sequence": s, "result": RESULTS[r]}


SAUL = {0x300: (4, saul_velocity), 0x301: (8, saul_pid), 0x302: (1, saul_mode), 0x303: (4, saul_config),
        0x400: (7, saul_tele_a), 0x401: (7, saul_tele_b), 0x402: (3, saul_ack)}


def vesc_set_rpm(c, d):
    return {"type": "vesc_set_rpm", "controller_id": c, "erpm": S_i.unpack(d)[0]}


def vesc_status_1(c, d):
    e, i, u = S_ihh.unpack(d)
    return {"type": "vesc_status_1", "controller_id": c, "erpm": e, "current": i / 10, "duty": u / 1000}


def vesc_status_2(c, d):
    a, b = S_ii.unpack(d)
    return {"type": "vesc_status_2", "controller_id": c, "ah_used": a / 10000, "ah_charged": b / 10000}


def vesc_status_3(c, d):
    a, b = S_ii.unpack(d)
    return {"type": "vesc_status_3", "controller_id": c, "wh_used": a / 10000, "wh_charged": b / 10000}


def vesc_status_4(c, d):
    f, m, i, p = S_hhhh.unpack(d)
    return {"type": "vesc_status_4", "controller_id": c, "temp_fet_c": f / 10, "temp_motor_c": m / 10,
            "current_in_a": i / 10, "pid_pos_deg": p / 50}


def vesc_status_5(c, d):
    t, v = S_ihxx.unpack(d)
    return {"type": "vesc_status_5", "controller_id": c, "tachometer": t, "voltage_in_v": v / 10}


VESC = {3: (4, vesc_set_rpm), 9: (8, vesc_status_1), 14: (8, vesc_status_2), 15: (8, vesc_status_3),
        16: (8, vesc_status_4), 27: (8, vesc_status_5)}


def python_decode(msg):
    ident = msg.arbitration_id
    if msg.is_error_frame or msg.is_remote_frame:
        return None
    if msg.is_extended_id:
        entry = VESC.get(ident >> 8) if ident < 0x10000 else None
        if entry is None or msg.dlc != entry[0]:
            return None
        return entry[1](ident & 0xFF, bytes(msg.data))
    entry = SAUL.get(ident)
    if entry is None or msg.dlc != entry[0]:
        return None
    return entry[1](bytes(msg.data))


# ---- the runs ------------------------------------------------------------------------------------------------------
def run_python_can(path):
    frames = decoded = 0
    telemetry = []
    for msg in can.LogReader(path):
        frames += 1
        m = python_decode(msg)
        if m is not None:
            decoded += 1
            if m["type"] == "telemetry_a":
                telemetry.append(m["pitch"])
    return frames, decoded, telemetry


def run_saulproto_tables(path):
    frames = decoded = 0
    telemetry = []
    for batch in saulproto.read_capture(path):
        frames += batch.frames
        decoded += batch.messages
        if "telemetry_a" in batch:
            telemetry.extend(batch["telemetry_a"]["pitch"])
    return frames, decoded, telemetry


def run_saulproto_messages(path):
    frames = decoded = 0
    telemetry = []
    for m in saulproto.messages(path):
        decoded += 1
        if m["type"] == "telemetry_a":
            telemetry.append(m["pitch"])
    frames = decoded  # every frame of the generated log decodes
    return frames, decoded, telemetry


def timed(name, fn, path):
    start = time.perf_counter()
    cpu = time.process_time()
    frames, decoded, telemetry = fn(path)
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu
    print(f"{name:44s} {wall:7.2f} s ({cpu:6.2f} s CPU) {frames / wall:12,.0f} frames/s  {decoded} decoded")
    return wall, frames, decoded, telemetry, cpu


def main():
    frames = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    with tempfile.TemporaryDirectory() as tmp:
        path = sys.argv[2] if len(sys.argv) > 2 else os.path.join(tmp, "bus.log")
        if len(sys.argv) <= 2:
            subprocess.run([sys.executable, os.path.join(HERE, "make_bus.py"), str(frames), path], check=True)
        print(f"machine: {os.cpu_count()} cores; python {sys.version.split()[0]}; python-can {can.__version__}; "
              f"log {os.path.getsize(path) / 1e6:.0f} MB")
        base = timed("python-can LogReader + Python decode", run_python_can, path)
        tables = timed("saulproto.read_capture (columns per type)", run_saulproto_tables, path)
        msgs = timed("saulproto.messages (one dict per message)", run_saulproto_messages, path)
        for name, r in (("read_capture", tables), ("messages", msgs)):
            same = r[1] == base[1] and r[2] == base[2] and r[3] == base[3]
            print(f"ratio python-can+decode / saulproto.{name}: {base[0] / r[0]:.1f}x wall, {base[4] / r[4]:.1f}x CPU"
                  f"{'' if same else '  (RESULTS DIFFER: frames/decoded/pitch values)'}")


if __name__ == "__main__":
    main()
