#!/usr/bin/env python3
"""saulctl wireshark: the generated Lua dissector, run by tshark over captures, must give every field the value
`saulctl decode --json` gives it (tests/cli/wireshark.sh). The captures are the samples robot_bus.log (SAUL and
VESC frames of a drive) and glitches.log (a wrong DLC, an unknown id, a remote and an error frame, an out-of-range
mode, a 29-bit id 0x300 that is a VESC frame), converted to pcapng and pcap.

Usage: wireshark.py SAULCTL ROOT
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import Checks, Saulctl  # noqa: E402

saulctl, root = Saulctl(sys.argv[1]), sys.argv[2]
checks = Checks()
check = checks.check
if not shutil.which("tshark"):
    print("SKIP tshark is not installed (scripts/setup.sh installs it)")
    checks.exit()
tmp = tempfile.mkdtemp(prefix="saul_wireshark_")
lua = os.path.join(tmp, "saul.lua")
code, _, err = saulctl.run(["wireshark", "-o", lua])
check("saulctl wireshark -o saul.lua exits 0", code == 0 and os.path.getsize(lua) > 0, err)
code, out, _ = saulctl.run(["wireshark", "--fields"])
fields = out.split()
check("the fields: saul.message, saul.problem, one per signal key and one per physical value of a scaled key",
      fields[:2] == ["saul.message", "saul.problem"] and "saul.telemetry_a.pitch_raw" in fields
      and "saul.telemetry_a.pitch" in fields and "saul.telemetry_b.battery" in fields
      and "saul.vesc_status_1.erpm" in fields and "saul.pid_gain.kd" in fields, fields[:6])


def same(expected, got):
    """A JSON value against tshark's text of it."""
    if isinstance(expected, bool):
        return got == str(int(expected))
    if isinstance(expected, (int, float)):
        try:
            g = float(got)
        except ValueError:
            return False
        return abs(g - expected) <= 1e-6 * max(1.0, abs(expected))
    return got == str(expected)


for sample in ("robot_bus.log", "glitches.log"):
    for ext in ("pcapng", "pcap"):
        cap = os.path.join(tmp, sample + "." + ext)
        saulctl.run(["convert", os.path.join(root, "captures", sample), cap])
        _, decoded, _ = saulctl.run(["decode", "--json", cap])
        frames = [json.loads(line) for line in decoded.splitlines() if line.strip()]
        args = ["tshark", "-X", "lua_script:" + lua, "-r", cap, "-T", "fields", "-E", "separator=\t",
                "-E", "occurrence=f"]
        for f in fields:
            args += ["-e", f]
        run = subprocess.run(args, capture_output=True, text=True)
        rows = [dict(zip(fields, line.split("\t"))) for line in run.stdout.splitlines()]
        problems = []
        if run.returncode != 0 or "Lua Error" in run.stdout + run.stderr:
            problems.append(run.stderr.strip()[:500])
        if len(rows) != len(frames):
            problems.append(f"{len(rows)} packets, {len(frames)} decoded frames")
        compared = 0
        for i, (j, row) in enumerate(zip(frames, rows)):
            if "message" in j:
                m = j["message"]
                if row["saul.message"] != m["type"]:
                    problems.append(f"frame {i + 1}: message {row['saul.message']!r}, decode says {m['type']}")
                for key, value in m.items():
                    if key == "type":
                        continue
                    got = row.get(f"saul.{m['type']}.{key}")
                    compared += 1
                    if got is None or not same(value, got):
                        problems.append(f"frame {i + 1}: {m['type']}.{key} = {got!r}, decode says {value!r}")
            elif j.get("error") in ("wrong_dlc", "out_of_range"):
                if row["saul.problem"] != j["error"]:
                    problems.append(f"frame {i + 1}: problem {row['saul.problem']!r}, decode says {j['error']}")
            elif row["saul.message"]:
                problems.append(f"frame {i + 1}: dissected as {row['saul.message']}, decode says {j.get('error')}")
        check(f"{sample} as {ext}: tshark with saul.lua gives what decode --json gives ({compared} values)",
              not problems and compared > 0, "\n".join(problems[:10]))

# what a person sees: the tree in physical units
run = subprocess.run(["tshark", "-X", "lua_script:" + lua, "-r", os.path.join(tmp, "robot_bus.log.pcapng"), "-V",
                      "-Y", "saul.message == \"telemetry_b\""], capture_output=True, text=True)
check("the tree shows physical units and names (battery in V, faults by name)",
      "battery: 39.6 V  [battery_raw = 39600]" in run.stdout and "SAUL-TEE SAUL telemetry_b" in run.stdout,
      run.stdout[:800])
run = subprocess.run(["tshark", "-X", "lua_script:" + lua, "-r", os.path.join(tmp, "glitches.log.pcapng"), "-V",
                      "-Y", "saul.problem"], capture_output=True, text=True)
check("a frame saulctl rejects carries an expert warning", "saulctl rejects this frame: wrong_dlc" in run.stdout,
      run.stdout[:800])
shutil.rmtree(tmp)
checks.exit()
