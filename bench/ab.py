#!/usr/bin/python3
"""Two saulctl binaries (a base and a change) on the same command, run alternately so that both see the same load:
the way issue 34's "keep a trick only where removing it costs more than 10 %" is measured (bench/README.md).
Prints the minimum wall time, the minimum and the median CPU time (user + sys of the child, from wait4) of each,
and the change's CPU median as a share of the base's. Output goes to /dev/null; a non-zero exit is reported.

    bench/ab.py BASE_SAULCTL NEW_SAULCTL [--runs N] -- ARGS...
    bench/ab.py /tmp/base/saulctl build-rel/saulctl/saulctl --runs 15 -- stats /tmp/rand.log
"""
import argparse
import os
import statistics
import sys
import time


def run(cmd):
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.dup2(null, 2)
        os.execv(cmd[0], cmd)
    _, status, usage = os.wait4(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"ab: {' '.join(cmd)} exited with {os.waitstatus_to_exitcode(status)}")
    return time.perf_counter() - t0, usage.ru_utime + usage.ru_stime


def main():
    if "--" not in sys.argv:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    split = sys.argv.index("--")
    parser = argparse.ArgumentParser(usage=__doc__)
    parser.add_argument("base")
    parser.add_argument("new")
    parser.add_argument("--runs", type=int, default=9)
    opt = parser.parse_args(sys.argv[1:split])
    args = sys.argv[split + 1:]
    times = {opt.base: [], opt.new: []}
    for _ in range(opt.runs):
        for binary in (opt.base, opt.new):
            times[binary].append(run([binary] + args))
    rows = {}
    for label, binary in (("base", opt.base), ("new", opt.new)):
        wall = min(t[0] for t in times[binary]) * 1e3
        cpu = [t[1] * 1e3 for t in times[binary]]
        rows[label] = statistics.median(cpu)
        print(f"{label:4} wall min {wall:8.1f} ms   CPU min {min(cpu):8.1f} ms   CPU median {rows[label]:8.1f} ms")
    print(f"new / base, CPU median: {rows['new'] / rows['base']:.3f} ({opt.runs} runs each, "
          f"load {os.getloadavg()[0]:.1f}): {' '.join(args)}")


if __name__ == "__main__":
    main()
