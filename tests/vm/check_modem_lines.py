#!/usr/bin/env python3
"""Checks the ESP flasher's DTR/RTS reset sequences as the guest's real tty drivers put them on the wire.

tests/vm/run.sh boots the guest with QEMU tracing every 8250 register write (serial_write) and every FTDI control
request (usb_serial_handle_control) into one file, host-timestamped by -msg timestamp=on:

    7395@1795383592.371173:serial_write write addr 0x04 val 0x0a
    7395@1795383598.032196:usb_serial_handle_control dev 0:1 got control 0x4001, value 0x100

8250: register 4 is the MCR, bit 0 DTR, bit 1 RTS (bit 3 OUT2 is the driver's interrupt enable). FTDI: request
0x4001 is SET_MODEM_CTRL, value = mask << 8 | levels with DTR = 1, RTS = 2; a line not in the mask keeps its level.

The trace does not say which 8250 was written (ttyS0, the console, is one too), so the guest (tests/vm/guest/init.sh,
modem_case) brackets each saulctl run with a byte written to ttyS1's scratch register: CODE before, 0xC0 after.
Within such a window every MCR write is ttyS1's (the console driver does not write the MCR) and every 0x4001 the
FTDI ttyUSB0's.

From the writes in a window the line levels are rebuilt as states (DTR,RTS), consecutive equal states merged,
each lasting until the next change (the last one until the window closes). The states must be exactly the case's
expected list below, in order: strict on order, tolerant on time:
  - a hold of H ms must last H - EARLY .. H + LATE ms (EARLY 15, LATE 40: TCG's timing is good to a few ms, but
    every libserialport call costs a few ms more on the FTDI, and a loaded host delays the guest);
  - a transient (DTR and RTS are set by separate calls, so another state shows between two steps) at most 25 ms;
  - "any" is not timed (the open's state, the SYNC attempts between two resets);
  - "at least H" for the last state, timed to the end of the window (after saulctl exited);
  - an optional state may be absent.
SAUL_VM_MODEM_EARLY_MS, SAUL_VM_MODEM_LATE_MS and SAUL_VM_MODEM_TRANSIENT_MS override the tolerances.

Usage: check_modem_lines.py TRACE CODE:CASE... [--verbose]
Prints "pass  modem lines: ..." or "FAIL  modem lines: ..." (with the timeline) per case; exit status 1 when any
case failed or its window is missing.
"""
import os
import re
import sys

EARLY_MS = float(os.environ.get("SAUL_VM_MODEM_EARLY_MS", "15"))
LATE_MS = float(os.environ.get("SAUL_VM_MODEM_LATE_MS", "40"))
TRANSIENT_MS = float(os.environ.get("SAUL_VM_MODEM_TRANSIENT_MS", "25"))
WINDOW_END = 0xC0


def hold(state, ms, why):
    return {"state": state, "kind": "hold", "ms": ms, "why": why}


def transient(state, why, optional=False):
    return {"state": state, "kind": "transient", "why": why, "optional": optional}


def any_time(state, why, optional=False):
    return {"state": state, "kind": "any", "why": why, "optional": optional}


def at_least(state, ms, why):
    return {"state": state, "kind": "at_least", "ms": ms, "why": why}


# States are "DR": DTR then RTS. esp_flasher.cpp sets each step with set_modem_lines(dtr, rts), which libserialport
# does as sp_set_dtr then sp_set_rts (sp_set_rts first when both go low): a step that raises DTR and drops RTS
# shows (1,1) in between (as esptool's ClassicReset does: setDTR(True) then setRTS(False)).
OPEN = [any_time("00", "port closed, lines low", optional=True),
        any_time("11", "open: the kernel raises DTR and RTS")]

CLASSIC_RESET_50 = [hold("01", 100, "EN low: in reset"),
                    transient("11", "DTR raised before RTS dropped"),
                    hold("10", 50, "GPIO0 low, EN released: the ROM samples GPIO0")]
CLASSIC_RESET_550 = [hold("01", 100, "EN low: in reset"),
                     transient("11", "DTR raised before RTS dropped"),
                     hold("10", 550, "GPIO0 low for 550 ms (second attempt, slow EN capacitor)")]
USJ_RESET = [
    # From the open's (1,1), the step to (0,0) drops RTS first (as esptool's USBJTAGSerialReset does), so the
    # lines pass through (1,0), never through (0,1), which the USB-Serial/JTAG takes as a reset request.
    transient("10", "RTS dropped before DTR (from the open's (1,1)), never (0,1)"),
    hold("00", 100, "idle"),
    hold("10", 100, "boot pin low"),
    transient("11", "through (1,1), never (0,0), into reset"),
    hold("01", 100, "reset"),
]

CASES = {
    # saulctl flash --board balance --port /dev/ttyS1 --connect-attempts 2 FILE: nothing answers, exit 3.
    "bridge-flash-2-attempts": ("8250", OPEN + CLASSIC_RESET_50 +
                                [any_time("00", "GPIO0 released; SYNC attempts, no answer")] +
                                CLASSIC_RESET_550 + [any_time("00", "GPIO0 released; SYNC attempts, then close")]),
    # saulctl flash --board balance --port /dev/ttyS1 --reset bootloader
    "bridge-reset-bootloader": ("8250", OPEN + CLASSIC_RESET_50 + [any_time("00", "GPIO0 released; close")]),
    # saulctl flash --board balance --port /dev/ttyS1 --reset app: the EN pulse
    "bridge-reset-app": ("8250", OPEN + [hold("01", 100, "EN low: in reset"),
                                         any_time("00", "EN released, GPIO0 high: boots the application")]),
    # saulctl flash --board io --port /dev/ttyUSB0 --reset bootloader
    "usj-reset-bootloader": ("ftdi", OPEN + USJ_RESET + [any_time("00", "out of reset; close")]),
    # saulctl flash --board io --port /dev/ttyUSB0 --reset app: no loader answers (SYNC attempts in the open's
    # state), so the USB-Serial/JTAG RTS reset restarts the application.
    "usj-reset-app": ("ftdi", OPEN[:1] + [any_time("11", "open; SYNC attempts, no answer"),
                                          hold("01", 200, "reset"),
                                          at_least("00", 200, "out of reset, waited before closing")]),
}

LINE = re.compile(r"^\d+@(\d+)\.(\d+):(\S+) (.*)$")
MCR_WRITE = re.compile(r"write addr 0x([0-9a-f]+) val 0x([0-9a-f]+)")
FTDI_CTRL = re.compile(r"got control 0x([0-9a-f]+), value 0x([0-9a-f]+)")


def read_events(path):
    """(time in s, kind, a, b): ("reg", addr, value) for serial_write, ("ctrl", request, value) for the FTDI."""
    events = []
    with open(path, errors="replace") as f:
        for line in f:
            m = LINE.match(line.strip())
            if not m:
                continue
            t = int(m.group(1)) + int(m.group(2)) / 1e6
            if m.group(3) == "serial_write":
                w = MCR_WRITE.search(m.group(4))
                if w:
                    events.append((t, "reg", int(w.group(1), 16), int(w.group(2), 16)))
            elif m.group(3) == "usb_serial_handle_control":
                c = FTDI_CTRL.search(m.group(4))
                if c:
                    events.append((t, "ctrl", int(c.group(1), 16), int(c.group(2), 16)))
    return events


def window(events, code):
    """Events strictly between the last scratch write of CODE and the next 0xC0 one, and the two times."""
    start = end = None
    for i, (t, kind, a, b) in enumerate(events):
        if kind == "reg" and a == 7 and b == code:
            start, end = i, None
        elif kind == "reg" and a == 7 and b == WINDOW_END and start is not None and end is None:
            end = i
    if start is None or end is None:
        return None
    return events[start + 1:end], events[start][0], events[end][0]


def ftdi_levels_before(events, t0):
    """The FTDI's (dtr, rts) before t0, from every SET_MODEM_CTRL since the boot (both low at reset)."""
    dtr = rts = 0
    for t, kind, a, b in events:
        if t >= t0:
            break
        if kind == "ctrl" and a == 0x4001:
            dtr, rts = apply_ftdi(dtr, rts, b)
    return dtr, rts


def apply_ftdi(dtr, rts, value):
    if value & 0x100:
        dtr = value & 1
    if value & 0x200:
        rts = (value >> 1) & 1
    return dtr, rts


def timeline(port, evs, t_start, t_end, all_events):
    """[(state "DR", start s, duration ms, writes)] with consecutive equal states merged."""
    changes = []  # (t, state)
    if port == "ftdi":
        dtr, rts = ftdi_levels_before(all_events, t_start)
        for t, kind, a, b in evs:
            if kind == "ctrl" and a == 0x4001:
                dtr, rts = apply_ftdi(dtr, rts, b)
                changes.append((t, f"{dtr}{rts}"))
    else:
        for t, kind, a, b in evs:
            if kind == "reg" and a == 4:
                changes.append((t, f"{b & 1}{(b >> 1) & 1}"))
    states = []
    for t, st in changes:
        if states and states[-1][0] == st:
            states[-1][3] += 1
            continue
        states.append([st, t, 0.0, 1])
    for i, s in enumerate(states):
        s[2] = ((states[i + 1][1] if i + 1 < len(states) else t_end) - s[1]) * 1000
    return states


def fits(step, duration_ms):
    kind = step["kind"]
    if kind == "any":
        return True, ""
    if kind == "transient":
        return duration_ms <= TRANSIENT_MS, f"transient, at most {TRANSIENT_MS:g} ms"
    if kind == "at_least":
        return duration_ms >= step["ms"] - EARLY_MS, f"at least {step['ms'] - EARLY_MS:g} ms"
    lo, hi = step["ms"] - EARLY_MS, step["ms"] + LATE_MS
    return lo <= duration_ms <= hi, f"{step['ms']} ms: {lo:g}..{hi:g} ms"


def match(spec, states):
    """Aligns the states with the spec (optional steps may be skipped): (ok, explanation lines)."""
    # Small sequences: plain backtracking over the optional steps.
    def go(i, j):
        if i == len(spec):
            return [] if j == len(states) else None
        step = spec[i]
        if j < len(states) and states[j][0] == step["state"]:
            ok, _ = fits(step, states[j][2])
            if ok:
                rest = go(i + 1, j + 1)
                if rest is not None:
                    return [(i, j)] + rest
        if step.get("optional"):
            return go(i + 1, j)
        return None

    return go(0, 0)


def fmt_state(s):
    return f"({s[0]},{s[1]})"


def describe_spec(spec):
    out = []
    for st in spec:
        k = st["kind"]
        t = {"any": "any time", "transient": f"transient <= {TRANSIENT_MS:g} ms",
             "hold": f"{st.get('ms')} ms (-{EARLY_MS:g}/+{LATE_MS:g})",
             "at_least": f">= {st.get('ms', 0) - EARLY_MS:g} ms"}[k]
        out.append(f"{fmt_state(st['state'])} {t}{' [optional]' if st.get('optional') else ''}  {st['why']}")
    return out


def check(case, code, events, verbose):
    port, spec = CASES[case]
    where = "8250 ttyS1 MCR" if port == "8250" else "FTDI ttyUSB0 SET_MODEM_CTRL"
    w = window(events, code)
    if w is None:
        print(f"FAIL  modem lines: {case}: no complete window 0x{code:02X}..0x{WINDOW_END:02X} in the trace")
        return False
    evs, t0, t1 = w
    states = timeline(port, evs, t0, t1, events)
    got = ", ".join(f"{fmt_state(s[0])} {s[2]:.1f} ms" for s in states)
    aligned = match(spec, states)
    if aligned is not None:
        timed = [f"{fmt_state(states[j][0])} {states[j][2]:.0f} ms" for i, j in aligned
                 if spec[i]["kind"] in ("hold", "at_least")]
        print(f"pass  modem lines: {case} ({where}): {len(states)} states in order; holds {', '.join(timed)}")
        if verbose:
            print(f"        (DTR,RTS) as seen: {got}")
        return True
    print(f"FAIL  modem lines: {case} ({where}): the line states are not the expected sequence")
    print(f"        (DTR,RTS) as seen, each until the next change: {got or 'no modem-line writes at all'}")
    print("        expected:")
    for line in describe_spec(spec):
        print(f"          {line}")
    # The first step that does not fit, walking without the optional ones that are absent.
    j = 0
    for step in spec:
        if j >= len(states):
            if not step.get("optional"):
                print(f"        first difference: missing {fmt_state(step['state'])} ({step['why']})")
                break
            continue
        st = states[j]
        if st[0] != step["state"]:
            if step.get("optional"):
                continue
            print(f"        first difference: state {j + 1} is {fmt_state(st[0])}, expected {fmt_state(step['state'])} "
                  f"({step['why']})")
            break
        ok, rule = fits(step, st[2])
        if not ok:
            print(f"        first difference: state {j + 1} {fmt_state(st[0])} lasted {st[2]:.1f} ms, expected {rule} "
                  f"({step['why']})")
            break
        j += 1
    else:
        if j < len(states):
            print(f"        first difference: {len(states) - j} unexpected state(s) after the sequence, from "
                  f"{fmt_state(states[j][0])}")
    return False


def main(argv):
    verbose = "--verbose" in argv
    args = [a for a in argv if a != "--verbose"]
    if len(args) < 1:
        print(__doc__, file=sys.stderr)
        return 2
    trace, wanted = args[0], args[1:]
    try:
        events = read_events(trace)
    except OSError as e:
        print(f"FAIL  modem lines: cannot read the trace {trace}: {e.strerror}")
        return 1
    ok = True
    for item in wanted:
        code, _, case = item.partition(":")
        if case not in CASES:
            print(f"FAIL  modem lines: unknown case '{case}' (known: {', '.join(CASES)})")
            ok = False
            continue
        ok = check(case, int(code, 0), events, verbose) and ok
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
