#!/usr/bin/env python3
# How many cores a command keeps busy over time (issue 28): bench/busy_trace.py CMD...
# Samples the summed run time of all the command's threads (/proc/PID/task/*/schedstat,
# nanoseconds) every 2 ms and prints the wall time, the CPU time seen and the cores
# busy in each 100 ms bucket. Threads that end between samples lose their last
# few ms, so the CPU time is a lower bound.
import os, subprocess, sys, time

BUCKET = 0.1


def runtime_ns(pid):
    total = 0
    try:
        tasks = os.listdir(f'/proc/{pid}/task')
    except OSError:
        return None
    for t in tasks:
        try:
            with open(f'/proc/{pid}/task/{t}/schedstat') as f:
                total += int(f.read().split()[0])
        except (OSError, ValueError, IndexError):
            pass
    return total


def main():
    if len(sys.argv) < 2:
        sys.exit('usage: busy_trace.py CMD...')
    t0 = time.perf_counter()
    p = subprocess.Popen(sys.argv[1:])
    samples, seen = [], 0
    while p.poll() is None:
        r = runtime_ns(p.pid)
        if r is not None:
            seen = max(seen, r)
            samples.append((time.perf_counter() - t0, seen))
        time.sleep(0.002)
    wall = time.perf_counter() - t0
    busy, prev_t, prev_r, k = [], 0.0, 0, 1
    for t, r in samples:
        if t >= k * BUCKET:
            busy.append((r - prev_r) / 1e9 / (t - prev_t))
            prev_t, prev_r, k = t, r, k + 1
    print(f'wall {wall:.3f} s, cpu >= {seen / 1e9:.3f} s, exit {p.returncode}')
    print('cores busy per 100 ms:', ' '.join(f'{u:.2f}' for u in busy))
    sys.exit(p.returncode)


if __name__ == '__main__':
    main()
