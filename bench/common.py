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


def texel_solid_angles(idx, face):
    """Exact solid angles of cube texels (f, j, i) of an N x N face (math/cube.h)."""
    idx = np.asarray(idx)
    i, j = idx[:, 2].astype(np.float64), idx[:, 1].astype(np.float64)
    a0, a1 = 2 * i / face - 1, 2 * (i + 1) / face - 1
    b0, b1 = 2 * j / face - 1, 2 * (j + 1) / face - 1
    f = lambda a, b: np.arctan2(a * b, np.sqrt(a * a + b * b + 1))  # noqa: E731
    return np.abs(f(a1, b1) - f(a0, b1) - f(a1, b0) + f(a0, b0))


def level_metrics(values, reference, idx, random, face, mean):
    """Issue 14's metric on channel sums: e = |out - ref| / max(ref, 0.05 mean) per
    texel, its max and 99th percentile over every measured texel; over the uniform
    sample (`random`), the solid-angle RMS of out - ref relative to the reference's,
    the energy bias (sum Omega out / sum Omega ref - 1), and the old relative RMSE
    and p99 (|out - ref| / ref)."""
    vs = np.asarray(values, np.float64).sum(axis=-1)
    rs = np.asarray(reference, np.float64).sum(axis=-1)
    e = np.abs(vs - rs) / np.maximum(rs, 0.05 * mean)
    rnd = np.asarray(random, bool)
    om = texel_solid_angles(np.asarray(idx)[rnd], face)
    d, r = vs[rnd] - rs[rnd], rs[rnd]
    rel = np.sort(np.abs(d) / np.maximum(r, 1e-30))
    es = np.sort(e)
    return {"max_e": float(es[-1]), "p99_e": float(es[min(len(es) - 1, int(0.99 * len(es)))]),
            "sa_rms": float(np.sqrt(np.sum(om * d * d) / max(np.sum(om * r * r), 1e-300))),
            "bias": float(np.sum(om * vs[rnd]) / max(np.sum(om * r), 1e-300) - 1),
            "rmse": float(np.sqrt(np.mean(rel * rel))), "p99": float(rel[min(len(rel) - 1, int(0.99 * len(rel)))])}


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
