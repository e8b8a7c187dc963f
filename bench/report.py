"""Pareto plots (PNG) and docs/benchmarks.md from the CSVs of a run."""
import json
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import sources  # noqa: E402
from common import read_csv  # noqa: E402
from sweeps import EPS_DEFAULT  # noqa: E402
from timing import SCALING_REPS  # noqa: E402

BOUNDS = {"lut": ("max_abs_err", 1e-4), "irradiance": ("max_e", 5e-3), "specular": ("worst_max_e", 1e-2)}
# Issue 14's goals at the defaults, on any HDRI.
GOALS = {"irradiance max e": 5e-3, "specular max e": 1e-2, "solid-angle RMS": 5e-3, "energy bias": 2.5e-3}
SUN_SOURCES = ("sun_1k", "sun_2k", "sunset", "sunset_2k", "nishita_2k")
STYLE = {"iblbake": ("tab:blue", "o"), "fis": ("tab:orange", "s"), "sh9": ("tab:green", "D"), "seed": ("tab:red", "^")}
LABEL = {"iblbake": "iblbake (default method)", "fis": "iblbake --specular-method fis", "sh9": "SH9 only",
         "seed": "seed baseline"}


TEXT = {"method", "setting", "source", "stage"}


def num(rows):
    """CSV strings to floats, except the text columns."""
    return [{k: (v if k in TEXT else float(v)) for k, v in r.items()} for r in rows]


def lower_envelope(points):
    """(time, error) points sorted by time, keeping those better than every faster one."""
    env = []
    for t, e in sorted(points):
        if not env or e < env[-1][1]:
            env.append((t, e))
    return env


def time_at_error(points, target):
    """Time a method needs for error <= target, from its sweep, and how it was found."""
    env = lower_envelope(points)
    if env[0][1] <= target:
        return env[0][0], "at most"
    for (t0, e0), (t1, e1) in zip(env, env[1:]):
        if e1 <= target:
            f = math.log(target / e0) / math.log(e1 / e0)
            return math.exp(math.log(t0) + f * math.log(t1 / t0)), "interpolated"
    if len(env) >= 2:
        (t0, e0), (t1, e1) = env[-2], env[-1]
        slope = math.log(e1 / e0) / math.log(t1 / t0)
        if slope <= -0.25:  # shallower, and the extrapolation means nothing
            return t1 * (target / e1) ** (1 / slope), "extrapolated"
    return None, "not reached"


def pareto_optimal(row, rows, metric):
    """No other row is at least as fast and as accurate, and strictly better in one."""
    return not any(o is not row and o["seconds"] <= row["seconds"] and o[metric] <= row[metric]
                   and (o["seconds"] < row["seconds"] or o[metric] < row[metric]) for o in rows)


def fmt_t(t):
    return "-" if t is None else (f"{t:.3g} s" if t < 1000 else f"{t:.0f} s")


def plot(kind, rows, metric, ylabel, path, per_source=True):
    srcs = sorted({r.get("source", "") for r in rows}, key=list(dict.fromkeys(r.get("source", "") for r in rows)).index)
    n = len(srcs)
    cols = 4 if n > 4 else n
    nrow = math.ceil(n / cols)
    fig, axes = plt.subplots(nrow, cols, figsize=(4 * cols, 3.4 * nrow), squeeze=False)
    for ax, src in zip(axes.flat, srcs):
        sel = [r for r in rows if r.get("source", "") == src]
        for method in STYLE:
            pts = sorted((r["seconds"], r[metric]) for r in sel if r["method"] == method)
            if pts:
                c, m = STYLE[method]
                ax.plot(*zip(*pts), marker=m, color=c, label=LABEL[method], lw=1, ms=4)
        for r in sel:
            if r["default"]:
                ax.plot(r["seconds"], r[metric], "k*", ms=11, mfc="none" if r["method"] == "seed" else "k")
        ax.axhline(BOUNDS[kind][1], color="gray", ls="--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(src or kind, fontsize=9)
        ax.set_xlabel("wall time (s)", fontsize=8)
        ax.set_ylabel(ylabel, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", alpha=0.2)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=6, loc="best")
    fig.suptitle(f"{kind}: error against wall time (star: defaults; dashed: the bound)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


KEEP_BEGIN, KEEP_END = "<!-- kept by bench/report.py -->", "<!-- /kept -->"


def kept_sections(text):
    """The hand-written parts of an earlier page (between KEEP_BEGIN and
    KEEP_END, markers included), which a regenerated page carries over
    unchanged: measurements this run does not make (issue 14's side-by-side
    timings against main and cmft, say)."""
    out, start = [], 0
    while True:
        a = text.find(KEEP_BEGIN, start)
        if a < 0:
            return out
        b = text.find(KEEP_END, a)
        if b < 0:
            raise ValueError("docs/benchmarks.md: %s without %s" % (KEEP_BEGIN, KEEP_END))
        out.append(text[a:b + len(KEEP_END)] + "\n")
        start = b + len(KEEP_END)


def generate(results, doc_path, meta):
    kept = kept_sections(doc_path.read_text()) if doc_path.exists() else []
    lut = num(read_csv(results / "lut.csv"))
    irr = num(read_csv(results / "irradiance.csv"))
    spec = num(read_csv(results / "specular.csv"))
    levels = num(read_csv(results / "specular_levels.csv"))
    plot("lut", lut, "max_abs_err", "max |error| vs high-order LUT", results / "lut.png")
    plot("irradiance", irr, "max_e", "worst texel error e", results / "irradiance.png")
    plot("specular", spec, "worst_max_e", "worst texel error e, worst level", results / "specular.png")
    rel = results.relative_to(doc_path.parent)
    srcs = list(dict.fromkeys(r["source"] for r in spec))

    L = []
    w = L.append
    w("# Benchmarks: run time against error\n")
    w(f"Made by `{meta['command']}` on {meta['date']}, on this machine: {meta['machine']} "
      f"(shared with other work, so timings are noisy; medians are used). Commit `{meta['commit']}`. "
      f"The whole run took {meta['run_minutes']:.1f} min. Every number below comes from that run (the two timing tables at the end from a later `--redo-timing`, dated there), except the sections marked as kept, which a run carries over and which say how they were measured; "
      f"the raw data is in [`{rel}/`]({rel}/) (CSV) with the plots.\n")
    w("Errors are measured against the exhaustive reference of SPEC's integral over the **bilinear** source "
      "(`tests/native/reference.cpp`: the bilinear L integrated cell by cell between texel centres with "
      "Gauss-Legendre rules, cells split near the kernel's peak and across its horizon, double precision), "
      "cached in `bench/.cache`. The main metric is issue 14's, per texel on the channel sum: "
      "**e = |out - ref| / max(ref, 0.05 x the mean of L)** (every level of Pre has the mean of L), taken over every "
      "irradiance texel and, per specular level, over every texel of levels of face "
      f"<= {meta.get('small_face', 16)} and over {meta['per_level']} random texels plus every texel near a "
      "bright feature (within max(6 alpha, 3 texels), at most 30 degrees, of a texel over max(16 x the mean, "
      "5 % of the peak)) of larger ones. On the random texels also: the solid-angle RMS of out - ref relative to "
      "the reference's (saRMS), the energy bias (sum Omega out / sum Omega ref - 1) and the earlier relative "
      "RMSE (|out - ref| / ref, no floor: it blows up on black texels). Irradiance is 32 x 32 per face, specular "
      "256 x 256 with the full chain of 9 levels (r = m / 8), the LUT 512 x 512 (karis).\n")
    for section in kept:
        w(section)

    # ---------------------------------------------------------------- bounds
    w("## Do the defaults meet the bounds on every source?\n")
    lut_def = next(r for r in lut if r["method"] == "iblbake" and r["default"])
    w(f"BRDF LUT (one for all sources): max |error| {lut_def['max_abs_err']:.2e} against the high-order solution "
      f"(phi {meta['lut_high_order'][0]}, u {meta['lut_high_order'][1]}), {lut_def['max_abs_err_dense']:.2e} against "
      f"the independent dense estimator (midpoint rule, {meta['lut_dense'][1]} x {meta['lut_dense'][2]}, every "
      f"{meta['lut_dense'][0]}-th texel in each direction, whose own resolution error is about the "
      f"{meta['lut_high_vs_dense']:.2e} by which it differs from the high-order solution): "
      f"bound 1e-4, **{'met' if lut_def['max_abs_err'] <= 1e-4 and lut_def['max_abs_err_dense'] <= 1e-4 else 'NOT met'}**.\n")
    w("Goals (issue 14), at the defaults on every source: irradiance max e <= 5e-3; every specular level max e <= "
      "1e-2, saRMS <= 5e-3 and |energy bias| <= 2.5e-3; the LUT as above.\n")
    w("| source | irradiance max e | specular max e, worst level | specular saRMS, worst level | "
      "specular energy bias, largest | specular rel RMSE, worst level (earlier metric) | all goals |")
    w("|---|---|---|---|---|---|---|")
    failures = []
    for s in srcs:
        ri = next(r for r in irr if r["source"] == s and r["method"] == "iblbake" and r["default"])
        rs = next(r for r in spec if r["source"] == s and r["method"] == "iblbake" and r["default"])
        checks = {"irradiance max e": ri["max_e"], "specular max e": rs["worst_max_e"],
                  "solid-angle RMS": rs["worst_sa_rms"], "energy bias": abs(rs["worst_bias"])}
        missed = [k for k, v in checks.items() if v > GOALS[k]]
        failures += [f"{k} on {s}: {checks[k]:.2e} > {GOALS[k]:g}" for k in missed]
        w(f"| {sources.describe(s)} | {ri['max_e']:.2e} | {rs['worst_max_e']:.2e} (r = {rs['worst_max_e_roughness']:g}) "
          f"| {rs['worst_sa_rms']:.2e} | {rs['worst_bias']:+.2e} | {rs['worst_rmse']:.2e} "
          f"(r = {rs['worst_rmse_roughness']:g}) | {'yes' if not missed else '**no**'} |")
    w("")
    w("Every default meets every goal on every source." if not failures else
      "Goals missed: " + "; ".join(failures) + ".")
    w("")
    suns = [s for s in SUN_SOURCES if s in srcs]
    if suns:
        w("Per level on the sun sources (default bake): max e / saRMS / energy bias.\n")
        nlev = max(int(r["level"]) for r in levels) + 1
        w("| source | " + " | ".join(f"r = {m / (nlev - 1):g}" for m in range(1, nlev)) + " |")
        w("|---|" + "---|" * (nlev - 1))
        for s in suns:
            lv = sorted((r for r in levels if r["source"] == s and r["method"] == "iblbake"
                         and r["setting"] == f"eps {EPS_DEFAULT}"), key=lambda r: r["level"])
            w(f"| {sources.describe(s)} | " + " | ".join(f"{r['max_e']:.1e} / {r['sa_rms']:.1e} / {r['bias']:+.0e}"
                                                      for r in lv if r["level"] > 0) + " |")
        w("")

    # --------------------------------------------------------- vs the seeds
    w("## Defaults against the seed baselines\n")
    w("The seed baselines are the seeds' algorithms written in C++ as the seeds write them "
      "(`bench/baselines.cpp`), in the same run on the same machine, every radiance read the bilinear lookup of "
      "SPEC section 1, parallel over texels like iblbake:\n")
    w("- LUT: 1024 Hammersley samples of GGX importance sampling per texel (seed `000`, the learnopengl / UE4 shader);")
    w("- irradiance: the Riemann sum over theta and phi with step 0.025 (seed `003`, learnopengl's shader; "
      "its tangent frame normalised as in learnopengl);")
    w("- specular: learnopengl's prefilter, 1024 Hammersley GGX samples per texel, no filtered (mip-level) lookups; "
      "level 0 (r = 0, where every sample is n) is one lookup per texel, as in iblbake.\n")
    w("Baseline wall times are of the whole output (irradiance 6 x 32^2, specular chain 256, LUT 512^2) on "
      f"`{meta['seed_timing_source']}`, median of 3 runs (1 run for the slowest settings); their work does not depend "
      "on the pixels, so each source's baseline error comes from the same per-texel code run at that source's "
      "reference texels. iblbake times are medians of 3 in-process bakes of just that output (`iblbake_core.bake`, "
      "which includes cleaning the source and the SH projection). "
      "\"Our time at the seed's error\" reads our sweep (its lower envelope, log-log interpolation); "
      "&le; means even our fastest setting measured is more accurate than the seed as written, so the speed-up "
      "is at least the figure shown. \"Seed time at our error\" reads the seed's sweep the same way; "
      "the seeds never reach our errors within their sweeps, so it is extrapolated along the last segment of "
      "their sweep (marked *extrap.*): an estimate of the order of magnitude, not a measurement.\n")
    w("| output | source | iblbake default: time, error | seed as written: time, error | our time at the seed's error "
      "| speed-up at the seed's error | seed time at our error | speed-up at our error |")
    w("|---|---|---|---|---|---|---|---|")

    def compare(kind, rows, metric, src, fmt):
        sel = [r for r in rows if r.get("source", src) == src]
        ours = next(r for r in sel if r["method"] == "iblbake" and r["default"])
        seed = next(r for r in sel if r["method"] == "seed" and r["default"])
        seed_pts = [(r["seconds"], r[metric]) for r in sel if r["method"] == "seed"]
        our_pts = [(r["seconds"], r[metric]) for r in sel if r["method"] == "iblbake"]
        t_seed, how = time_at_error(seed_pts, ours[metric])
        t_ours, how_o = time_at_error(our_pts, seed[metric])
        mark = {"extrapolated": " *extrap.*", "interpolated": "", "at most": "", "not reached": ""}
        bound = {"at most": "&le; ", "interpolated": "", "extrapolated": "", "not reached": ""}
        if t_seed is None:
            seed_at_ours, speed_ours = "not reached (its error falls slower than time^-0.25, or not at all)", "-"
        else:
            seed_at_ours = f"{fmt_t(t_seed)}{mark[how]}"
            speed_ours = f"{t_seed / ours['seconds']:.3g}x{mark[how]}"
        speed_seed = "-" if t_ours is None else \
            f"{'&ge; ' if how_o == 'at most' else ''}{seed['seconds'] / t_ours:.3g}x{mark[how_o]}"
        w(f"| {kind} | {src or 'all'} | {fmt_t(ours['seconds'])}, {ours[metric]:{fmt}} | {fmt_t(seed['seconds'])}, "
          f"{seed[metric]:{fmt}} | {bound[how_o]}{fmt_t(t_ours)}{mark[how_o]} | {speed_seed} | {seed_at_ours} | "
          f"{speed_ours} |")

    compare("LUT (max abs)", lut, "max_abs_err", None, ".2e")
    for s in srcs:
        compare("irradiance (max e)", irr, "max_e", s, ".2e")
    for s in srcs:
        compare("specular (worst texel e, worst level)", spec, "worst_max_e", s, ".2e")
    w("")

    # --------------------------------------------------------------- Pareto
    w("## Pareto plots\n")
    w("Each panel: one source; x wall time, y error, both log; every point one setting of a sweep; "
      "the black star marks the default (open star: the seed as written). The sweeps: LUT Gauss-Legendre orders "
      "(phi points, u points), every texel integrated or k nodes per row with a cubic spline between, against the "
      "seed's sample count; irradiance lat-long bins (8 .. 512) and SH9 alone "
      "(evaluated per SPEC section 5) against the seed's step; specular `eps` of the hierarchical sum and "
      "`rings` / `lod_bias` of filtered importance sampling (`--specular-method fis`) against the seed's sample count.\n")
    for kind in ("lut", "irradiance", "specular"):
        w(f"![{kind}]({rel}/{kind}.png)\n")
    w("Is each default on the Pareto front of all settings measured (no setting of any method both faster and more "
      "accurate)?\n")
    w("| output | sources where the default is Pareto-optimal | where it is not (dominated by) |")
    w("|---|---|---|")
    for kind, rows, metric in (("LUT", lut, "max_abs_err"), ("irradiance", irr, "max_e"),
                               ("specular", spec, "worst_max_e")):
        on, off = [], []
        for s in (srcs if kind != "LUT" else [None]):
            sel = [r for r in rows if r.get("source", s) == s]
            d = next(r for r in sel if r["method"] == "iblbake" and r["default"])
            if pareto_optimal(d, sel, metric):
                on.append(s or "all")
            else:
                by = [f"{o['method']} {o['setting']}" for o in sel if o is not d and o["seconds"] <= d["seconds"]
                      and o[metric] <= d[metric]]
                off.append(f"{s or 'all'} ({', '.join(by)})")
        w(f"| {kind} | {', '.join(on) or '-'} | {'; '.join(off) or '-'} |")
    w("")

    # ---------------------------------------------------------------- sweeps
    w("### The sweeps in numbers\n")
    w("LUT (512 x 512, karis):\n")
    w("| method | setting | time | max abs err (high order) | max abs err (dense estimator) |")
    w("|---|---|---|---|---|")
    for r in lut:
        w(f"| {r['method']} | {r['setting']}{' (default)' if r['default'] else ''} | {fmt_t(r['seconds'])} | "
          f"{r['max_abs_err']:.2e} | {r['max_abs_err_dense']:.2e} |")
    w("")
    for kind, rows, cols in (("Irradiance", irr, ("max_e",)),
                             ("Specular", spec, ("worst_max_e",)), ("Specular", spec, ("worst_rmse",))):
        settings = list(dict.fromkeys((r["method"], r["setting"]) for r in rows))
        what = {"max_e": "worst texel error e", "worst_max_e": "worst texel error e over every level (time against "
                "worst texel error)", "worst_rmse": "relative RMSE of the worst level (the earlier metric)"}[cols[0]]
        w(f"{kind}: time (median over sources) and {what} per source:\n")
        w("| method | setting | time | " + " | ".join(srcs) + " |")
        w("|---|---|---|" + "---|" * len(srcs))
        for m, st in settings:
            sel = {r["source"]: r for r in rows if r["method"] == m and r["setting"] == st}
            ts = sorted(r["seconds"] for r in sel.values())
            w(f"| {m} | {st} | {fmt_t(ts[len(ts) // 2])} | " +
              " | ".join(f"{sel[s][cols[0]]:.1e}" if s in sel else "-" for s in srcs) + " |")
        w("")
    w("Specular error per mip of the default bake (max e / relative RMSE):\n")
    w("| source | " + " | ".join(f"r = {m / 8:g}" for m in range(9)) + " |")
    w("|---|" + "---|" * 9)
    for s in srcs:
        lv = sorted((r for r in levels if r["source"] == s and r["method"] == "iblbake"
                     and r["setting"] == f"eps {EPS_DEFAULT}"), key=lambda r: r["level"])
        w(f"| {s} | " + " | ".join(f"{r['max_e']:.1e} / {r['rmse']:.1e}" for r in lv) + " |")
    w("")

    # ---------------------------------------------------------------- timing
    stages = num(read_csv(results / "default_bake.csv"))
    w("## Where a default bake spends its time\n")
    w(f"`iblbake bake SRC -o OUT` on sunset.exr resized to 2048 x 1024 (irradiance 32, specular 256 with 9 levels, "
      f"LUT 512 read from the cache, EXR), median of {meta['timing_reps']} runs after one warm-up, each its own process; "
      f"peak RSS {meta['default_rss_mb']:.0f} MB (`/usr/bin/time`). Measured {meta['timing_date']} at commit "
      f"`{meta['timing_commit']}`. Stages as the manifest's `timings` reports them:\n")
    if "calibration_seconds" in meta:
        speed = meta["calibration_quiet_seconds"] / meta["calibration_seconds"]
        w(f"The host is shared and its speed drifts (up to 1.7x within a day). A fixed calibration workload (the "
          f"irradiance seed at step 0.05 on forest.exr) timed just before took {meta['calibration_seconds']:.2f} s "
          f"against {meta['calibration_quiet_seconds']:.2f} s in a quiet run: the host ran at {speed:.2f} of its "
          f"quiet speed, so the total below corresponds to about {speed * wall_total(stages):.2f} s on a quiet host "
          f"(an estimate; the measured figure is the one in the table).\n")
    w("| stage | seconds |")
    w("|---|---|")
    for r in stages:
        w(f"| {r['stage']} | {r['seconds']:.3f} |")
    w("")
    if (results / "scaling.csv").exists():
        w(f"Scaling (sunset.exr resized; default options except the face size; median of {SCALING_REPS} runs, "
          "1 for 8192 x 4096):\n")
        w("The memory budget is the issue's: 3x the source's RGB float size plus the outputs held in memory "
          "(irradiance, the specular chain, the LUT). The last column compares each row with the one before: the "
          "time ratio over the source pixel ratio (same face), or over the output texel ratio (same source); under "
          "1 means the cost grew slower than the count it should follow.\n")
        w("| source | specular face | wall time | peak RSS | budget | within | time ratio / pixel ratio |")
        w("|---|---|---|---|---|---|---|")
        prev = None
        for r in num(read_csv(results / "scaling.csv")):
            sw, sh = (int(v) for v in r["source"].split("x"))
            face = int(r["face_size"])
            chain, n = 0, face
            while n >= 1:
                chain += 6 * n * n * 3 * 4
                n //= 2
            budget = (3 * sw * sh * 3 * 4 + chain + 6 * 32 * 32 * 3 * 4 + 512 * 512 * 3 * 4) / 2**20
            ratio = "-"
            if prev and prev[1] == face and prev[0] != sw * sh:
                ratio = f"{(r['seconds'] / prev[2]) / (sw * sh / prev[0]):.2f} (pixels)"
            elif prev and prev[0] == sw * sh and prev[1] != face:
                ratio = f"{(r['seconds'] / prev[2]) / (face / prev[1]) ** 2:.2f} (texels)"
            prev = (sw * sh, face, r["seconds"])
            within = "yes" if r["peak_rss_mb"] <= budget else "no"
            w(f"| {r['source']} | {face} | {r['seconds']:.2f} s | {r['peak_rss_mb']:.0f} MB | {budget:.0f} MB | "
              f"{within} | {ratio} |")
        w("")

    # ------------------------------------------------- hand-written history
    history = doc_path.parent / "bench" / "speed_history.md"
    if history.exists():
        w(history.read_text().rstrip() + "\n")

    # -------------------------------------------------------------- commands
    w("## Reproduce\n")
    w("```sh")
    w("bash bench/run.sh            # builds, then the whole benchmark (this page, docs/bench/*)")
    w("bash bench/run.sh --quick    # 4 sources, short sweeps, into bench/.cache/quick/ (a few minutes)")
    w("bash bench/run.sh --timing-only --reps 9   # just the default bake's per-stage timing, median of 9 (printed)")
    w("bash bench/run.sh --redo-timing  # rerun the timing and scaling tables of this page only")
    w("```\n")
    w("Sources are made in `bench/.cache/sources` (`iblbake_bench sun`, `oiiotool --pattern checker`, "
      "`oiiotool --resize:filter=triangle`); references are cached in `bench/.cache/reference` by source sha256 "
      "and settings, so a rerun only re-times.\n")
    doc_path.write_text("\n".join(L))
    return failures


def wall_total(stages):
    return next(r["seconds"] for r in stages if r["stage"] == "total (wall)")


def load_meta(results):
    return json.loads((results / "meta.json").read_text())
