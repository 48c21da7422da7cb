"""saulctl decode --format long: one row per signal (time,interface,id,message,signal,value,unit), loaded into an
SQL engine and aggregated per signal without parsing strings: Python's sqlite3, and DuckDB itself (not packaged in
Debian: its Node package @duckdb/node-api, which scripts/setup.sh installs into tests/npm from the npm registry;
tests/npm/long_csv_duckdb.mjs runs the query of docs/captures.md over read_csv_auto).

The per-signal counts and means are compared with the same figures worked out from `saulctl decode --json` (the
wire integers) through a table of scales written here by hand from docs/protocol.md, and a few rows are checked
against the bytes of captures/robot_bus.log by hand.

usage: long_csv.py SAULCTL ROOT
"""
import csv
import io
import json
import os
import sqlite3
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import Checks, Saulctl  # noqa: E402

exe, root = sys.argv[1], sys.argv[2]
saulctl = Saulctl(exe)
c = Checks()
log = os.path.join(root, "captures", "robot_bus.log")

code, long_csv, err = saulctl.run(["decode", "--format", "long", log])
c.check("decode --format long exits 0", code == 0, err)
lines = long_csv.splitlines()
c.check("header: time,interface,id,message,signal,value,unit", lines[0] == "time,interface,id,message,signal,value,unit",
        lines[0])

# By hand from the bytes: 400#63004F00900101 at 2.900900 s: pitch 0x0063 = 99 -> 0.99 deg, pid_out 0x4F = 79,
# speed 0x0190 = 400 mm/s, state 1 (BALANCE, as its number); 401#...B09A.. -> 0x9AB0 = 39600 mV = 39.6 V;
# 303#D007B004 -> tilt 2000 -> 20 deg; VESC 00000944#00000093000C000B -> current 12 / 10 = 1.2 A.
for row in ["1763800002.900900,can0,400,telemetry_a,pitch,0.99,deg",
            "1763800002.900900,can0,400,telemetry_a,pid_out,79,permille",
            "1763800002.900900,can0,400,telemetry_a,speed_mmps,400,mm/s",
            "1763800002.900900,can0,400,telemetry_a,state,1,",
            "1763800000.001000,can0,401,telemetry_b,battery,39.6,V",
            "1763800000.700000,can0,303,config_cmd,tilt_limit,20,deg",
            "1763800001.550500,can0,00000944,vesc_status_1,current,1.2,A",
            "1763800001.550500,can0,00000944,vesc_status_1,controller_id,68,"]:
    c.check(f"row by hand: {row}", row in lines)

db = sqlite3.connect(":memory:")
db.execute("create table s (time real, interface text, id text, message text, signal text, value real, unit text)")
db.executemany("insert into s values (?,?,?,?,?,?,?)", list(csv.reader(io.StringIO(long_csv)))[1:])
typed = db.execute("select count(*) from s where typeof(value) != 'real'").fetchone()[0]
c.check("every value is a number the engine stores as one (no string parsing)", typed == 0, typed)
got = {(m, s): (n, avg, unit) for m, s, n, avg, unit in
       db.execute("select message, signal, count(*), avg(value), min(unit) from s group by message, signal")}

# The same from JSON: key -> (signal, factor to the physical unit, unit), by hand from docs/protocol.md.
SCALES = {
    ("telemetry_a", "pitch_raw"): ("pitch", 0.01, "deg"),
    ("telemetry_a", "pid_out"): ("pid_out", 1, "permille"),
    ("telemetry_a", "speed_mmps"): ("speed_mmps", 1, "mm/s"),
    ("telemetry_b", "battery_raw"): ("battery", 0.001, "V"),
    ("telemetry_b", "vesc_l_rpm"): ("vesc_l_rpm", 1, "rpm"),
    ("velocity_cmd", "speed_mmps"): ("speed_mmps", 1, "mm/s"),
    ("velocity_cmd", "steer_mrad"): ("steer_mrad", 1, "mrad"),
    ("vesc_status_1", "erpm"): ("erpm", 1, "rpm"),
    ("vesc_status_1", "current"): ("current", 1, "A"),
    ("vesc_status_5", "voltage_in"): ("voltage_in", 1, "V"),
    ("vesc_set_rpm", "erpm"): ("erpm", 1, "rpm"),
}
code, jsonl, err = saulctl.run(["decode", "--json", log])
sums = {}
signals_in_json = 0
# JSON has a scaled wire integer twice: raw ("pitch_raw": 1234) and physical ("pitch": 12.34), written here
# by hand; the long CSV has it once, physical. The twin must be the raw value times the factor.
PHYSICAL_TWINS = {("telemetry_a", "pitch"): "pitch_raw", ("telemetry_b", "battery"): "battery_raw",
                  ("config_cmd", "tilt_limit"): "tilt_limit_raw"}
twins_checked, twins_wrong = 0, []
for line in jsonl.splitlines():
    msg = json.loads(line).get("message", {})
    # every signal but the type and strings; named values (state, mode, result, gain) are rows too, as numbers
    for k in msg:
        raw_key = PHYSICAL_TWINS.get((msg["type"], k))
        if raw_key is None:
            signals_in_json += k != "type"
            continue
        twins_checked += 1
        want = msg[raw_key] * (0.001 if raw_key == "battery_raw" else 0.01)
        if not isinstance(msg[k], float) or abs(msg[k] - want) > 1e-9:
            twins_wrong.append((msg["type"], k, msg[k], msg[raw_key]))
    for key, value in msg.items():
        if (msg["type"], key) in SCALES:
            name, factor, unit = SCALES[(msg["type"], key)]
            n, total = sums.get((msg["type"], name), (0, 0.0))
            sums[(msg["type"], name)] = (n + 1, total + value * factor)
c.check(f"JSON's physical twins are the raw values scaled ({twins_checked} checked)",
        twins_checked > 0 and not twins_wrong, twins_wrong[:5])
for (message, signal), (n, total) in sorted(sums.items()):
    want = (n, total / n)
    have = got.get((message, signal))
    c.check(f"{message}.{signal}: count {n}, mean {total / n:.6g} as from JSON by hand",
            have is not None and have[0] == n and abs(have[1] - want[1]) <= 1e-9 * max(1, abs(want[1])),
            f"long CSV {have}, JSON {want}")
    unit = [u for (m, k), (s, f, u) in SCALES.items() if m == message and s == signal][0]
    c.check(f"{message}.{signal}: unit {unit}", have is not None and have[2] == unit, have)
c.check("one row per number signal of every decoded frame", len(lines) - 1 == signals_in_json,
        f"{len(lines) - 1} rows, {signals_in_json} number signals in JSON")

# DuckDB, as a data engineer would load the file: the same counts, means and units per signal, the value column
# inferred as numbers (DOUBLE) without being told.
import subprocess  # noqa: E402
import tempfile  # noqa: E402
npm_dir = os.path.join(root, "tests", "npm")
c.check("DuckDB's Node package is installed (scripts/setup.sh: npm ci in tests/npm)",
        os.path.isdir(os.path.join(npm_dir, "node_modules", "@duckdb", "node-api")), npm_dir)
with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
    f.write(long_csv)
try:
    r = subprocess.run(["node", os.path.join(npm_dir, "long_csv_duckdb.mjs"), f.name], capture_output=True, text=True,
                       timeout=120)
finally:
    os.unlink(f.name)
c.check("DuckDB reads the long CSV", r.returncode == 0, r.stderr[-600:])
duck = {(row["message"], row["signal"]): row for row in json.loads(r.stdout or "[]")}
c.check("DuckDB: the same message/signal groups as sqlite", set(duck) == set(got), sorted(set(duck) ^ set(got))[:5])
c.check("DuckDB infers every value as DOUBLE", all(row["value_type"] == "DOUBLE" for row in duck.values()),
        [k for k, row in duck.items() if row["value_type"] != "DOUBLE"][:5])
mismatch = [(k, row, got.get(k)) for k, row in duck.items() if got.get(k) is None or row["n"] != got[k][0]
            or abs(row["mean"] - got[k][1]) > 1e-9 * max(1, abs(got[k][1])) or row["unit"] != (got[k][2] or "")]
c.check(f"DuckDB: count, mean and unit of all {len(duck)} signals equal sqlite's (checked above against JSON by hand)",
        not mismatch, mismatch[:3])

# saulctl's own stats --signals: the same counts and means as DuckDB (and sqlite) over the long CSV, min and max
# bounding the mean, the same units.
code, out, err = saulctl.run(["stats", "--signals", "--json", log])
own = {(r["message"], r["signal"]): r for r in (json.loads(out).get("signals", []) if code == 0 else [])}
c.check("saulctl stats --signals --json exits 0 with a signals list", code == 0 and own, err[-300:])
c.check("stats --signals: the same message/signal groups as DuckDB", set(own) == set(duck), sorted(set(own) ^ set(duck))[:5])
differ = [(k, r, duck.get(k)) for k, r in own.items() if duck.get(k) is None or r["count"] != duck[k]["n"]
          or abs(r["mean"] - duck[k]["mean"]) > 1e-9 * max(1, abs(duck[k]["mean"])) or r["unit"] != duck[k]["unit"]
          or not r["min"] <= r["mean"] <= r["max"]]
c.check(f"stats --signals: count, mean and unit of all {len(own)} signals equal DuckDB's", not differ, differ[:3])

# Serial captures too (inter-board STATE pitch -1234 -> -12.34 deg).
code, out, err = saulctl.run(["decode", "--format", "long", os.path.join(root, "captures", "interboard_uart.serial")])
c.check("inter-board serial capture: STATE pitch -12.34 deg, no id", code == 0 and
        "0000000000.001100,serial:/dev/ttyUSB0@460800:8N1,,state,pitch,-12.34,deg" in out.splitlines(), out[:400])
c.exit()
