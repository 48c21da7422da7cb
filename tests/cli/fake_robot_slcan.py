#!/usr/bin/env python3
"""A robot behind a virtual slcan adapter, just enough for saulctl flash's robot check.

Prints the pty path, then reads slcan lines. On a 0x302 mode command ("t3021MM") it answers, as the BALANCE board
would, with a 0x402 acknowledgement ("t402302" + "00" + result) and one 0x400 telemetry frame whose state byte is
--state. Frame layouts: docs/protocol.md (0x402: command, sequence, result; 0x400: pitch, pid, speed as int16 LE,
state). Ends when stdin says "quit" or closes; --log records the lines it received.
"""
import argparse

from ptyfake import Pty

p = argparse.ArgumentParser()
p.add_argument("--state", type=int, default=0, help="robot state in 0x400 after the mode command (0 = OFF)")
p.add_argument("--result", type=int, default=0, help="0x402 result byte (0 applied, 2 not allowed)")
p.add_argument("--no-ack", action="store_true", help="stay silent")
p.add_argument("--no-telemetry", action="store_true", help="acknowledge but send no 0x400")
p.add_argument("--log", help="file receiving every line saulctl sent")
args = p.parse_args()

port = Pty()
port.announce()
log = open(args.log, "w") if args.log else None
line = b""


def handle(chunk):
    global line
    for b in chunk:
        if b != 0x0D:
            line += bytes([b])
            continue
        text = line.decode(errors="replace")
        line = b""
        if log:
            log.write(text + "\n")
            log.flush()
        if text.startswith("t3021") and not args.no_ack:
            out = "t4023%02X%02X%02X\r" % (0x02, 0x00, args.result)
            if not args.no_telemetry:
                out += "t4007" + "000000000000" + "%02X" % args.state + "\r"
            port.send(out.encode())


port.serve(handle, size=4096)
port.close()
