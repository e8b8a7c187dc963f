#!/usr/bin/env python3
"""Times shell commands side by side, alternating, in one run: the way to
compare two builds (or iblbake and cmft) on a shared host whose speed drifts.

    bench/alternate.py [--reps N] [--warmup W] [--pause S] NAME=COMMAND NAME=COMMAND ...

Each round runs every command once, in the given order (rotated by one each
round, so no command always follows the same one), timed for wall time,
CPU time (user + system, from wait4 in microseconds) and peak RSS. Prints the load average before and after, and per
command the median wall time, its spread (min..max), the median CPU time,
the median peak RSS and the ratios of the medians to the first command's. Commands run through
`sh -c`; their output is discarded; a failure stops the run. --pause S sleeps S
seconds before each command: on this VM a short command run straight after
cmft's three seconds of eight threads on two cores was measured up to 20 %
slower than after a pause, which charges one program for another's load."""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time


def run(cmd):
    """Wall time, peak RSS (MB) and CPU time (user + system) of `sh -c cmd`,
    from the kernel's accounting of the child (wait4: microseconds, where
    /usr/bin/time prints hundredths, too coarse for a 0.3 s bake)."""
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        p = subprocess.Popen(["sh", "-c", cmd], stdout=subprocess.DEVNULL, stderr=err)
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        if p.returncode != 0:
            err.seek(0)
            sys.exit(f"command failed ({p.returncode}): {cmd}\n{err.read().decode(errors='replace')[-2000:]}")
    return wall, ru.ru_maxrss / 1024.0, ru.ru_utime + ru.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--warmup", type=int, default=1, help="untimed rounds first (caches, page cache)")
    ap.add_argument("--pause", type=float, default=0.0, help="seconds of sleep before each command")
    ap.add_argument("commands", nargs="+", metavar="NAME=COMMAND")
    a = ap.parse_args()
    cmds = []
    for c in a.commands:
        name, sep, cmd = c.partition("=")
        if not sep:
            sys.exit(f"expected NAME=COMMAND, got {c!r}")
        cmds.append((name, cmd))
    load0 = os.getloadavg()
    for _ in range(a.warmup):
        for _, cmd in cmds:
            run(cmd)
    walls = {n: [] for n, _ in cmds}
    rss = {n: [] for n, _ in cmds}
    cpu = {n: [] for n, _ in cmds}
    for k in range(a.reps):
        for j in range(len(cmds)):
            name, cmd = cmds[(j + k) % len(cmds)]
            if a.pause > 0:
                time.sleep(a.pause)
            w, m, c = run(cmd)
            walls[name].append(w)
            rss[name].append(m)
            cpu[name].append(c)
    load1 = os.getloadavg()
    print(f"load average before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, "
          f"after {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}; {a.reps} alternating rounds, {os.cpu_count()} cores"
          + (f", {a.pause:g} s pause before each command" if a.pause > 0 else ""))
    first = statistics.median(walls[cmds[0][0]])
    first_cpu = statistics.median(cpu[cmds[0][0]])
    print(f"{'command':<14} {'wall s':>8} {'min..max s':>15} {'CPU s':>7} {'peak RSS MB':>12} "
          f"{'wall / 1st':>10} {'CPU / 1st':>9}")
    for name, _ in cmds:
        med, mc = statistics.median(walls[name]), statistics.median(cpu[name])
        print(f"{name:<14} {med:8.3f} {min(walls[name]):7.3f}..{max(walls[name]):<7.3f} {mc:7.3f} "
              f"{statistics.median(rss[name]):12.1f} {med / first:10.2f} {mc / first_cpu:9.2f}")
    for name, cmd in cmds:
        print(f"  {name}: {cmd}")


if __name__ == "__main__":
    main()
