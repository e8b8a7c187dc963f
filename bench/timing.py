"""Wall time, per-stage time and peak memory of default bakes through the CLI
(`iblbake bake SRC -o OUT`: irradiance 32, specular 256 full chain, LUT 512
from the cache, EXR), each in its own process."""
import json
import shutil
import statistics
import subprocess
import time

import sources
from common import CACHE, CLI, log, run_tool


def bake_once(src, out, *extra):
    """One CLI bake: (wall seconds, peak RSS in MB, the manifest's stage timings)."""
    lut_cache = CACHE / "lut-cache"
    rss_file = CACHE / "peak_rss_kb"
    # Through /usr/bin/time: a child forked straight from this (large) Python
    # process would inherit its peak RSS across exec.
    cmd = ["/usr/bin/time", "-f", "%M", "-o", str(rss_file),
           str(CLI), "bake", str(src), "-o", str(out), "--cache-dir", str(lut_cache), "-q", *map(str, extra)]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t0
    with open(out / "manifest.json") as f:
        stages = json.load(f)["timings"]
    return wall, int(rss_file.read_text().split()[-1]) / 1024.0, stages


def timed_bake(src, reps, *extra):
    """Median wall time over reps runs (after one warm-up that fills the LUT cache), the
    median of each stage, and the largest peak RSS."""
    out = CACHE / "bake-out"
    bake_once(src, out, *extra)
    runs = [bake_once(src, out, *extra) for _ in range(reps)]
    shutil.rmtree(out)
    stages = {k: statistics.median(r[2][k] for r in runs) for k in runs[0][2]}
    return statistics.median(r[0] for r in runs), max(r[1] for r in runs), stages


# The calibration workload: the irradiance seed at step 0.05 on forest.exr
# (a fixed amount of arithmetic, independent of iblbake's code), and its
# median in the quiet run at commit 7597f61. The host is shared: its speed
# drifts by up to 1.7x within a day, so the doc reports how fast it ran.
CALIBRATION_QUIET_SECONDS = 1.374


def calibration(reps=3):
    """Median seconds of the calibration workload now, and the host's speed against the quiet run."""
    out = CACHE / "calibration.f32"
    secs = run_tool("seed-irradiance", sources.STUDIOLIGHTS / "forest.exr", 32, 0.05, reps, out)
    out.unlink(missing_ok=True)
    log(f"calibration workload: {secs:.3f} s (quiet run {CALIBRATION_QUIET_SECONDS} s)")
    return secs


def default_bake(reps):
    """Per-stage timing of the default bake of a 2048 x 1024 source (sunset, LUT cached)."""
    src = sources.resized("sunset", 2048, 1024)
    wall, rss, stages = timed_bake(src, reps)
    log(f"default bake 2048x1024: {wall:.3f} s (median of {reps}), peak RSS {rss:.0f} MB")
    rows = [{"stage": k, "seconds": v} for k, v in stages.items()]
    rows.append({"stage": "read, hash, start-up (wall minus stages)", "seconds": wall - sum(stages.values())})
    rows.append({"stage": "total (wall)", "seconds": wall})
    return rows, rss


SCALING_REPS = 3  # runs per scaling row (median); the 8K row runs once


def scaling(reps, quick):
    """Wall time and peak RSS against source size (face 256) and face size (2048 x 1024 source)."""
    rows = []
    widths = [512, 2048, 8192] if quick else [512, 1024, 2048, 4096, 8192]
    for w in widths:
        src = sources.resized("sunset", w, w // 2)
        wall, rss, _ = timed_bake(src, reps if w < 8192 else 1)
        rows.append({"source": f"{w}x{w // 2}", "face_size": 256, "seconds": wall, "peak_rss_mb": rss})
        log(f"scaling {w}x{w // 2} face 256: {wall:.2f} s, {rss:.0f} MB")
    src = sources.resized("sunset", 2048, 1024)
    for face in ([64, 1024] if quick else [64, 128, 512, 1024]):
        wall, rss, _ = timed_bake(src, reps, "--face-size", face)
        rows.append({"source": "2048x1024", "face_size": face, "seconds": wall, "peak_rss_mb": rss})
        log(f"scaling 2048x1024 face {face}: {wall:.2f} s, {rss:.0f} MB")
    return sorted(rows, key=lambda r: (r["face_size"] != 256, r["face_size"], int(r["source"].split("x")[0])))
