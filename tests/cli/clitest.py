"""Running saulctl from a Python test in tests/cli, and tallying the checks.

Every check prints one line ("ok   name" or "FAIL name" with the detail indented below it); the script's exit
code is 1 when any check failed, which is what ctest looks at. A saulctl that does not end within its timeout is
killed and reported as hung (exit code None), so a test never waits forever.
"""
import os
import select
import subprocess
import sys
import time


class Saulctl:
    """The saulctl under test, started with stdin from /dev/null unless a test feeds it."""

    def __init__(self, exe):
        self.exe = exe

    def start(self, args, stdin=subprocess.DEVNULL, **kw):
        return subprocess.Popen([self.exe] + args, stdin=stdin, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)

    def run(self, args, timeout=60):
        """Starts saulctl and waits for it: (exit code, stdout, stderr)."""
        return finish(self.start(args), timeout)


def finish(proc, timeout=10, feed=None):
    """Waits for proc (writing feed to its stdin first): (exit code or None when it hung, stdout, stderr)."""
    try:
        out, err = proc.communicate(input=feed, timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        return None, out.decode(), err.decode() + "\n[killed: saulctl hung]"
    return proc.returncode, out.decode(), err.decode()


def wait_stderr_line(proc, needle, timeout=5.0):
    """Reads saulctl's stderr line by line until one contains needle; returns what was read."""
    seen = b""
    end = time.monotonic() + timeout
    fd = proc.stderr.fileno()
    while needle.encode() not in seen and time.monotonic() < end:
        r, _, _ = select.select([fd], [], [], max(0.0, end - time.monotonic()))
        if not r:
            break
        chunk = os.read(fd, 4096)
        if not chunk:
            break
        seen += chunk
    return seen.decode()


class Checks:
    def __init__(self):
        self.results = []

    def check(self, name, ok, detail=""):
        """Records one check and prints its line; detail is shown only when it failed."""
        self.results.append(bool(ok))
        more = "" if ok or not detail else "\n     " + str(detail).replace("\n", "\n     ")
        print(("ok   " if ok else "FAIL ") + name + more)

    def exit(self):
        failed = self.results.count(False)
        print(f"{len(self.results) - failed} passed, {failed} failed")
        sys.exit(1 if failed else 0)
