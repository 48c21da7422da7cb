#!/usr/bin/env python3
"""The architecture's arrows, checked: every #include in the tree must point down (docs/architecture.md).

core includes nothing of host; each host folder includes only the folders its README allows; nothing in
libsaulproto or firmware/logic includes saulctl; firmware/logic includes no host. Prints each violation as
FILE:LINE: what, and exits 1 if there is any. Run: python3 tests/layers/check_layers.py [ROOT]
"""
import pathlib
import re
import sys

ARGS = [a for a in sys.argv[1:] if not a.startswith("--")]
ROOT = pathlib.Path(ARGS[0] if ARGS else pathlib.Path(__file__).resolve().parents[2])

# folder -> the saulproto/host folders it may include (core is always allowed, itself too)
HOST_ALLOWED = {
    "link": set(),
    "capture": set(),
    "report": {"capture"},
    "robot": {"link"},
    "replay": {"link", "capture", "report"},
    "flash": {"link"},
    "suite": {"link", "capture", "report", "tune"},
    "tune": {"capture", "report"},
}
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')


def layer_of(path: pathlib.Path):
    """('core', None) / ('host', folder) / ('logic', None) / (None, None) for a source file of the tree."""
    parts = path.relative_to(ROOT).parts
    if parts[:1] != ("libsaulproto",) and parts[:2] != ("firmware", "logic"):
        return None, None
    if parts[:2] == ("firmware", "logic"):
        return "logic", None
    if "core" in parts:
        return "core", None
    if "host" in parts:
        i = parts.index("host")
        folder = parts[i + 1] if len(parts) > i + 2 else None  # files directly in host/ (util.hpp, README)
        return "host", folder
    return None, None


def self_test() -> int:
    """A tree with one include against each kind of arrow must give exactly those violations (a checker that
    cannot fail is no check)."""
    import tempfile
    global ROOT
    with tempfile.TemporaryDirectory() as tmp:
        ROOT = pathlib.Path(tmp)
        bad = {
            "libsaulproto/src/core/a.cpp": '#include "saulproto/host/link/can_link.hpp"',
            "libsaulproto/src/host/capture/b.cpp": '#include "saulproto/host/link/serial_port.hpp"',
            "libsaulproto/include/saulproto/host/link/c.hpp": '#include "saulproto/host/report/format.hpp"',
            "firmware/logic/d.cpp": '#include "saulproto/host/capture/capture.hpp"',
            "libsaulproto/src/host/report/e.cpp": '#include "saulctl/commands.hpp"',
            "libsaulproto/src/host/replay/ok.cpp": '#include "saulproto/host/report/format.hpp"',
        }
        for name, text in bad.items():
            (ROOT / name).parent.mkdir(parents=True, exist_ok=True)
            (ROOT / name).write_text(text + "\n")
        problems = collect()
    if len(problems) != 5 or any("ok.cpp" in p for p in problems):
        print("self-test FAILED: expected 5 violations, got:", *problems, sep="\n  ")
        return 1
    print("layers self-test: 5 planted violations found, the allowed include passed")
    return 0


def main() -> int:
    if "--self-test" in sys.argv:
        return self_test()
    problems = collect()
    for p in problems:
        print(p)
    print(f"layers: {len(problems)} include(s) against the arrows")
    return 1 if problems else 0


def collect() -> list:
    problems = []
    files = [p for p in ROOT.rglob("*") if p.suffix in (".hpp", ".cpp", ".h", ".inc") and p.is_file()]
    for path in files:
        if any(part.startswith("build") for part in path.relative_to(ROOT).parts):
            continue
        layer, folder = layer_of(path)
        if layer is None:
            continue
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            target = m.group(1)
            where = f"{path.relative_to(ROOT)}:{number}"
            if "saulctl" in target or target.startswith("commands.hpp") or target.startswith("live.hpp"):
                problems.append(f"{where}: includes saulctl ({target}): arrows point down, saulctl is on top")
            if not target.startswith("saulproto/host/"):
                continue
            if layer in ("core", "logic"):
                problems.append(f"{where}: {layer} includes the host layer ({target})")
                continue
            parts = target.split("/")
            to_folder = parts[2] if len(parts) > 3 else None
            if folder is None or to_folder is None or to_folder == folder:
                continue
            if to_folder not in HOST_ALLOWED.get(folder, set()):
                allowed = ", ".join(sorted(HOST_ALLOWED.get(folder, set()))) or "none"
                problems.append(f"{where}: host/{folder} includes host/{to_folder} ({target}); "
                                f"host/{folder} may include core and: {allowed}")
    return problems


if __name__ == "__main__":
    sys.exit(main())
