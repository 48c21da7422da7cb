#!/usr/bin/env python3
"""Writes a long capture of the SAUL-TEE bus as `candump -L` logs it, for bench/compare.

Same traffic as captures/make_robot_bus.py, continued for as long as asked: Orin velocity stream (0x300, 20 Hz),
BALANCE telemetry (0x400/0x401, 10 Hz), VESC SET_RPM to both wheels (50 Hz), VESC STATUS (10 Hz) and STATUS_5
(5 Hz), occasional PID gains / config / mode requests with their acks. The speed profile wanders so payloads vary.
On the real bus the VESCs report faster than this; the rates are scaled up (--scale) so a long capture keeps the
mix but stays a plausible bus load per second of file time.
  make_bus.py FRAMES OUT.log [--random]
With --random every payload's bytes are random (same ids, lengths and times, seeded): nothing repeats, so a cache
of lines or contents seen before gains nothing; bench/compare times both logs.
"""
import math
import random
import struct
import sys

T0 = 1763800000.0
frames = int(sys.argv[1])
out = open(sys.argv[2], "w", buffering=1 << 20)
scramble = "--random" in sys.argv[3:]
rng = random.Random(15)
n = 0


def emit(t, ident, data, extended=False):
    global n
    us = int(round(t * 1e6))  # whole microseconds, as candump prints them
    sec, usec = divmod(us, 1_000_000)
    ids = f"{ident:08X}" if extended else f"{ident:03X}"
    if scramble:
        data = rng.randbytes(len(data))
    out.write(f"({sec:010d}.{usec:06d}) can0 {ids}#{data.hex().upper()}\n")
    n += 1


step = 0
while n < frames:
    t = T0 + step / 1000.0  # 1 ms steps
    speed = int(400 * math.sin(step / 7000.0))
    rpm = int(speed / 1000.0 / (math.pi * 0.2) * 60)
    if step % 50 == 0:
        emit(t + 0.0001, 0x300, struct.pack("<hh", speed, int(100 * math.cos(step / 3000.0))))
    if step % 20 == 0:
        emit(t + 0.0002, (3 << 8) | 68, struct.pack(">i", rpm * 7), True)
        emit(t + 0.0003, (3 << 8) | 56, struct.pack(">i", -rpm * 7), True)
    if step % 5 == 0:  # VESC STATUS, scaled up to 200 Hz per controller
        emit(t + 0.0004, (9 << 8) | 68, struct.pack(">ihh", rpm * 7, abs(speed) // 30, speed // 20), True)
        emit(t + 0.0005, (9 << 8) | 56, struct.pack(">ihh", -rpm * 7, abs(speed) // 31, speed // 20), True)
    if step % 10 == 0:  # telemetry, scaled up to 100 Hz
        pitch = int(150 * math.sin(step / 300.0))
        emit(t + 0.0006, 0x400, struct.pack("<hhhB", pitch, int(pitch * 0.8), speed, 1))
        emit(t + 0.0007, 0x401, struct.pack("<hhHB", rpm, rpm, 39600 - abs(speed), 0))
    if step % 40 == 0:
        emit(t + 0.0008, (27 << 8) | 68, struct.pack(">ihh", step, 396, 0), True)
        emit(t + 0.0009, (27 << 8) | 56, struct.pack(">ihh", step, 395, 0), True)
    if step % 20000 == 0:  # now and then: PID set, config, mode request, each acknowledged
        for i, g in enumerate((1.5, 0.25, 0.05)):
            emit(t + 0.0001 * i, 0x301, struct.pack("<BBxxf", i, step // 20000 & 0xFF, g))
        emit(t + 0.0005, 0x402, bytes([0x01, 0x01, 0x00]))
        emit(t + 0.0006, 0x303, struct.pack("<HH", 2000, 1200))
        emit(t + 0.0007, 0x402, bytes([0x03, 0x00, 0x00]))
    step += 1
out.close()
print(f"wrote {n} frames to {sys.argv[2]}", file=sys.stderr)
