#!/usr/bin/env python3
"""Writes captures/robot_bus.log: three seconds of the SAUL-TEE bus as `candump -L` would log it.

Independent of libsaulproto: every payload is packed here with Python's struct module from the byte layouts
in docs/protocol.md, so decoding this file with saulctl checks the C++ codecs against a second implementation.

Story: the robot is OFF; the Orin asks for BALANCE (rejected: not armed), the operator arms it with the button
(telemetry shows BALANCE), the Orin tunes the PID (one 0x301 set, acknowledged), sets a 20 deg tilt limit,
then drives forward at up to 0.4 m/s. The BALANCE board commands both VESCs (ids 68 left, 56 right) with
SET_RPM, and the VESCs report STATUS and STATUS_5.
Assumptions for the numbers only: wheel diameter 0.2 m, 7 motor pole pairs.
"""
import math
import struct
import sys

T0 = 1763800000.0  # 2025-11-22 08:26:40 UTC
POLE_PAIRS = 7
WHEEL_CIRC_M = math.pi * 0.2

lines = []


def emit(t, can_id, data, extended=False):
    ident = f"{can_id:08X}" if extended else f"{can_id:03X}"
    sec = int(t)
    usec = int(round((t - sec) * 1e6))
    if usec == 1000000:
        sec, usec = sec + 1, 0
    lines.append((t, f"({sec:010d}.{usec:06d}) can0 {ident}#{data.hex().upper()}"))


def vesc(cmd, vesc_id):
    return (cmd << 8) | vesc_id


def speed_at(t):
    # 0 until 1.0 s, ramp to 400 mm/s by 2.0 s, hold
    if t < 1.0:
        return 0
    return int(min(400, (t - 1.0) * 400))


state = 0  # OFF
for step in range(0, 300):  # 10 ms steps for 3 s
    t = step / 100.0
    ts = T0 + t
    if step == 10:  # 0.10 s: Orin asks for balance while OFF -> ack not_allowed
        emit(ts, 0x302, bytes([1]))
        emit(ts + 0.0004, 0x402, bytes([0x02, 0x00, 0x02]))
    if step == 50:  # 0.50 s: armed by button hold (IO board), BALANCE reports state 1
        state = 1
    if step == 60:  # 0.60 s: PID set 1: Kp 1.5, Ki 0.25, Kd 0.05
        for i, g in enumerate((1.5, 0.25, 0.05)):
            emit(ts + i * 0.0002, 0x301, struct.pack("<BBxxf", i, 1, g))
        emit(ts + 0.0008, 0x402, bytes([0x01, 0x01, 0x00]))
    if step == 70:  # 0.70 s: config 20.00 deg, 1200 mm/s
        emit(ts, 0x303, struct.pack("<HH", 2000, 1200))
        emit(ts + 0.0004, 0x402, bytes([0x03, 0x00, 0x00]))
    speed = speed_at(t)
    mech_rpm = int(round(speed / 1000.0 / WHEEL_CIRC_M * 60))
    if step % 5 == 0 and step >= 80:  # Orin velocity at 20 Hz
        emit(ts + 0.0001, 0x300, struct.pack("<hh", speed, 0))
    if step % 2 == 0 and state == 1:  # BALANCE -> VESC SET_RPM (ERPM) at 50 Hz
        erpm = mech_rpm * POLE_PAIRS
        emit(ts + 0.0002, vesc(3, 68), struct.pack(">i", erpm), extended=True)
        emit(ts + 0.0003, vesc(3, 56), struct.pack(">i", erpm), extended=True)
    if step % 10 == 5:  # VESC STATUS at 10 Hz: ERPM, current x10, duty x1000
        erpm = mech_rpm * POLE_PAIRS if state == 1 else 0
        emit(ts + 0.0005, vesc(9, 68), struct.pack(">ihh", erpm, 12 if speed else 0, int(speed / 20)), True)
        emit(ts + 0.0006, vesc(9, 56), struct.pack(">ihh", erpm, 11 if speed else 0, int(speed / 20)), True)
    if step % 20 == 15:  # STATUS_5 at 5 Hz: tacho, input voltage x10
        emit(ts + 0.0007, vesc(27, 68), struct.pack(">ihh", step * 3, 396, 0), True)
        emit(ts + 0.0008, vesc(27, 56), struct.pack(">ihh", step * 3, 396, 0), True)
    if step % 10 == 0:  # telemetry at 10 Hz
        pitch = int(round(150 * math.sin(t * 3))) if state == 1 else 0
        pid_out = int(pitch * 0.8) if state == 1 else 0
        emit(ts + 0.0009, 0x400, struct.pack("<hhhB", pitch, pid_out, speed, state))
        emit(ts + 0.0010, 0x401, struct.pack("<hhHB", mech_rpm, mech_rpm, 39600 - speed, 0))

lines.sort(key=lambda x: x[0])
out = sys.argv[1] if len(sys.argv) > 1 else "captures/robot_bus.log"
with open(out, "w") as f:
    for _, line in lines:
        f.write(line + "\n")
print(f"wrote {len(lines)} frames to {out}")
