"""Quality sweeps: (wall time, error) for iblbake's knobs and for the seed baselines.

Our bakes run in-process through iblbake_core (median of `reps` runs); the
seed baselines run in iblbake_bench (bench/baselines.cpp). Both use every core."""

import numpy as np

import reference
from common import CACHE, iblbake_core, level_metrics, log, median_time, run_tool

LUT_SIZE = 512
LUT_HIGH_ORDER = (16, 48)
LUT_DENSE = (32, 4000, 2000)  # stride, n_theta, n_phi of the independent estimator
LUT_DEFAULT = (4, 6, 64)  # phi points, u points, integrated nodes per row (0: every texel)
EPS_DEFAULT = 0.4  # the hierarchical specular's default (ibl/specular.h)
EPS_SWEEP = [0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.5, 2.0]


def _f32(path, shape):
    return np.fromfile(path, dtype=np.float32).reshape(shape)


def _cached_npy(name, make):
    path = CACHE / name
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        np.save(path, make())
    return np.load(path)


# --------------------------------------------------------------------- LUT
def lut_references():
    """The high-order LUT and the independent dense estimator on every 32nd texel."""
    hi_p, hi_u = LUT_HIGH_ORDER
    high = _cached_npy(f"lut_karis_{LUT_SIZE}_{hi_p}_{hi_u}.npy",
                       lambda: (log("high-order LUT (once)"),
                                iblbake_core.brdf_lut(LUT_SIZE, "karis", hi_p, hi_u, row_nodes=0))[1])
    stride, nt, nph = LUT_DENSE

    def dense():
        log("dense LUT estimator (once)")
        tmp = CACHE / "dense.csv"
        run_tool("dense-lut", LUT_SIZE, stride, nt, nph, tmp)
        d = np.loadtxt(tmp, delimiter=",", skiprows=1)
        tmp.unlink()
        return d
    return high, _cached_npy(f"lut_dense_{LUT_SIZE}_{stride}_{nt}_{nph}.npy", dense)


def lut_errors(lut, high, dense):
    i, j = dense[:, 0].astype(int), dense[:, 1].astype(int)
    return {"max_abs_err": float(np.abs(lut[..., :2] - high[..., :2]).max()),
            "max_abs_err_dense": float(np.abs(lut[j, i, :2] - dense[:, 2:4]).max())}


def lut_sweep(quick):
    high, dense = lut_references()
    log(f"high-order LUT vs dense estimator: {lut_errors(high, high, dense)['max_abs_err_dense']:.2e}")
    rows = []
    direct = [(1, 2, 0), (2, 3, 0), (3, 4, 0), (4, 6, 0)] + ([] if quick else [(6, 8, 0), (8, 12, 0)])
    splined = [(1, 2, 8), (2, 3, 8), (2, 3, 12), (2, 3, 16), (3, 5, 24), (4, 6, 32), (4, 6, 48), (4, 6, 64),
               (6, 8, 64)]
    for p, u, k in direct + splined:
        secs, lut = median_time(lambda: iblbake_core.brdf_lut(LUT_SIZE, "karis", p, u, row_nodes=k), 3)
        setting = f"phi {p}, u {u}" + (f", {k} nodes/row" if k else ", every texel")
        rows.append({"method": "iblbake", "setting": setting, "seconds": secs,
                     "default": int((p, u, k) == LUT_DEFAULT), **lut_errors(lut, high, dense)})
        log(f"LUT iblbake {setting}: {secs:.3f} s, {rows[-1]['max_abs_err']:.2e}")
    for n in [64, 256, 1024] + ([] if quick else [4096]):
        out = CACHE / "seed_lut.f32"
        secs = run_tool("seed-lut", LUT_SIZE, n, 3 if n <= 1024 else 1, out)
        rows.append({"method": "seed", "setting": f"{n} samples", "seconds": secs, "default": int(n == 1024),
                     **lut_errors(_f32(out, (LUT_SIZE, LUT_SIZE, 3)), high, dense)})
        log(f"LUT seed {n}: {secs:.3f} s, {rows[-1]['max_abs_err']:.2e}")
    return rows


# ------------------------------------------------------- seed baselines
SEED_IRR_STEP, SEED_SPEC_SAMPLES = 0.025, 1024


def seed_timings(path, quick):
    """Wall time of the seed baselines' full outputs (irradiance 32, specular 256 full chain), per setting.

    Their work does not depend on the pixels (fixed sample patterns, one
    bilinear lookup per sample), so it is timed on one source; the errors of
    each source come from the same code run at its reference texels (_seed_at)."""
    face_irr, face_spec = reference.IRR_FACE, reference.SPEC_FACE
    steps = [0.1, 0.025] if quick else [0.2, 0.1, 0.05, 0.025, 0.0125]
    samples = [64, 1024] if quick else [64, 256, 1024, 4096]
    out = CACHE / "seed_out.f32"
    times = {"irradiance": {}, "specular": {}}
    for d in steps:
        times["irradiance"][d] = run_tool("seed-irradiance", path, face_irr, d, 3 if d >= 0.025 else 1, out)
        log(f"seed irradiance step {d}: {times['irradiance'][d]:.2f} s")
    for n in samples:
        times["specular"][n] = run_tool("seed-specular", path, face_spec, n, 3 if n <= 1024 else 1, out)
        log(f"seed specular {n} samples: {times['specular'][n]:.2f} s")
    out.unlink()
    return times


def _seed_at(ref, path, kind, param):
    out = CACHE / "seed_at.f32"
    run_tool("seed-at", ref.path, path, kind, param, out)
    v = np.fromfile(out, dtype=np.float32)
    out.unlink()
    return v


# -------------------------------------------------------------- irradiance
def _sh9_irradiance(sh9, idx, face):
    """SPEC section 5: Irr(n) ~ sum (A_l / pi) L_lm Y_lm(n) at the reference texels."""
    band = np.array([1, 2 / 3, 2 / 3, 2 / 3, .25, .25, .25, .25, .25])
    out = []
    for f, j, i in idx:
        x, y, z = iblbake_core.texel_direction(int(f), int(i), int(j), face)
        basis = np.array([0.282095, 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
                          1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)])
        out.append(sh9 @ (band * basis))
    return np.array(out)


def _irr_row(source, method, setting, secs, values, ref, default=False):
    idx, ref_vals, rnd = ref.irradiance
    m = level_metrics(values, ref_vals, idx, rnd, reference.IRR_FACE, ref.mean)
    return {"source": source, "method": method, "setting": setting, "seconds": secs, "max_e": m["max_e"],
            "p99_e": m["p99_e"], "max_rel": float(np.max(np.abs(np.asarray(values).sum(-1) - ref_vals.sum(-1)) /
                                                       np.maximum(ref_vals.sum(-1), 1e-30))),
            "rmse": m["rmse"], "bias": m["bias"], "default": int(default)}


def irradiance_sweep(name, path, img, ref, seed_times, quick):
    idx, ref_vals, _ = ref.irradiance
    face = reference.IRR_FACE
    rows = []
    for bins in ([32, 128, 512] if quick else [8, 16, 32, 64, 128, 256, 512]):
        secs, r = median_time(lambda: iblbake_core.bake(img, specular=False, lut=False, irradiance_size=face,
                                                        irradiance_bins=bins), 3)
        rows.append(_irr_row(name, "iblbake", f"{bins} bins", secs, reference.at(r["irradiance"], idx), ref,
                             bins == 128))
    secs, r = median_time(lambda: iblbake_core.bake(img, irradiance=False, specular=False, lut=False), 3)
    rows.append(_irr_row(name, "sh9", "9 coefficients", secs, _sh9_irradiance(r["sh9"], idx, face), ref))
    for delta, secs in seed_times["irradiance"].items():
        vals = _seed_at(ref, path, "irradiance", delta).reshape(-1, 3)
        rows.append(_irr_row(name, "seed", f"step {delta}", secs, vals, ref, delta == SEED_IRR_STEP))
    for r in rows:
        log(f"irradiance {name} {r['method']} {r['setting']}: {r['seconds']:.3f} s, max e {r['max_e']:.2e}")
    return rows


# ---------------------------------------------------------------- specular
def _spec_rows(source, method, setting, secs, levels, ref, default=False, at_texels=False):
    """One summary row and one row per level; levels are cubes, or values at the texels with at_texels."""
    per_level = []
    for m, ((idx, vals, rnd), lvl) in enumerate(zip(ref.specular, levels)):
        s = level_metrics(lvl if at_texels else reference.at(lvl, idx), vals, idx, rnd, ref.faces[m], ref.mean)
        per_level.append({"source": source, "method": method, "setting": setting, "level": m,
                          "roughness": ref.roughness[m], **s})
    worst = max(per_level, key=lambda r: r["rmse"])
    worst_e = max(per_level, key=lambda r: r["max_e"])
    summary = {"source": source, "method": method, "setting": setting, "seconds": secs,
               "worst_max_e": worst_e["max_e"], "worst_max_e_roughness": worst_e["roughness"],
               "worst_sa_rms": max(r["sa_rms"] for r in per_level),
               "worst_bias": max((r["bias"] for r in per_level), key=abs),
               "worst_rmse": worst["rmse"], "worst_rmse_roughness": worst["roughness"],
               "worst_p99": max(r["p99"] for r in per_level), "default": int(default)}
    return summary, per_level


def specular_sweep(name, path, img, ref, seed_times, quick):
    face = reference.SPEC_FACE
    summaries, levels = [], []

    def add(method, setting, secs, cubes, default=False, at_texels=False):
        s, lv = _spec_rows(name, method, setting, secs, cubes, ref, default, at_texels)
        summaries.append(s)
        levels.extend(lv)
        log(f"specular {name} {method} {setting}: {secs:.3f} s, worst texel e {s['worst_max_e']:.2e}, "
            f"worst RMSE {s['worst_rmse']:.2e}")

    for eps in ([0.25, 0.4, 0.7] if quick else EPS_SWEEP):
        secs, r = median_time(lambda: iblbake_core.bake(img, irradiance=False, lut=False, face_size=face, eps=eps), 3)
        add("iblbake", f"eps {eps}", secs, r["specular"], eps == EPS_DEFAULT)
    fis = [(12, 1.0)] if quick else [(6, 1.0), (12, 1.0), (24, 1.0), (12, 2.0)]
    for rings, bias in fis:
        secs, r = median_time(lambda: iblbake_core.bake(img, irradiance=False, lut=False, face_size=face,
                                                        specular_method="fis", rings=rings, lod_bias=bias), 3)
        add("fis", f"rings {rings}, lod bias {bias:g}", secs, r["specular"])
    for n, secs in seed_times["specular"].items():
        flat, levels_at, off = _seed_at(ref, path, "specular", n), [], 0
        for idx, _, _ in ref.specular:  # values come in the reference's row order
            levels_at.append(flat[off:off + len(idx) * 3].reshape(-1, 3))
            off += len(idx) * 3
        add("seed", f"{n} samples", secs, levels_at, n == SEED_SPEC_SAMPLES, at_texels=True)
    return summaries, levels


def source_image(path):
    return iblbake_core.read_image(str(path))


