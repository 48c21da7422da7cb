#!/usr/bin/env bash
# saulctl flash end to end, against tests/cli/esp_rom_emulator.py (an ESP32-S3 ROM bootloader on a
# pseudo-terminal, written from the protocol documentation) and tests/cli/fake_robot_slcan.py. Expected values
# are the test images themselves (made here with Python, independently of saulctl) and the emulator's report.
# Nothing waits on a clock: the emulators are driven by the bytes saulctl sends, and stopped through their stdin.
set -uo pipefail
saulctl=$1
root=$2
source "$(dirname "$0")/check.bash"
out=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; [ -n "${KEEP:-}" ] || rm -rf "$out"; }
trap cleanup EXIT
trap '' PIPE  # an emulator that ended by itself (a reset) has closed its control pipe
emulator="$root/tests/cli/esp_rom_emulator.py"
robot="$root/tests/cli/fake_robot_slcan.py"
unset SAUL_LINK  # no CAN link unless a test gives one
export HOME="$out"  # and no ~/.config/saulctl/link either

# --- test images ------------------------------------------------------------------------------------------------
python3 - "$out" <<'EOF'
import os, struct, sys
out = sys.argv[1]
def image(chip, size, desc=True, flash_code=2, seed=1):
    # ESP image: 8-byte header, 16-byte extended header with the chip id, one segment holding esp_app_desc_t.
    h = struct.pack('<BBBBI', 0xE9, 1, 2, (flash_code << 4) | 0xF, 0x40375A88)
    h += struct.pack('<BBBBHBHH4BB', 0xEE, 0, 0, 0, chip, 0, 0, 99, 0, 0, 0, 0, 0)
    d = struct.pack('<II8x32s32s16s16s32s32s80x', 0xABCD5432, 0, b'v2.7.1-flash-test', b'saul_balance',
                    b'12:34:56', b'Nov 22 2025', b'v5.3.1', bytes(32)) if desc else b''
    # Compressible but not trivial, like code: words from a small vocabulary mixed with pseudo-random bytes.
    body, x = bytearray(), seed
    while len(body) < size:
        x = (x * 1103515245 + 12345) & 0x7FFFFFFF
        body += struct.pack('<I', 0x40370000 + (x >> 20)) if x & 3 else struct.pack('<I', x)
    img = h + struct.pack('<II', 0x3C000020, size) + d + bytes(body)
    return img[:size]
open(os.path.join(out, 'app.bin'), 'wb').write(image(9, 200 * 1024 + 3))  # not a multiple of 4
open(os.path.join(out, 'app2.bin'), 'wb').write(image(9, 64 * 1024, seed=7))
open(os.path.join(out, 'c3.bin'), 'wb').write(image(5, 8192))
open(os.path.join(out, 'bootloader.bin'), 'wb').write(image(9, 20 * 1024, desc=False, flash_code=3, seed=3))
pt = struct.pack('<2BBB4I16sI', 0xAA, 0x50, 0, 0, 0x9000, 0x6000, 0, 0, b'nvs', 0).ljust(3072, b'\xff')
open(os.path.join(out, 'pt.bin'), 'wb').write(pt)
open(os.path.join(out, 'big.bin'), 'wb').write(image(9, 8192, seed=5).ljust(5 * 1024 * 1024, b'\0'))
os.makedirs(os.path.join(out, 'build', 'bootloader'))
os.makedirs(os.path.join(out, 'build', 'partition_table'))
os.link(os.path.join(out, 'bootloader.bin'), os.path.join(out, 'build', 'bootloader', 'bootloader.bin'))
os.link(os.path.join(out, 'pt.bin'), os.path.join(out, 'build', 'partition_table', 'partition-table.bin'))
os.link(os.path.join(out, 'app.bin'), os.path.join(out, 'build', 'saul_balance.bin'))
args = '''{
  "write_flash_args" : [ "--flash_mode", "dio", "--flash_size", "8MB", "--flash_freq", "80m" ],
  "flash_settings" : { "flash_mode": "dio", "flash_size": "8MB", "flash_freq": "80m" },
  "flash_files" : { "0x0" : "bootloader/bootloader.bin", "0x10000" : "saul_balance.bin",
                    "0x8000" : "partition_table/partition-table.bin" },
  "extra_esptool_args" : { "after" : "hard_reset", "before" : "default_reset", "stub" : true, "chip" : "CHIP" }
}'''
open(os.path.join(out, 'build', 'flasher_args.json'), 'w').write(args.replace('CHIP', 'esp32s3'))
os.makedirs(os.path.join(out, 'c3build'))
open(os.path.join(out, 'c3build', 'flasher_args.json'), 'w').write(args.replace('CHIP', 'esp32c3'))
# The build's settings disagree with the bootloader's header (dio, 8MB, 80m): qio, 4MB, 40m.
os.makedirs(os.path.join(out, 'mismatch'))
for name in ('bootloader', 'partition_table'):
    os.symlink(os.path.join(out, 'build', name), os.path.join(out, 'mismatch', name))
os.symlink(os.path.join(out, 'app.bin'), os.path.join(out, 'mismatch', 'saul_balance.bin'))
mis = args.replace('CHIP', 'esp32s3').split('"flash_settings"')
mis[1] = mis[1].replace('"dio"', '"qio"', 1).replace('"8MB"', '"4MB"', 1).replace('"80m"', '"40m"', 1)
open(os.path.join(out, 'mismatch', 'flasher_args.json'), 'w').write('"flash_settings"'.join(mis))
# An ELF file (what the linker writes beside the .bin): ELF magic, 64-bit, little-endian, Xtensa (machine 94).
elf = b'\x7fELF' + bytes([1, 1, 1, 0]) + bytes(8) + struct.pack('<HHI', 2, 94, 1) + bytes(4096)
open(os.path.join(out, 'app.elf'), 'wb').write(elf)
EOF

# --- helpers ----------------------------------------------------------------------------------------------------
# start NAME SCRIPT ARGS...: runs an emulator with its stdin on a fifo we hold open; sets tty_path and ctl_fd.
start() {
  local name=$1 script=$2; shift 2
  mkfifo "$out/$name.ctl" "$out/$name.tty"
  python3 "$script" "$@" <"$out/$name.ctl" >"$out/$name.tty" &
  pids+=($!)
  last_pid=$!
  exec {ctl_fd}>"$out/$name.ctl"
  read -r tty_path <"$out/$name.tty"
}
# stop: tells the emulator started last to end (it writes its report), and waits for it.
stop() {
  echo quit >&"$ctl_fd" 2>/dev/null
  exec {ctl_fd}>&-
  wait "$last_pid" 2>/dev/null
}
# rom NAME EMULATOR-ARGS... -- SAULCTL-ARGS...: one flash run; leaves NAME.out, NAME.err, NAME.rc, NAME.json.
rom() {
  local name=$1; shift
  local eargs=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do eargs+=("$1"); shift; done
  shift
  start "$name" "$emulator" --report "$out/$name.json" "${eargs[@]}"
  "$saulctl" flash --port "$tty_path" "$@" >"$out/$name.out" 2>"$out/$name.err"
  echo $? >"$out/$name.rc"
  stop
}
rc() { cat "$out/$1.rc"; }
# json NAME EXPRESSION: evaluates a Python expression over the report r.
json() { python3 -c "import json,sys; r=json.load(open('$out/$1.json')); sys.exit(0 if ($2) else 1)"; }
# same FLASHFILE OFFSET FILE: the emulator's flash holds FILE at OFFSET, byte for byte.
same() {
  python3 -c "import sys; f=open('$1','rb').read(); d=open('$3','rb').read(); o=int('$2',0); sys.exit(0 if f[o:o+len(d)]==d else 1)"
}

export out
export -f rc json same

# --- one image at 0x10000 ---------------------------------------------------------------------------------------
rom one --flash-file "$out/flash1.bin" -- --board balance "$out/app.bin"
check "an app image at 0x10000 flashes with exit 0" test "$(rc one)" -eq 0
check "the emulator's flash holds the image byte for byte at 0x10000" same "$out/flash1.bin" 0x10000 "$out/app.bin"
check "written compressed (FLASH_DEFL_*), after SPI_ATTACH, at 460800 baud" \
  json one "r['commands'].get('FLASH_DEFL_DATA',0) > 0 and r['spi_attached'] and r['baud'] == [460800] and 'FLASH_DATA' not in r['commands']"
check "the ROM is never sent FLASH_END (it would leave the loader)" json one "r['left_loader'] is None"
check "the region is checked, then verified, by SPI_FLASH_MD5" json one "len(r['md5']) == 2"
check "the report says written and verified" grep -q '^0x010000 .*app.bin .*written and verified' "$out/one.out"
check "the app version comes from the image header" \
  grep -q '^app at 0x010000: saul_balance v2.7.1-flash-test (built Nov 22 2025 12:34:56, ESP-IDF v5.3.1)$' "$out/one.out"
check "throughput is reported" grep -qE 'KiB/s effective' "$out/one.out"
check "without a link it says the robot was not checked" grep -q '^note: no CAN link' "$out/one.out"

rom again --flash-file "$out/flash1.bin" -- --board balance "$out/app.bin"
check "a second run with the same image exits 0" test "$(rc again)" -eq 0
check "a second run skips the region: its MD5 already matches" grep -q 'unchanged (flash MD5 already matches)' "$out/again.out"
check "a second run erases and writes nothing" \
  json again "not any(k.startswith('FLASH_') for k in r['commands'])"

rom plain --flash-file "$out/flash1.bin" -- --board balance --no-compress --force "$out/app2.bin"
check "--no-compress --force writes with FLASH_DATA, padded 1 KiB blocks" \
  json plain "r['commands'].get('FLASH_DATA') == 64 and 'FLASH_DEFL_DATA' not in r['commands']"
check "--no-compress lands byte for byte" same "$out/flash1.bin" 0x10000 "$out/app2.bin"

# --- several regions, build folder ------------------------------------------------------------------------------
rom pairs --flash-file "$out/flash2.bin" --flash-size 0x800000 -- --board balance \
  0x0 "$out/bootloader.bin" 0x8000 "$out/pt.bin" 0x10000 "$out/app.bin"
check "OFFSET FILE pairs flash with exit 0" test "$(rc pairs)" -eq 0
check "pairs: bootloader at 0x0" same "$out/flash2.bin" 0x0 "$out/bootloader.bin"
check "pairs: partition table at 0x8000" same "$out/flash2.bin" 0x8000 "$out/pt.bin"
check "pairs: app at 0x10000" same "$out/flash2.bin" 0x10000 "$out/app.bin"
check "pairs: the flash size comes from the bootloader's header (8 MB)" json pairs "r['spi_params_size'] == 8*1024*1024"

rom build --flash-file "$out/flash3.bin" --flash-size 0x800000 -- --board balance --build-dir "$out/build"
check "--build-dir (flasher_args.json) flashes with exit 0" test "$(rc build)" -eq 0
check "--build-dir: every flash_files entry lands" bash -c "same '$out/flash3.bin' 0x0 '$out/bootloader.bin' &&
  same '$out/flash3.bin' 0x8000 '$out/pt.bin' && same '$out/flash3.bin' 0x10000 '$out/app.bin'"
check "--build-dir: names the files as flasher_args.json does" grep -q '^0x008000 partition_table/partition-table.bin' "$out/build.out"

"$saulctl" flash --board balance --port /dev/null --build-dir "$out/c3build" >/dev/null 2>"$out/c3build.err"
check "a build folder made for esp32c3 is refused before touching the port" test $? -eq 1
check "... saying which target it was built for" grep -q 'made for esp32c3' "$out/c3build.err"

# --- wrong chip, chip detection ---------------------------------------------------------------------------------
rom c3 --chip esp32c3 -- --board balance "$out/app.bin"
check "an ESP32-C3 on the port is refused with exit 1" test "$(rc c3)" -eq 1
check "... and named" grep -q 'this is an ESP32-C3, not an ESP32-S3 (found by GET_SECURITY_INFO)' "$out/c3.err"
check "... before anything is erased or written" json c3 "not any(k.startswith('FLASH_') for k in r['commands'])"

rom esp32 --chip esp32 -- --board balance "$out/app.bin"
check "an ESP32 (no GET_SECURITY_INFO) is named from its READ_REG magic" \
  grep -q 'this is an ESP32, not an ESP32-S3 (found by READ_REG 0x40001000)' "$out/esp32.err"

rom magic --no-security-info --flash-file "$out/flash4.bin" -- --board balance "$out/app.bin"
check "an S3 ROM without GET_SECURITY_INFO is found by its magic value and flashed" \
  bash -c "test $(rc magic) -eq 0 && grep -q 'ESP32-S3 (READ_REG 0x40001000)' '$out/magic.out'"

rom c3image -- --board balance "$out/c3.bin"
check "an image built for the ESP32-C3 is refused" \
  bash -c "test $(rc c3image) -eq 1 && grep -q 'is an image for the ESP32-C3 (image chip id 5)' '$out/c3image.err'"

# --- no answer --------------------------------------------------------------------------------------------------
rom silent --silent -- --board balance --connect-attempts 1 "$out/app.bin"
check "no answer exits 3" test "$(rc silent)" -eq 3
check "... with the download-mode hint" \
  grep -q 'no serial data received: the board is not in download mode.*Hold BOOT on the BALANCE board and tap RESET.*--no-reset' "$out/silent.err"

rom chatter --chatter -- --board balance --connect-attempts 1 "$out/app.bin"
check "an application talking instead of the ROM exits 3" test "$(rc chatter)" -eq 3
check "... says it runs its application and shows what it said" \
  grep -q 'running its application, not in download mode.*Seen: "ESP-ROM:esp32s3-20210327' "$out/chatter.err"

rom mute --mute-download -- --board balance --connect-attempts 1 "$out/app.bin"
check "a chip in download mode that never answers is told apart (a line problem)" \
  bash -c "test $(rc mute) -eq 3 && grep -q 'the chip is in download mode (its boot log says so: \"ESP-ROM.*waiting for download\") but never answered SYNC: .*unplug, replug and run again$' '$out/mute.err'"

rom echo --echo -- --board io --connect-attempts 1 "$out/app.bin"
check "a loopback is recognised as one" \
  bash -c "test $(rc echo) -eq 3 && grep -q 'comes straight back' '$out/echo.err'"

# --- the IO board (USB-Serial/JTAG) -----------------------------------------------------------------------------
rom io --usb-serial-jtag --flash-file "$out/flash5.bin" -- --board io "$out/app.bin"
check "the IO board flashes with exit 0" test "$(rc io)" -eq 0
check "IO: byte for byte" same "$out/flash5.bin" 0x10000 "$out/app.bin"
check "IO: the application's RTC watchdog is disabled and the super watchdog feeds itself first" \
  json io "r['wdt_disabled'] and r['swd_autofeed']"
check "IO: no baud change over USB" json io "r['baud'] == []"
check "IO: leaves download mode by an RTC watchdog reset, forced-download flag cleared" \
  json io "r['resets'] == [{'kind': 'rtc_watchdog', 'forced_download_cleared': True}]"
check "IO: says so" grep -q 'RTC watchdog system reset' "$out/io.out"

rom iomanual --usb-serial-jtag --boot-pin-held -- --board io --no-reset "$out/app.bin"
check "IO in download mode by hand (BOOT held): still leaves it by the watchdog" \
  bash -c "test $(rc iomanual) -eq 0 && json iomanual \"r['resets'][0]['kind'] == 'rtc_watchdog'\""

rom stub --stub --flash-file "$out/flash6.bin" -- --board balance "$out/app.bin"
check "a stub loader already running is used (16 KiB blocks, 2 status bytes)" \
  bash -c "test $(rc stub) -eq 0 && grep -q 'stub loader' '$out/stub.out'"
check "stub: byte for byte" same "$out/flash6.bin" 0x10000 "$out/app.bin"
check "stub: 16 KiB blocks" json stub "r['regions'][0]['block'] == 0x4000"

# --- faults on the line -----------------------------------------------------------------------------------------
rom badsum --bad-checksum-block 3 --flash-file "$out/flash7.bin" -- --board balance "$out/app.bin"
check "a block refused for its checksum is sent again and the image still lands" \
  bash -c "test $(rc badsum) -eq 0 && same '$out/flash7.bin' 0x10000 '$out/app.bin'"
check "... the emulator did refuse it (error 0x07)" json badsum "{'op': 'FLASH_DEFL_DATA', 'error': 7} in r['errors_sent']"
check "... and the report counts the retry" grep -q '1 block(s) sent again' "$out/badsum.out"

rom dropped --drop-byte-in-block 5 --flash-file "$out/flash8.bin" -- --board balance --no-compress "$out/app2.bin"
check "a block that lost a byte on the line is sent again and the image still lands" \
  bash -c "test $(rc dropped) -eq 0 && same '$out/flash8.bin' 0x10000 '$out/app2.bin'"
check "... the emulator did refuse it (error 0x05)" json dropped "{'op': 'FLASH_DATA', 'error': 5} in r['errors_sent']"

rom vanish --vanish-after 30000 -- --board balance "$out/app.bin"
check "the port vanishing mid-write exits 1" test "$(rc vanish)" -eq 1
check "... and the region is reported UNVERIFIED" \
  bash -c "grep -q '^0x010000 .*UNVERIFIED' '$out/vanish.out' && grep -q 'went away while flashing .*app.bin at 0x10000: that region is UNVERIFIED' '$out/vanish.err'"

# --- refused before touching the board --------------------------------------------------------------------------
rom big -- --board balance "$out/big.bin"
check "an image larger than the flash is refused with exit 1" test "$(rc big)" -eq 1
check "... naming sizes and the fix" grep -q 'beyond the 4 MB flash (assumed: the smallest ESP32-S3 module; pass --flash-size for more)' "$out/big.err"
check "... without a byte sent to the board" json big "r['bytes_in'] == 0"
"$saulctl" flash --board balance --port /dev/null "$out/missing.bin" >/dev/null 2>"$out/missing.err"
check "a missing file exits 1 naming it" bash -c "test $? -eq 1 && grep -q 'missing.bin: no such file' '$out/missing.err'"
"$saulctl" flash --board balance --port /dev/null >/dev/null 2>&1
check "no input is a usage error (exit 2)" test $? -eq 2
"$saulctl" flash --board balance --port /dev/null 0x10000 >/dev/null 2>&1
check "an odd OFFSET FILE list is a usage error (exit 2)" test $? -eq 2
"$saulctl" flash --port /dev/null "$out/app.bin" >/dev/null 2>"$out/noboard.err"
check "a port of unknown identity without --board is a usage error naming --board" \
  bash -c "test $? -eq 2 && grep -q -- '--board balance' '$out/noboard.err'"
"$saulctl" flash --board balance --port /dev/null 0x10800 "$out/app.bin" >/dev/null 2>"$out/align.err"
check "an offset off a 4 KiB sector is refused" grep -q 'not on a 4 KiB sector boundary' "$out/align.err"

# --- what the ROM could not boot, and a build that disagrees with its bootloader ---------------------------------
rom elf -- --board balance "$out/app.elf"
check "an ELF file is refused with exit 1" test "$(rc elf)" -eq 1
check "... saying so and naming the .bin beside it" \
  grep -q "app.elf: this is an ELF file (the linker's output), not a flash image: flash $out/app.bin, the .bin idf.py wrote beside it (--force writes it anyway)$" "$out/elf.err"
check "... before a byte is sent to the board" json elf "r['bytes_in'] == 0"
rom elfforce --flash-file "$out/flash10.bin" -- --board balance --force "$out/app.elf"
check "--force writes the ELF anyway, with a warning" \
  bash -c "test $(rc elfforce) -eq 0 && grep -q 'warning: .*app.elf: this is an ELF file.*written anyway (--force)' '$out/elfforce.err'"
check "... byte for byte" same "$out/flash10.bin" 0x10000 "$out/app.elf"
rom notimage -- --board balance 0x0 "$out/pt.bin" 0x10000 "$out/app.bin"
check "a file at 0x0 without the image magic 0xE9 is refused with exit 1" \
  bash -c "test $(rc notimage) -eq 1 && grep -q 'pt.bin at 0x0: not an ESP image (first byte 0xAA, an image starts with 0xE9)' '$out/notimage.err'"
check "... before a byte is sent to the board" json notimage "r['bytes_in'] == 0"
rom mismatch --flash-file "$out/flash11.bin" --flash-size 0x800000 -- --board balance --build-dir "$out/mismatch"
check "a bootloader header that disagrees with flasher_args.json still flashes (exit 0)" test "$(rc mismatch)" -eq 0
check "... with one warning naming mode, size and frequency" \
  grep -q 'warning: bootloader/bootloader.bin: its header says flash mode dio (flasher_args.json: qio), flash size 8 MB (flasher_args.json: 4MB), flash frequency 80m (flasher_args.json: 40m); .*rebuild (idf.py build) so they agree$' "$out/mismatch.err"
check "a build that agrees with its bootloader gives no warning" bash -c "! grep -q warning '$out/build.err'"

# --- failures mid-write end with their fix ----------------------------------------------------------------------
rom werr --write-error-block 2 -- --board balance --no-compress "$out/app2.bin"
check "a flash write error exits 1" test "$(rc werr)" -eq 1
check "... and says what to do" \
  grep -q 'block 2 of 64 of .*app2.bin refused 3 times, the region at 0x10000 is UNVERIFIED: flash write error (read-back mismatch) (error 0x08): the flash did not take the data .*the module.s flash is faulty$' "$out/werr.err"
rom quiet --quiet-from-block 3 -- --board balance "$out/app.bin"
check "no answer mid-write exits 3" test "$(rc quiet)" -eq 3
check "... with the fix" \
  grep -q 'no answer to block 3 of .* after 3 tries: .*UNVERIFIED: reset the board into download mode (or replug it) and flash again$' "$out/quiet.err"

# --- the robot check --------------------------------------------------------------------------------------------
robot_run() {  # robot_run NAME ROBOT-ARGS... : a robot, then a flash with --link to it
  local name=$1; shift
  start "${name}_robot" "$robot" --log "$out/$name.lines" "$@"
  local link="slcan:$tty_path"
  local robot_ctl=$ctl_fd robot_pid=$last_pid
  rom "$name" --flash-file "$out/flash9.bin" -- --board balance --link "$link" "$out/app2.bin"
  echo quit >&"$robot_ctl" 2>/dev/null
  exec {robot_ctl}>&-
  wait "$robot_pid" 2>/dev/null
}
robot_run robot_off --state 0
check "robot check: mode off acknowledged and 0x400 OFF, then flashed" \
  bash -c "test $(rc robot_off) -eq 0 && grep -q '^robot check: state OFF on slcan:' '$out/robot_off.out'"
check "robot check: it sent mode off (0x302 00)" grep -q '^t302100$' "$out/robot_off.lines"
robot_run robot_balancing --state 1
check "robot check: still BALANCE after mode off -> refused, exit 1" \
  bash -c "test $(rc robot_balancing) -eq 1 && grep -q 'still reports state BALANCE after mode off: not flashing; .*then run again$' '$out/robot_balancing.err'"
check "robot check: ... and the board was not touched" json robot_balancing "r['bytes_in'] == 0"
robot_run robot_silent --no-ack
check "robot check: no acknowledgement -> exit 3 with the way out" \
  bash -c "test $(rc robot_silent) -eq 3 && grep -q -- 'no acknowledgement of mode off.*--skip-robot-check' '$out/robot_silent.err'"
rom skip --flash-file "$out/flash9.bin" -- --board balance --force --skip-robot-check --link slcan:/nonexistent "$out/app2.bin"
check "--skip-robot-check flashes without the robot and warns loudly" \
  bash -c "test $(rc skip) -eq 0 && grep -q 'WARNING: --skip-robot-check' '$out/skip.err'"

echo "$fails failed"
[ "$fails" -eq 0 ]
