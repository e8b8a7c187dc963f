#!/usr/bin/env python3
# Peak and time series of a command's VmRSS (issue 28): bench/rss_trace.py OUT.tsv CMD...
# writes "seconds<TAB>kB" every 5 ms and prints the peak and the wall time.
import subprocess, sys, time
# usage: rss_trace.py OUT.tsv cmd...  samples VmRSS every 5 ms
out = open(sys.argv[1], 'w')
t0 = time.monotonic()
p = subprocess.Popen(sys.argv[2:])
peak = 0
while p.poll() is None:
    try:
        for line in open(f'/proc/{p.pid}/status'):
            if line.startswith('VmRSS'):
                kb = int(line.split()[1]); peak = max(peak, kb)
                out.write(f'{time.monotonic()-t0:.3f}\t{kb}\n')
    except Exception: pass
    time.sleep(0.005)
print('peak_kb', peak, 'wall', round(time.monotonic()-t0, 3))
