"""Paths, the native tools, timing and error statistics shared by the benchmark."""
import csv
import hashlib
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
BUILD = Path(os.environ.get("IBLBAKE_BUILD_DIR", ROOT / "build"))
CACHE = ROOT / "bench" / ".cache"
RESULTS = ROOT / "docs" / "bench"
BENCH_TOOL = BUILD / "bench" / "iblbake_bench"
CLI = BUILD / "native" / "iblbake"
sys.path.insert(0, str(BUILD / "native"))
import iblbake_core  # noqa: E402  (the module built into BUILD/native)


def log(msg):
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def run_tool(*args):
    """Runs iblbake_bench; returns the seconds it printed (or None)."""
    out = subprocess.run([str(BENCH_TOOL), *map(str, args)], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        if line.startswith("seconds "):
            return float(line.split()[1])
    return None


def median_time(fn, reps):
    """Median wall time of reps calls of fn, and fn's last result."""
    times, result = [], None
    for _ in range(max(1, reps)):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def rel_errors(values, reference):
    """Relative error of the channel sum per texel (as tests/native/measure_accuracy.cpp)."""
    vs = np.asarray(values, np.float64).sum(axis=-1)
    rs = np.asarray(reference, np.float64).sum(axis=-1)
    return np.abs(vs - rs) / np.maximum(rs, 1e-30)


def error_stats(e):
    """max, mean, RMS and 99th percentile (the value at index floor(0.99 n)) of relative errors."""
    e = np.sort(np.asarray(e, np.float64))
    return {"max": float(e[-1]), "mean": float(e.mean()), "rmse": float(np.sqrt(np.mean(e * e))),
            "p99": float(e[min(len(e) - 1, int(0.99 * len(e)))])}


def write_csv(path, rows):
    path.parent.mkdir(parents=True, exist_ok=True)
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))
