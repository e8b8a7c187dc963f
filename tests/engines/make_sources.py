"""Writes the engine tests' lat-long sources (float EXR, SPEC section 1 mapping).

marker.exr  six coloured lobes around the engine axes (SPEC 2, Y up):
            +X red, -X cyan, +Y green, -Y magenta, +Z blue, -Z yellow,
            each exp(k (d.a - 1)) with k = 12 on a dim grey floor.
marker_babylon.exr  the marker turned for Babylon's lat-long convention.
smooth.exr  L(w) = c + D.w + w^T Q w per channel (constant, dipole and a
            traceless quadrupole: SH bands 0, 1 and 2 only, so SH9 is exact),
            and Irr(n) = c + (2/3) D.n + (1/4) n^T Q n exactly.
sun.exr     smooth.exr plus a sun: a uniform disc of SUN_RADIUS_DEG around
            SUN_DIR (engine space), each texel holding the disc's exact share
            of it (16 x 16 points per texel on the disc's edge): the sun as a
            light (issue 27).

Usage: make_sources.py OUTDIR [--width 512]
"""
import argparse
import json
import os
import sys

import numpy as np

import iblbake_core

# Engine-space lobe axes and colours (RGB).
LOBES = [
    ("+X", (1, 0, 0), (1.0, 0.0, 0.0)),
    ("-X", (-1, 0, 0), (0.0, 1.0, 1.0)),
    ("+Y", (0, 1, 0), (0.0, 1.0, 0.0)),
    ("-Y", (0, -1, 0), (1.0, 0.0, 1.0)),
    ("+Z", (0, 0, 1), (0.0, 0.0, 1.0)),
    ("-Z", (0, 0, -1), (1.0, 1.0, 0.0)),
]
LOBE_SHARPNESS = 12.0
FLOOR = 0.02

# Smooth source: per channel constant c, vector D and traceless symmetric Q
# (engine space), small enough that L > 0 everywhere.
SMOOTH_C = (0.60, 0.50, 0.40)
SMOOTH_D = ((0.35, 0.10, -0.15), (-0.05, 0.30, 0.20), (0.10, -0.12, 0.25))
SMOOTH_Q = (((0.10, 0.05, 0.00), (0.05, -0.04, 0.03), (0.00, 0.03, -0.06)),
            ((-0.05, 0.00, 0.04), (0.00, 0.08, -0.02), (0.04, -0.02, -0.03)),
            ((0.02, -0.03, 0.00), (-0.03, -0.05, 0.02), (0.00, 0.02, 0.03)))


# The sun of sun.exr: engine-space direction (up, right and towards the
# camera of the sphere renders), angular radius and radiance (RGB).
SUN_DIR = (0.45, 0.6, 0.66)
SUN_RADIUS_DEG = 1.5
SUN_RADIANCE = (2000.0, 1800.0, 1500.0)


def engine_dirs(width, height):
    """Engine-space unit directions of the texel centres, (H, W, 3)."""
    col = (np.arange(width) + 0.5) / width
    row = (np.arange(height) + 0.5) / height
    u, v = np.meshgrid(col, 1.0 - row)
    phi = (0.5 - u) * 2.0 * np.pi          # atan2(y, x) in Blender space
    lat = (v - 0.5) * np.pi                # asin(z)
    bx, by, bz = np.cos(lat) * np.cos(phi), np.cos(lat) * np.sin(phi), np.sin(lat)
    return np.stack([bx, bz, -by], axis=-1)  # SPEC 2: engine (x, y, z) = (bx, bz, -by)


def marker(width, height, turn=None):
    d = engine_dirs(width, height)
    if turn is not None:
        d = turn(d)
    img = np.full((height, width, 3), FLOOR, dtype=np.float64)
    for _, axis, colour in LOBES:
        w = np.exp(LOBE_SHARPNESS * (d @ np.asarray(axis, dtype=np.float64) - 1.0))
        img += w[..., None] * np.asarray(colour)
    return img.astype(np.float32)


def smooth(width, height):
    d = engine_dirs(width, height)
    img = np.empty((height, width, 3), dtype=np.float64)
    for ch in range(3):
        q = np.asarray(SMOOTH_Q[ch])
        img[..., ch] = SMOOTH_C[ch] + d @ np.asarray(SMOOTH_D[ch]) + np.einsum("...i,ij,...j->...", d, q, d)
    assert img.min() > 0
    return img.astype(np.float32)


def sun(width, height):
    """smooth() plus the disc of SUN_RADIUS_DEG around SUN_DIR, antialiased."""
    img = smooth(width, height).astype(np.float64)
    axis = np.asarray(SUN_DIR, dtype=np.float64)
    axis /= np.linalg.norm(axis)
    cos_r = np.cos(np.radians(SUN_RADIUS_DEG))
    near = engine_dirs(width, height) @ axis > np.cos(np.radians(SUN_RADIUS_DEG + 3 * 360.0 / width))
    k = 16
    for y, x in zip(*np.nonzero(near)):
        u = (x + (np.arange(k) + 0.5) / k) / width
        v = 1.0 - (y + (np.arange(k) + 0.5) / k) / height
        uu, vv = np.meshgrid(u, v)
        phi, lat = (0.5 - uu) * 2 * np.pi, (vv - 0.5) * np.pi
        d = np.stack([np.cos(lat) * np.cos(phi), np.sin(lat), -np.cos(lat) * np.sin(phi)], -1)
        wt = np.cos(lat)
        cover = (wt * (d @ axis >= cos_r)).sum() / wt.sum()
        img[y, x] += cover * np.asarray(SUN_RADIANCE)
    return img.astype(np.float32)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir")
    ap.add_argument("--width", type=int, default=512)
    a = ap.parse_args(argv)
    os.makedirs(a.outdir, exist_ok=True)
    w, h = a.width, a.width // 2
    iblbake_core.write_exr(os.path.join(a.outdir, "marker.exr"), marker(w, h))
    iblbake_core.write_exr(os.path.join(a.outdir, "smooth.exr"), smooth(w, h))
    iblbake_core.write_exr(os.path.join(a.outdir, "sun.exr"), sun(w, h))
    # The same marker for Babylon's own prefiltering, whose lat-long
    # convention shows at Babylon direction d the image's (d.z, d.y, d.x); its
    # world is SPEC's with x negated (as its glTF loader places glTF content),
    # so it must read marker(-s.z, s.y, s.x).
    iblbake_core.write_exr(os.path.join(a.outdir, "marker_babylon.exr"),
                           marker(w, h, lambda d: np.stack([-d[..., 2], d[..., 1], d[..., 0]], axis=-1)))
    with open(os.path.join(a.outdir, "sources.json"), "w") as f:
        json.dump({"lobes": [{"name": n, "axis": ax, "colour": c} for n, ax, c in LOBES],
                   "lobe_sharpness": LOBE_SHARPNESS, "floor": FLOOR,
                   "smooth": {"c": SMOOTH_C, "d": SMOOTH_D, "q": SMOOTH_Q},
                   "sun": {"direction": SUN_DIR, "radius_deg": SUN_RADIUS_DEG, "radiance": SUN_RADIANCE},
                   "width": w, "height": h}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
