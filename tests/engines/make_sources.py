"""Writes the engine tests' lat-long sources (float EXR, SPEC section 1 mapping).

marker.exr  six coloured lobes around the engine axes (SPEC 2, Y up):
            +X red, -X cyan, +Y green, -Y magenta, +Z blue, -Z yellow,
            each exp(k (d.a - 1)) with k = 12 on a dim grey floor.
dipole.exr  L(w) = c + D w per channel (constant plus dipole): its SH9 is
            exact (bands 0 and 1 only), and Irr(n) = c + (2/3) D n exactly.

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

# Dipole source: per channel constant c and vector D (engine space), |D| < c.
DIPOLE_C = (0.60, 0.50, 0.40)
DIPOLE_D = ((0.35, 0.10, -0.15), (-0.05, 0.30, 0.20), (0.10, -0.12, 0.25))


def engine_dirs(width, height):
    """Engine-space unit directions of the texel centres, (H, W, 3)."""
    col = (np.arange(width) + 0.5) / width
    row = (np.arange(height) + 0.5) / height
    u, v = np.meshgrid(col, 1.0 - row)
    phi = (0.5 - u) * 2.0 * np.pi          # atan2(y, x) in Blender space
    lat = (v - 0.5) * np.pi                # asin(z)
    bx, by, bz = np.cos(lat) * np.cos(phi), np.cos(lat) * np.sin(phi), np.sin(lat)
    return np.stack([bx, bz, -by], axis=-1)  # SPEC 2: engine (x, y, z) = (bx, bz, -by)


def marker(width, height):
    d = engine_dirs(width, height)
    img = np.full((height, width, 3), FLOOR, dtype=np.float64)
    for _, axis, colour in LOBES:
        w = np.exp(LOBE_SHARPNESS * (d @ np.asarray(axis, dtype=np.float64) - 1.0))
        img += w[..., None] * np.asarray(colour)
    return img.astype(np.float32)


def dipole(width, height):
    d = engine_dirs(width, height)
    img = np.empty((height, width, 3), dtype=np.float64)
    for ch in range(3):
        img[..., ch] = DIPOLE_C[ch] + d @ np.asarray(DIPOLE_D[ch])
    return img.astype(np.float32)


def write_hdr(path, img):
    """Radiance RGBE (.hdr), flat (not run-length encoded) scanlines, top row first."""
    rgb = np.maximum(img.astype(np.float64), 0.0)
    m = rgb.max(axis=-1)
    e = np.zeros(m.shape, dtype=np.int64)
    ok = m > 1e-32
    mant, ex = np.frexp(m[ok])          # m = mant * 2^ex, mant in [0.5, 1)
    e[ok] = ex
    scale = np.zeros(m.shape)
    scale[ok] = 256.0 / np.ldexp(1.0, ex)
    out = np.zeros(img.shape[:2] + (4,), dtype=np.uint8)
    out[..., :3] = np.clip(np.floor(rgb * scale[..., None]), 0, 255).astype(np.uint8)
    out[..., 3] = np.where(ok, e + 128, 0).astype(np.uint8)
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(f"-Y {img.shape[0]} +X {img.shape[1]}\n".encode())
        f.write(out.tobytes())


def read_hdr_values(img):
    """The float values an RGBE file of img decodes to (centre-less decode: m * 2^(e-136))."""
    rgb = np.maximum(img.astype(np.float64), 0.0)
    m = rgb.max(axis=-1)
    ok = m > 1e-32
    ex = np.zeros(m.shape)
    ex[ok] = np.frexp(m[ok])[1]
    q = np.floor(rgb * np.where(ok, 256.0 / np.ldexp(1.0, ex.astype(np.int64)), 0)[..., None])
    return (q * np.ldexp(1.0, (ex - 8).astype(np.int64))[..., None]).astype(np.float32)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir")
    ap.add_argument("--width", type=int, default=512)
    a = ap.parse_args(argv)
    os.makedirs(a.outdir, exist_ok=True)
    w, h = a.width, a.width // 2
    iblbake_core.write_exr(os.path.join(a.outdir, "marker.exr"), marker(w, h))
    iblbake_core.write_exr(os.path.join(a.outdir, "dipole.exr"), dipole(w, h))
    # The same marker as Radiance RGBE, for engines that prefilter only .hdr
    # (Babylon's HDRCubeTexture); marker_q.exr holds exactly the values it decodes to,
    # so our bake and the engine's filtering see the same texels.
    write_hdr(os.path.join(a.outdir, "marker.hdr"), marker(w, h))
    iblbake_core.write_exr(os.path.join(a.outdir, "marker_q.exr"), read_hdr_values(marker(w, h)))
    with open(os.path.join(a.outdir, "sources.json"), "w") as f:
        json.dump({"lobes": [{"name": n, "axis": ax, "colour": c} for n, ax, c in LOBES],
                   "lobe_sharpness": LOBE_SHARPNESS, "floor": FLOOR,
                   "dipole": {"c": DIPOLE_C, "d": DIPOLE_D}, "width": w, "height": h}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
