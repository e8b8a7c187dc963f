"""The exhaustive reference (every source texel, exact solid angles, double) at a
fixed random set of output texels per level, computed once by iblbake_bench and
cached in bench/.cache/reference, keyed by the source's sha256 and the settings."""
import numpy as np

from common import CACHE, log, read_csv, run_tool, sha256_file

IRR_FACE, SPEC_FACE = 32, 256


class Reference:
    """Reference values for one source: irradiance texels, specular texels per level."""

    def __init__(self, path, rows):
        self.path = path
        def arrays(sel):
            idx = np.array([(int(r["f"]), int(r["j"]), int(r["i"])) for r in sel])
            val = np.array([[float(r[c]) for c in "rgb"] for r in sel])
            return idx, val
        self.irradiance = arrays([r for r in rows if r["kind"] == "irradiance"])
        levels = sorted({int(r["level"]) for r in rows if r["kind"] == "specular"})
        self.specular = [arrays([r for r in rows if r["kind"] == "specular" and int(r["level"]) == m]) for m in levels]
        self.roughness = [float(next(r["roughness"] for r in rows if r["kind"] == "specular" and int(r["level"]) == m))
                          for m in levels]


def load(src_path, per_level):
    key = f"{sha256_file(src_path)[:16]}_irr{IRR_FACE}_spec{SPEC_FACE}_n{per_level}"
    path = CACHE / "reference" / f"{key}.csv"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        log(f"reference for {src_path.name} (once; cached as {path.name})")
        tmp = path.with_suffix(".tmp")
        run_tool("reference", src_path, tmp, IRR_FACE, SPEC_FACE, per_level)
        tmp.rename(path)
    return Reference(path, read_csv(path))


def at(cube, idx):
    """Values of a (6, N, N, 3) cube at reference texel indices (f, j, i)."""
    return cube[idx[:, 0], idx[:, 1], idx[:, 2]]
