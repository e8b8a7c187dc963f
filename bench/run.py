"""The benchmark: run time against error for every output, against the seed
baselines, plus the default bake's timing. One command: bash bench/run.sh
(options: --quick, --timing-only, --reps N, --no-scaling, --report-only)."""
import argparse
import datetime
import json
import os
import platform
import subprocess
import time

import reference
import report
import sources
import sweeps
import timing
from common import CACHE, RESULTS, ROOT, log, write_csv


def machine():
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    mem = int(next(l.split()[1] for l in open("/proc/meminfo") if l.startswith("MemTotal"))) / 2**20
    return f"{cpu}, {os.cpu_count()} cores, {mem:.0f} GB RAM, {platform.system()} {platform.release()}"


def timing_only(reps):
    cal = timing.calibration()
    rows, rss = timing.default_bake(reps)
    print(f"calibration workload {cal:.3f} s (quiet: {timing.CALIBRATION_QUIET_SECONDS} s): the host ran at "
          f"{timing.CALIBRATION_QUIET_SECONDS / cal:.2f} of its quiet speed")
    for r in rows:
        print(f"{r['stage']:45s} {r['seconds']:8.3f} s")
    print(f"peak RSS {rss:.0f} MB")


def bake_timing(results, args):
    """The default bake's per-stage timing and the scaling table, into CSVs; returns their metadata."""
    cal = timing.calibration()
    stage_rows, rss = timing.default_bake(args.reps)
    write_csv(results / "default_bake.csv", stage_rows)
    if not args.no_scaling:
        write_csv(results / "scaling.csv", timing.scaling(timing.SCALING_REPS, args.quick))
    return {"timing_reps": args.reps, "default_rss_mb": rss, "timing_date": datetime.date.today().isoformat(),
            "calibration_seconds": cal, "calibration_quiet_seconds": timing.CALIBRATION_QUIET_SECONDS,
            "timing_commit": subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                                            capture_output=True, text=True).stdout.strip()}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="4 sources, short sweeps, results in bench/.cache/quick")
    ap.add_argument("--timing-only", action="store_true", help="only the default bake's per-stage timing")
    ap.add_argument("--reps", type=int, default=5, help="runs per default-bake timing (median)")
    ap.add_argument("--no-scaling", action="store_true", help="skip the scaling table")
    ap.add_argument("--report-only", action="store_true", help="redo plots and markdown from the last CSVs")
    ap.add_argument("--redo-timing", action="store_true",
                    help="rerun only the default-bake timing and the scaling table, then the report")
    ap.add_argument("--per-level", type=int, default=300, help="reference texels per output level")
    args = ap.parse_args()
    if args.timing_only:
        return timing_only(args.reps)
    results = CACHE / "quick" if args.quick else RESULTS
    doc = results / "benchmarks.md" if args.quick else ROOT / "docs" / "benchmarks.md"
    if args.report_only:
        return report.generate(results, doc, report.load_meta(results))
    if args.redo_timing:
        meta = report.load_meta(results)
        meta.update(bake_timing(results, args))
        (results / "meta.json").write_text(json.dumps(meta, indent=1))
        return report.generate(results, doc, meta)

    t_start = time.time()
    srcs = sources.all_sources(args.quick)
    log(f"sources: {', '.join(srcs)}")
    lut_rows = sweeps.lut_sweep(args.quick)
    write_csv(results / "lut.csv", lut_rows)
    high, dense = sweeps.lut_references()
    seed_src = "forest"
    seed_times = sweeps.seed_timings(srcs[seed_src], args.quick)

    irr_rows, spec_rows, level_rows = [], [], []
    for name, path in srcs.items():
        ref = reference.load(path, args.per_level)
        img = sweeps.source_image(path)
        irr_rows += sweeps.irradiance_sweep(name, path, img, ref, seed_times, args.quick)
        s, lv = sweeps.specular_sweep(name, path, img, ref, seed_times, args.quick)
        spec_rows += s
        level_rows += lv
        write_csv(results / "irradiance.csv", irr_rows)
        write_csv(results / "specular.csv", spec_rows)
        write_csv(results / "specular_levels.csv", level_rows)

    timing_meta = bake_timing(results, args)
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    meta = {"command": "bash bench/run.sh" + (" --quick" if args.quick else ""),
            "date": datetime.date.today().isoformat(), "machine": machine(), "commit": commit,
            "run_minutes": (time.time() - t_start) / 60, "per_level": args.per_level,
            "small_face": reference.SMALL_FACE,
            "lut_high_order": sweeps.LUT_HIGH_ORDER, "lut_dense": sweeps.LUT_DENSE,
            "lut_high_vs_dense": sweeps.lut_errors(high, high, dense)["max_abs_err_dense"],
            "seed_timing_source": f"{seed_src}.exr", **timing_meta}
    (results / "meta.json").write_text(json.dumps(meta, indent=1))
    failures = report.generate(results, doc, meta)
    log(f"done in {meta['run_minutes']:.1f} min: {doc}")
    for f in failures:
        log(f"BOUND MISSED: {f}")


if __name__ == "__main__":
    main()
