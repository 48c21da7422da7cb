#!/usr/bin/env python3
"""A test double of the ESP32-S3 ROM serial bootloader, on a pseudo-terminal.

Written from Espressif's serial-protocol documentation (docs/flashing.md), independently of libsaulproto's codec:
SLIP framing, request/response packets with 4 ROM status bytes (2 with --stub), the 0xEF XOR checksum, SYNC,
READ_REG/WRITE_REG over a few ESP32-S3 registers, GET_SECURITY_INFO, SPI_ATTACH, SPI_SET_PARAMS, CHANGE_BAUDRATE,
FLASH_BEGIN/DATA/END, FLASH_DEFL_BEGIN/DATA/END (inflated with zlib) and SPI_FLASH_MD5 over a simulated NOR flash
(erase sets 0xFF, writes AND bits in).

It prints the pty's path on stdout, then answers whatever comes in. It ends when its stdin says "quit" (or
closes), when the chip "resets" (RTC watchdog armed, or the ROM told to leave the loader), or when told to vanish;
then it writes --report (JSON) and saves --flash-file. Nothing in it waits on a clock except --baud-pacing, which
spends the time the bytes would take on a real UART.

Fault injection: --silent (no chip in download mode), --chatter (the app's boot text instead of answers),
--mute-download (the ROM's download banner, then nothing), --echo (a loopback), --bad-checksum-block N, --drop-byte-in-block N, --vanish-after BYTES,
--write-error-block N (flash write error 0x08 for data block N, every time), --quiet-from-block N (no answer from
data block N on).
"""
import argparse
import hashlib
import json
import os
import struct
import time
import zlib

from ptyfake import Pty

CHIPS = {  # name: (chip id for GET_SECURITY_INFO, magic at 0x40001000, security info length)
    "esp32s3": (9, 0x00000009, 20),
    "esp32c3": (5, 0x1B31506F, 20),
    "esp32s2": (2, 0x000007C6, 12),
    "esp32": (0, 0x00F01D83, 0),  # the ESP32 ROM has no GET_SECURITY_INFO
}
OP_NAMES = {0x02: "FLASH_BEGIN", 0x03: "FLASH_DATA", 0x04: "FLASH_END", 0x05: "MEM_BEGIN", 0x06: "MEM_END",
            0x07: "MEM_DATA", 0x08: "SYNC", 0x09: "WRITE_REG", 0x0A: "READ_REG", 0x0B: "SPI_SET_PARAMS",
            0x0D: "SPI_ATTACH", 0x0F: "CHANGE_BAUDRATE", 0x10: "FLASH_DEFL_BEGIN", 0x11: "FLASH_DEFL_DATA",
            0x12: "FLASH_DEFL_END", 0x13: "SPI_FLASH_MD5", 0x14: "GET_SECURITY_INFO"}
MAGIC_REG = 0x40001000
UARTDEV_BUF_NO = 0x3FCEF14C
GPIO_STRAP = 0x60004038
RTC_OPTION1 = 0x6000812C
WDT_CONFIG0 = 0x60008098
WDT_CONFIG1 = 0x6000809C
WDT_PROTECT = 0x600080B0
WDT_KEY = 0x50D83AA1
SWD_CONF = 0x600080B4
SWD_PROTECT = 0x600080B8
SWD_KEY = 0x8F1D312A
SECTOR = 0x1000

ERR_INVALID = 0x05
ERR_CHECKSUM = 0x07
ERR_FLASH_WRITE = 0x08
ERR_DEFLATE = 0x0B
DOWNLOAD_TEXT = (b"ESP-ROM:esp32s3-20210327\r\nBuild:Mar 27 2021\r\nrst:0x1 (POWERON),boot:0x0 (DOWNLOAD(USB/UART0))\r\n"
                 b"waiting for download\r\n")
BOOT_TEXT = (b"ESP-ROM:esp32s3-20210327\r\nBuild:Mar 27 2021\r\nrst:0x1 (POWERON),boot:0x8 (SPI_FAST_FLASH_BOOT)\r\n"
             b"SPIWP:0xee\r\nmode:DIO, clock div:1\r\nI (31) boot: ESP-IDF v5.3 2nd stage bootloader\r\n")


class Done(Exception):
    pass


class Rom:
    def __init__(self, args, port):
        self.a = args
        self.port = port
        self.stub = args.stub
        chip_id, magic, _ = CHIPS[args.chip]
        self.flash = bytearray(b"\xff" * args.flash_size)
        if args.flash_file and os.path.exists(args.flash_file):
            with open(args.flash_file, "rb") as f:
                data = f.read()
            self.flash[:len(data)] = data[:len(self.flash)]
        usj = args.usb_serial_jtag
        self.regs = {
            MAGIC_REG: magic,
            UARTDEV_BUF_NO: 4 if usj else 1,
            # Download mode by the USB-Serial/JTAG reset is "forced"; by a held BOOT pin (or the bridge's DTR) the
            # strapping register shows GPIO0 low.
            GPIO_STRAP: 0x8 if (usj and not args.boot_pin_held) else 0x0,
            RTC_OPTION1: 0x1 if (usj and not args.boot_pin_held) else 0x0,
            WDT_CONFIG0: 0x80000000 if usj else 0,  # an app's RTC watchdog left running
            SWD_CONF: 0,
        }
        self.report = {"chip": args.chip, "stub": self.stub, "usb_serial_jtag": usj, "syncs": 0, "commands": {},
                       "regions": [], "md5": [], "baud": [], "errors_sent": [], "resets": [], "duplicate_blocks": 0,
                       "spi_attached": False, "spi_params_size": None, "wdt_disabled": False, "swd_autofeed": False,
                       "left_loader": None, "bytes_in": 0, "bytes_out": 0, "noise_frames": 0}
        self.synced = False
        self.attached = False
        self.write = None  # the write in progress
        self.data_blocks = 0  # data blocks received, all writes together (for fault injection)
        self.baud = 115200
        self.line_free = time.monotonic()
        self.chattered = False

    # --- wire ----------------------------------------------------------------------------------------------------
    def pace(self, nbytes):
        if not self.a.baud_pacing:
            return
        self.line_free = max(self.line_free, time.monotonic()) + nbytes * 10.0 / self.baud
        delay = self.line_free - time.monotonic()
        if delay > 0:
            time.sleep(delay)  # the time the bytes take on a UART at this rate: simulation, not synchronisation

    def send_raw(self, data):
        self.pace(len(data))
        self.port.send(data)
        self.report["bytes_out"] += len(data)

    def respond(self, op, value=0, data=b"", status=0, error=0):
        status_bytes = bytes([status, error]) if self.stub else bytes([status, error, 0, 0])
        body = data + status_bytes
        packet = struct.pack("<BBHI", 1, op, len(body), value) + body
        frame = b"\xc0" + packet.replace(b"\xdb", b"\xdb\xdd").replace(b"\xc0", b"\xdb\xdc") + b"\xc0"
        self.send_raw(frame)
        if status:
            self.report["errors_sent"].append({"op": OP_NAMES.get(op, hex(op)), "error": error})

    def fail(self, op, error):
        self.respond(op, status=1, error=error if not (self.stub and error == ERR_INVALID) else 0xC0)

    # --- packets -------------------------------------------------------------------------------------------------
    def handle_frame(self, raw):
        if len(raw) < 8:
            self.report["noise_frames"] += 1
            return
        direction, op, size, checksum = struct.unpack("<BBHI", raw[:8])
        data = raw[8:]
        if direction != 0:
            self.report["noise_frames"] += 1
            return
        if op in (0x03, 0x11):
            self.data_blocks += 1
            if self.a.quiet_from_block is not None and self.data_blocks >= self.a.quiet_from_block:
                return  # the chip stopped answering mid-write
            if self.a.drop_byte_in_block == self.data_blocks:
                data = data[: len(data) // 2] + data[len(data) // 2 + 1:]  # one byte lost on the line
        name = OP_NAMES.get(op, hex(op))
        if len(data) != size:
            return self.fail(op, ERR_INVALID)
        if not self.synced and op != 0x08:
            return  # the ROM ignores everything until it has synced
        self.report["commands"][name] = self.report["commands"].get(name, 0) + 1
        handler = getattr(self, "op_%02x" % op, None)
        if handler is None:
            return self.respond(op, status=1, error=0xFF if self.stub else ERR_INVALID)
        handler(op, data, checksum)

    def op_08(self, op, data, _):  # SYNC
        if data != b"\x07\x07\x12\x20" + b"\x55" * 32:
            return self.fail(op, ERR_INVALID)
        self.synced = True
        self.report["syncs"] += 1
        # The ROM answers one SYNC several times, with a non-zero value; the stub once, with 0.
        for _ in range(1 if self.stub else 8):
            self.respond(op, value=0 if self.stub else 0x12)

    def op_14(self, op, data, _):  # GET_SECURITY_INFO
        chip_id, _, length = CHIPS[self.a.chip]
        if length == 0 or self.a.no_security_info:
            return self.fail(op, ERR_INVALID)
        info = struct.pack("<IB7B", 0, 0, *([0] * 7))
        if length == 20:
            info += struct.pack("<II", chip_id, 0)
        self.respond(op, data=info)

    def op_0a(self, op, data, _):  # READ_REG
        if len(data) != 4:
            return self.fail(op, ERR_INVALID)
        (addr,) = struct.unpack("<I", data)
        self.respond(op, value=self.regs.get(addr, 0))

    def op_09(self, op, data, _):  # WRITE_REG
        if len(data) != 16:
            return self.fail(op, ERR_INVALID)
        addr, value, mask, _delay = struct.unpack("<IIII", data)
        old = self.regs.get(addr, 0)
        if addr in (WDT_CONFIG0, WDT_CONFIG1) and self.regs.get(WDT_PROTECT) != WDT_KEY:
            return self.respond(op)  # write-protected: silently ignored, as the hardware does
        if addr == SWD_CONF and self.regs.get(SWD_PROTECT) != SWD_KEY:
            return self.respond(op)
        new = (old & ~mask) | (value & mask)
        self.regs[addr] = new & 0xFFFFFFFF
        self.respond(op)
        if addr == WDT_CONFIG0 and new == 0:
            self.report["wdt_disabled"] = True
        if addr == SWD_CONF and new & 0x80000000:
            self.report["swd_autofeed"] = True
        if addr == WDT_CONFIG0 and new & 0x80000000:
            # Armed: the chip resets (a system reset, which samples GPIO0 again). Over USB-Serial/JTAG the port
            # drops off the bus.
            self.report["resets"].append({"kind": "rtc_watchdog",
                                          "forced_download_cleared": (self.regs.get(RTC_OPTION1, 0) & 1) == 0})
            raise Done()

    def op_0d(self, op, data, _):  # SPI_ATTACH
        if len(data) != (4 if self.stub else 8):
            return self.fail(op, ERR_INVALID)
        self.attached = True
        self.report["spi_attached"] = True
        self.respond(op)

    def op_0b(self, op, data, _):  # SPI_SET_PARAMS
        if len(data) != 24:
            return self.fail(op, ERR_INVALID)
        _id, total, block, sector, page, mask = struct.unpack("<6I", data)
        if (block, sector, page, mask) != (0x10000, 0x1000, 0x100, 0xFFFF):
            return self.fail(op, ERR_INVALID)
        self.report["spi_params_size"] = total
        self.respond(op)

    def op_0f(self, op, data, _):  # CHANGE_BAUDRATE
        if len(data) != 8:
            return self.fail(op, ERR_INVALID)
        new, old = struct.unpack("<II", data)
        if not self.stub and old != 0:
            return self.fail(op, ERR_INVALID)
        self.respond(op)  # still at the old rate
        self.baud = new
        self.report["baud"].append(new)

    def begin(self, op, data, compressed):
        words = 4 if self.stub else 5  # the S3 ROM takes a fifth word, "encrypted"
        if len(data) != 4 * words or not self.attached:
            return self.fail(op, ERR_INVALID)
        size, blocks, block, offset = struct.unpack("<4I", data[:16])
        if size == 0 and blocks == 0:  # the stub's "finish what you have"
            return self.respond(op)
        limit = 0x4000 if self.stub else 0x400
        if block == 0 or block > limit or offset % SECTOR or offset + size > len(self.flash):
            return self.fail(op, ERR_INVALID)
        if compressed and not self.stub and size % block:
            return self.fail(op, ERR_INVALID)  # the ROM wants the size rounded up to whole blocks
        if not self.stub:  # the ROM erases everything up front
            end = offset + ((size + SECTOR - 1) // SECTOR) * SECTOR
            self.flash[offset:end] = b"\xff" * (end - offset)
        self.write = {"offset": offset, "pos": offset, "size": size, "blocks": blocks, "block": block, "seq": 0,
                      "compressed": compressed, "z": zlib.decompressobj() if compressed else None, "erased": offset}
        self.report["regions"].append({"offset": offset, "size": size, "blocks": blocks, "block": block,
                                       "compressed": compressed, "written": 0, "retries": 0})
        self.respond(op)

    def data_block(self, op, data, checksum, compressed):
        w = self.write
        if w is None or w["compressed"] != compressed or len(data) < 16:
            return self.fail(op, ERR_INVALID)
        length, seq, _z1, _z2 = struct.unpack("<4I", data[:16])
        payload = data[16:]
        if length != len(payload):
            return self.fail(op, ERR_INVALID)
        expect = 0xEF
        for b in payload:
            expect ^= b
        if checksum != expect or self.a.bad_checksum_block == self.data_blocks:
            self.a.bad_checksum_block = None  # once
            return self.fail(op, 0xC1 if self.stub else ERR_CHECKSUM)
        if self.a.write_error_block == seq + 1:
            return self.fail(op, ERR_FLASH_WRITE)
        if seq == w["seq"] - 1:  # the same block again (its answer was lost): already written
            self.report["duplicate_blocks"] += 1
            return self.respond(op)
        if seq != w["seq"] or seq >= w["blocks"]:
            return self.fail(op, ERR_INVALID)
        if compressed:
            try:
                out = w["z"].decompress(payload)
            except zlib.error:
                return self.fail(op, 0xC7 if self.stub else ERR_DEFLATE)
        else:
            if len(payload) != w["block"]:
                return self.fail(op, ERR_INVALID)  # the last block is padded to the block size
            out = payload
        if w["pos"] + len(out) > len(self.flash) or (compressed and w["pos"] + len(out) > w["offset"] + w["size"]):
            return self.fail(op, 0xC9 if self.stub else ERR_INVALID)
        if self.stub:  # the stub erases as it goes
            end = w["pos"] + len(out)
            while w["erased"] < end:
                self.flash[w["erased"]:w["erased"] + SECTOR] = b"\xff" * SECTOR
                w["erased"] += SECTOR
        pos = w["pos"]
        for i, b in enumerate(out):  # NOR flash: a write can only clear bits
            self.flash[pos + i] &= b
        w["pos"] += len(out)
        w["seq"] += 1
        self.report["regions"][-1]["written"] = w["pos"] - w["offset"]
        self.respond(op)

    def op_02(self, op, data, _):
        self.begin(op, data, False)

    def op_10(self, op, data, _):
        self.begin(op, data, True)

    def op_03(self, op, data, checksum):
        self.data_block(op, data, checksum, False)

    def op_11(self, op, data, checksum):
        self.data_block(op, data, checksum, True)

    def end(self, op, data):
        if len(data) != 4:
            return self.fail(op, ERR_INVALID)
        (flag,) = struct.unpack("<I", data)
        self.respond(op)
        if not self.stub or flag == 0:  # the ROM leaves the loader on END; the stub only when told to reboot
            self.report["left_loader"] = {"op": OP_NAMES[op], "flag": flag}
            raise Done()

    def op_04(self, op, data, _):
        self.end(op, data)

    def op_12(self, op, data, _):
        self.end(op, data)

    def op_13(self, op, data, _):  # SPI_FLASH_MD5
        if len(data) != 16:
            return self.fail(op, ERR_INVALID)
        addr, size, _a, _b = struct.unpack("<4I", data)
        if addr + size > len(self.flash):
            return self.fail(op, ERR_INVALID)
        digest = hashlib.md5(bytes(self.flash[addr:addr + size]))
        self.report["md5"].append({"offset": addr, "size": size})
        self.respond(op, data=digest.digest() if self.stub else digest.hexdigest().encode())


class SlipReader:
    """Cuts the byte stream into SLIP frames (C0 ... C0, DB DC = C0, DB DD = DB) and hands each to on_frame."""

    def __init__(self, on_frame):
        self.on_frame = on_frame
        self.storage = bytearray()
        self.in_frame = False
        self.escape = False

    def feed(self, chunk):
        for b in chunk:
            if b == 0xC0:
                if self.in_frame and self.storage:
                    frame = bytes(self.storage)
                    self.storage.clear()
                    self.in_frame = False
                    self.on_frame(frame)
                else:
                    self.in_frame = True
                    self.storage.clear()
                self.escape = False
            elif self.in_frame:
                if self.escape:
                    self.storage.append({0xDC: 0xC0, 0xDD: 0xDB}.get(b, b))
                    self.escape = False
                elif b == 0xDB:
                    self.escape = True
                else:
                    self.storage.append(b)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--chip", choices=sorted(CHIPS), default="esp32s3")
    p.add_argument("--stub", action="store_true", help="answer like esptool's stub loader")
    p.add_argument("--usb-serial-jtag", action="store_true", help="the IO board: talks over USB-Serial/JTAG")
    p.add_argument("--boot-pin-held", action="store_true", help="download mode entered by holding BOOT")
    p.add_argument("--no-security-info", action="store_true", help="refuse GET_SECURITY_INFO (an older ROM)")
    p.add_argument("--flash-size", type=lambda s: int(s, 0), default=4 * 1024 * 1024)
    p.add_argument("--flash-file", help="flash contents, loaded at start and saved at the end")
    p.add_argument("--report", help="JSON report written at the end")
    p.add_argument("--silent", action="store_true", help="never answer")
    p.add_argument("--chatter", action="store_true", help="send the application's boot text, never answer")
    p.add_argument("--mute-download", action="store_true",
                   help="send the ROM's download-mode banner, never answer (a broken RX line)")
    p.add_argument("--echo", action="store_true", help="send back whatever arrives")
    p.add_argument("--bad-checksum-block", type=int, help="report a checksum error for data block N (1-based), once")
    p.add_argument("--drop-byte-in-block", type=int, help="lose one byte of data block N (1-based)")
    p.add_argument("--write-error-block", type=int, help="answer data block N (1-based) with a flash write error")
    p.add_argument("--quiet-from-block", type=int, help="stop answering from the Nth data block received on")
    p.add_argument("--vanish-after", type=int, help="close the port after receiving this many bytes")
    p.add_argument("--baud-pacing", action="store_true", help="spend the time the bytes would take at the baud rate")
    p.add_argument("--link", help="also make this symlink to the pty")
    args = p.parse_args()

    port = Pty()
    port.announce(args.link)
    rom = Rom(args, port)
    slip = SlipReader(rom.handle_frame)

    def handle(chunk):
        rom.report["bytes_in"] += len(chunk)
        if args.vanish_after is not None and rom.report["bytes_in"] >= args.vanish_after:
            rom.report["resets"].append({"kind": "vanished", "after_bytes": rom.report["bytes_in"]})
            raise Done()
        rom.pace(len(chunk))
        if args.silent:
            return
        if args.echo:
            port.send(chunk)
            return
        if args.chatter or args.mute_download:
            if not rom.chattered:
                rom.chattered = True
                rom.send_raw(BOOT_TEXT if args.chatter else DOWNLOAD_TEXT)
            return
        slip.feed(chunk)

    try:
        port.serve(handle)
    except Done:
        pass
    finally:
        port.close()  # an IO board leaving the USB bus; a no-op for the host when it has already closed
        if args.flash_file:
            with open(args.flash_file, "wb") as f:
                f.write(rom.flash)
        if args.report:
            with open(args.report, "w") as f:
                json.dump(rom.report, f, indent=1)


if __name__ == "__main__":
    main()
