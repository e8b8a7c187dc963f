"""The exhaustive reference of SPEC's integral over the bilinear source, computed
once per source by iblbake_bench and cached in bench/.cache/reference, keyed by
the source's sha256 and the settings: every irradiance texel and, per specular
level, every texel of levels of face <= SMALL_FACE, else PER_LEVEL drawn at
random plus every texel near a bright feature (tests/native/reference.h)."""
import numpy as np

from common import CACHE, log, read_csv, run_tool, sha256_file

IRR_FACE, SPEC_FACE = 32, 256
SMALL_FACE = 16


class Reference:
    """Reference values for one source: irradiance texels, specular texels per level.
    Each is (idx (f, j, i), values (n, 3), random mask); `mean` is the channel sum
    of L's mean (every level's mean, issue 14's error floor is 5 % of it)."""

    def __init__(self, path, rows):
        self.path = path
        mean_row = next(r for r in rows if r["kind"] == "mean")
        self.mean = sum(float(mean_row[c]) for c in "rgb")

        def arrays(sel):
            idx = np.array([(int(r["f"]), int(r["j"]), int(r["i"])) for r in sel])
            val = np.array([[float(r[c]) for c in "rgb"] for r in sel])
            rnd = np.array([r["random"] == "1" for r in sel])
            return idx, val, rnd
        self.irradiance = arrays([r for r in rows if r["kind"] == "irradiance"])
        levels = sorted({int(r["level"]) for r in rows if r["kind"] == "specular"})
        self.specular = [arrays([r for r in rows if r["kind"] == "specular" and int(r["level"]) == m]) for m in levels]
        self.roughness = [float(next(r["roughness"] for r in rows if r["kind"] == "specular" and int(r["level"]) == m))
                          for m in levels]
        self.faces = [int(next(r["face"] for r in rows if r["kind"] == "specular" and int(r["level"]) == m))
                      for m in levels]


def load(src_path, per_level):
    key = f"{sha256_file(src_path)[:16]}_bilinear_irr{IRR_FACE}_spec{SPEC_FACE}_n{per_level}_s{SMALL_FACE}"
    path = CACHE / "reference" / f"{key}.csv"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        log(f"reference for {src_path.name} (once; cached as {path.name})")
        tmp = path.with_suffix(".tmp")
        run_tool("reference", src_path, tmp, IRR_FACE, SPEC_FACE, per_level, SMALL_FACE)
        tmp.rename(path)
    return Reference(path, read_csv(path))


def at(cube, idx):
    """Values of a (6, N, N, 3) cube at reference texel indices (f, j, i)."""
    return cube[idx[:, 0], idx[:, 1], idx[:, 2]]
