"""One grammar across saulctl's verbs (docs/cli.md, issue 14).

The table below is written by hand: for each verb, which of the shared words it takes. Every verb's --help is
read and checked against it, each shared option must be spelled one way wherever it appears, and the README's
list of the verbs that take --json must be the truth. Then the grammar is driven: an explicit link beats
$SAUL_LINK on every live verb, `--id 400` is 0x400 in decode, a bad id or duration is a usage error, and --for
is the same as --duration.

usage: grammar.py SAULCTL ROOT
"""
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import Checks, Saulctl  # noqa: E402

exe, root = sys.argv[1], sys.argv[2]
saulctl = Saulctl(exe)
c = Checks()

# verb -> the shared words it takes. link: -l/--link; LINK: the link also as a positional; id: --id (hex);
# duration: --duration with --for as its alias; count: -n/--count; json: --json.
TABLE = {
    "decode": {"id", "json"},
    "convert": set(),
    "stats": {"json"},
    "record": {"link", "LINK", "duration", "count"},
    "replay": {"link", "id", "json"},
    "plot": set(),  # its --id also takes message names (telemetry_a); checked apart below
    "sniff": {"link", "LINK", "id", "duration", "count", "json"},
    "monitor": {"link", "duration", "json"},
    "mode": {"link", "json"},
    "estop": {"link", "json"},
    "pid": {"link", "json"},
    "config": {"link", "json"},
    "drive": {"link", "duration", "json"},
    "ports": {"json"},
    "sim": {"duration"},
    "test": {"link"},
    "flash": {"link"},
    "console": {"json"},  # a board's USB console: a port, not a CAN link
    "pride vcu": {"duration", "json"},  # the Pride one-wire port, not a CAN link
    "doctor": {"link", "json"},
    "completion": set(),
    "dbc": set(),
    "wireshark": set(),
    "tune record": {"duration", "json"},  # BALANCE's console port, or --sim
    "tune report": {"json"},
    "tune compare": {"json"},
}


def help_of(verb):
    code, out, err = saulctl.run(verb.split() + ["--help"])
    return code, out


def options_of(text):
    """{frozenset of the names on one option line: help text after them}, from CLI11's Options section."""
    opts = {}
    section = ""
    last = None
    for line in text.splitlines():
        if re.match(r"^[A-Z][a-z]+:$", line):
            section, last = line, None
            continue
        m = re.match(r"^  (-[^ ]+)(?: [^ ]+)?(?:\s+(.*))?$", line)
        if section == "Options:" and m:
            last = frozenset(n for n in m.group(1).split(",") if n.startswith("-"))
            opts[last] = m.group(2) or ""
        elif section == "Options:" and last is not None and line.startswith(" " * 10):
            opts[last] += " " + line.strip()  # CLI11 puts the text of a long option line on the next line
        else:
            last = None
    return opts


def positionals_of(text):
    names = []
    section = ""
    for line in text.splitlines():
        if re.match(r"^[A-Z][a-z]+:$", line):
            section = line
            continue
        m = re.match(r"^  ([A-Za-z][^ ]*)", line)
        if section == "Positionals:" and m:
            names.append(m.group(1))
    return names


# Every verb saulctl lists is in the table (a new verb must say which words it takes).
code, top = help_of("")
listed = set(re.findall(r"^  ([a-z]+)\s", top.split("Subcommands:")[1], re.M))
tabled = {v.split()[0] for v in TABLE}
c.check("every verb of 'saulctl --help' is in the table", listed == tabled, f"listed {sorted(listed)}")

# The one spelling of each shared option (the names on its help line, exactly).
SPELLING = {
    "link": lambda names: {"-l", "--link"} <= names and names <= {"-l", "--link", "--to"},
    "id": lambda names: names == {"--id"},
    "duration": lambda names: names == {"--duration", "--for"},
    "count": lambda names: names == {"-n", "--count"},
    "json": lambda names: names == {"--json"},
}
MARK = {"link": "--link", "id": "--id", "duration": "--duration", "count": "--count", "json": "--json"}
# Other spellings of the same words that must not come back.
FORBIDDEN = {"--for", "--to", "--link", "--id", "--duration", "--count", "--json", "--ids", "--time-limit",
             "--seconds", "--jsonl", "--port-link", "--bus", "--channel", "--can"}

for verb, words in TABLE.items():
    code, text = help_of(verb)
    if code != 0:
        c.check(f"{verb} --help exits 0", False, text)
        continue
    opts = options_of(text)
    for word, ok in SPELLING.items():
        lines = [names for names in opts if MARK[word] in names]
        if word in words:
            c.check(f"{verb}: takes {MARK[word]}, spelled {sorted(lines[0]) if lines else '?'}",
                    len(lines) == 1 and ok(lines[0]), f"{[sorted(l) for l in lines]}")
        elif verb != "plot" or word != "id":
            c.check(f"{verb}: no {MARK[word]} (the table says so)", not lines, f"{[sorted(l) for l in lines]}")
    # A shared word under another name: any option line naming one of them must be one of the spellings above.
    for names in opts:
        odd = names & FORBIDDEN
        if odd and not any(ok(names) for ok in SPELLING.values()) and not (verb == "plot" and names == {"--id"}):
            c.check(f"{verb}: {sorted(names)} is a shared word spelled another way", False)
    pos = positionals_of(text)
    c.check(f"{verb}: the link as a positional LINK {'too' if 'LINK' in words else 'never'}",
            ("LINK" in pos) == ("LINK" in words), f"positionals {pos}")
    # The help of each shared option says its grammar.
    for names, desc in opts.items():
        if names == {"--id"} and verb != "plot":
            c.check(f"{verb}: --id says ids are hex, 400 = 0x400, and takes ID:MASK and FIRST-LAST",
                    "hex" in desc and "400 = 0x400" in desc and "ID:MASK" in desc and "FIRST-LAST" in desc, desc)
        if names == {"--duration", "--for"}:
            c.check(f"{verb}: --duration names its units", "ms" in desc and "10s" in desc, desc)
    # Examples use the one grammar too: no "--for" or "--to" in the worked examples.
    examples = text.split("Examples:")[1] if "Examples:" in text else ""
    c.check(f"{verb}: examples say --duration and --link (no --for, no --to)",
            not re.search(r"(^|\s)--(for|to)\s", examples), examples)

code, text = help_of("plot")
c.check("plot --id: a hex CAN id or a message name", "in hex (400 = 0x400)" in options_of(text).get(frozenset({"--id"}), ""))

# The README's list of the verbs that take --json is the truth, both ways.
readme = open(os.path.join(root, "README.md"), encoding="utf-8").read()
m = re.search(r"Verbs whose output is data take `--json` for scripts: (.*?)\.\n", readme)
c.check("README lists the verbs that take --json", m is not None)
readme_json = set(re.findall(r"`([a-z ]+)`", m.group(1))) if m else set()
table_json = {v for v, words in TABLE.items() if "json" in words}
c.check("README's --json verbs are exactly the table's", readme_json == table_json,
        f"README {sorted(readme_json)} table {sorted(table_json)}")
for verb in sorted(readme_json):
    code, text = help_of(verb)
    c.check(f"README says '{verb}' takes --json: its --help shows it", frozenset({"--json"}) in options_of(text))
c.check("README links docs/cli.md", "(docs/cli.md)" in readme)

# An explicit link beats $SAUL_LINK on every live verb, whichever way it is given; the error names the link given.
env = dict(os.environ, SAUL_LINK="slcan:/dev/saul-from-env")
live = [
    ["sniff", "--link", "LINK"], ["sniff", "LINK"], ["sniff", "--id", "400", "LINK"], ["sniff", "LINK", "--id", "400,401"],
    ["record", "--link", "LINK", "-o", "OUT"], ["record", "LINK", "-o", "OUT"], ["monitor", "--link", "LINK"],
    ["mode", "off", "--link", "LINK"], ["estop", "-l", "LINK"], ["pid", "1", "2", "3", "--link", "LINK"],
    ["config", "--tilt-limit", "10", "--max-speed", "100", "--link", "LINK"],
    ["drive", "--speed", "0", "--yes", "--duration", "1s", "--link", "LINK"], ["doctor", "--link", "LINK"],
    ["replay", os.path.join(root, "captures", "robot_bus.log"), "--link", "LINK"],
]
out_dir = os.environ.get("TMPDIR", "/tmp")
for args in live:
    real = [a.replace("LINK", "slcan:/dev/saul-given").replace("OUT", os.path.join(out_dir, f"grammar-{os.getpid()}.log"))
            if a in ("LINK", "OUT") else a for a in args]
    p = subprocess.run([exe] + real, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=30)
    said = p.stdout + p.stderr
    c.check(f"{' '.join(args)} with SAUL_LINK set: opens the given link (exit 1, names it), not SAUL_LINK's",
            p.returncode == 1 and "saul-given" in said and "saul-from-env" not in said, f"{p.returncode} {said}")
    try:
        os.unlink(os.path.join(out_dir, f"grammar-{os.getpid()}.log"))
    except FileNotFoundError:
        pass

p = subprocess.run([exe, "sniff", "--link", "can0", "slcan:/dev/x"], capture_output=True, text=True)
c.check("sniff with two different links: usage error naming both", p.returncode == 2 and "two links" in p.stderr,
        p.stderr)

# Ids are hex everywhere: decode --id 400 is 0x400 (the sample's 30 telemetry_a frames), as 0x400 is.
log = os.path.join(root, "captures", "robot_bus.log")
counts = {}
for form in ("400", "0x400", "0X400", "400:7FF"):
    code, out, err = saulctl.run(["decode", "--id", form, log])
    counts[form] = (code, len(out.splitlines()), all(" 400#" in l for l in out.splitlines()))
c.check("decode --id 400 = 0x400 = 0X400 = 400:7FF: the 30 frames of 0x400", set(counts.values()) == {(0, 30, True)},
        counts)
code, out, err = saulctl.run(["decode", "--id", "400,300", log])
code2, out2, _ = saulctl.run(["decode", "--id", "400", "--id", "300", log])
c.check("--id 400,300 = --id 400 --id 300", code == 0 and out == out2 and len(out.splitlines()) > 30)
# Ranges: FIRST-LAST is every id from FIRST to LAST (made of aligned ID:MASK blocks: 301-305 is 301, 302:7FE,
# 304:7FE and nothing more), the same frames as the ids listed one by one.
for rng, listed in (("400-401", "400,401"), ("300-303", "300,301,302,303"), ("301-305", "301,302,303,304,305"),
                    ("0x2FF-0x402", "300,301,302,303,400,401,402")):
    code, out, err = saulctl.run(["decode", "--id", rng, log])
    code2, out2, _ = saulctl.run(["decode", "--id", listed, log])
    c.check(f"decode --id {rng} = --id {listed}", code == 0 and code2 == 0 and out == out2 and out, err)
code, out, err = saulctl.run(["decode", "--id", "00000900-000009FF", log])
c.check("a 29-bit range (00000900-000009FF): the VESC status frames 0x938 and 0x944 only",
        code == 0 and out and all(l.split()[2].split("#")[0] in ("00000938", "00000944") for l in out.splitlines()), out[:300])
for bad in ("401-400", "400-40F:7F0", "400-"):
    code, out, err = saulctl.run(["decode", "--id", bad, log])
    c.check(f"decode --id {bad}: usage error", code == 2 and "--help" in err, err)
for opt in ("--id", "--exclude-id"):
    code, out, err = saulctl.run(["replay", log, "--link", "slcan:/dev/saul-given", opt, "400-401,300"])
    c.check(f"replay {opt} 400-401,300: accepted (the link is tried)", code == 1 and "saul-given" in err, err)
    code, out, err = saulctl.run(["replay", log, "--link", "slcan:/dev/saul-given", opt, "401-400"])
    c.check(f"replay {opt} 401-400: usage error before the link", code == 2 and "saul-given" not in err, err)
code, out, err = saulctl.run(["decode", "--id", "1024", log])
c.check("decode --id 1024 is 0x1024 (29-bit): none of the sample's frames, not 0x400", code == 0 and out == "", out)
for bad in ("xyz", "400:zz", "123456789"):
    code, out, err = saulctl.run(["decode", "--id", bad, log])
    c.check(f"decode --id {bad}: usage error (exit 2) that says ids are hex or names the id",
            code == 2 and bad.split(":")[-1] in err and "--help" in err, err)
code, out, err = saulctl.run(["sniff", "--id", "zz", "--link", "slcan:/dev/saul-given"])
c.check("sniff --id zz: usage error before any link is opened", code == 2 and "saul-given" not in err, err)
code, out, err = saulctl.run(["plot", log, "--id", "400", "--field", "pitch", "-o", "-", "--format", "csv"])
c.check("plot --id 400 is 0x400 (its pitch signal)", code == 0 and out.splitlines()[0] == "time_s,pitch", err)

# Durations: units everywhere, --for the same as --duration, a bad one a usage error before anything opens.
for verb in (["sniff"], ["record", "--format", "candump", "-o", "/dev/null"], ["monitor"], ["drive", "--speed", "0", "--yes"]):
    for opt in ("--duration", "--for"):
        for good in ("500ms", "10s", "2m", "1.5"):
            code, out, err = saulctl.run(verb + [opt, good, "--link", "slcan:/dev/saul-given"])
            if code != 1 or "saul-given" not in err:
                c.check(f"{verb[0]} {opt} {good}: accepted (the link is tried)", False, f"{code} {err}")
                break
        else:
            c.check(f"{verb[0]} {opt} 500ms / 10s / 2m / 1.5: accepted (the link is tried)", True)
        code, out, err = saulctl.run(verb + [opt, "10 s", "--link", "slcan:/dev/saul-given"])
        c.check(f"{verb[0]} {opt} '10 s': usage error naming the duration", code == 2 and "bad duration '10 s'" in err,
                err)
for verb in (["sim", "--speed", "0"], ["pride", "vcu", "/dev/saul-given"]):
    code, out, err = saulctl.run(verb + ["--for", "3x"])
    c.check(f"{' '.join(verb[:2])} --for 3x: usage error", code == 2 and "bad duration" in err, err)
code, out, err = saulctl.run(["stats", log, "--window", "1 s"])
c.check("other durations are checked too: stats --window '1 s' is a usage error", code == 2 and "bad duration" in err,
        err)

# docs/cli.md states the grammar and its examples run.
doc = open(os.path.join(root, "docs", "cli.md"), encoding="utf-8").read()
for must in ("--link", "SAUL_LINK", "--id 400", "0x400", "--duration", "--for", "--json", "Exit codes", "500ms"):
    c.check(f"docs/cli.md explains {must}", must in doc)

c.exit()
