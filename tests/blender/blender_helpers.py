"""Helpers of the add-on tests: run tests/blender/cases.py in headless
Blender and read what it wrote (the `case` fixture is in conftest.py)."""
import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
BUILD_NATIVE = os.environ.get("IBLBAKE_CORE_DIR", os.path.join(ROOT, "build", "native"))
sys.path.insert(0, BUILD_NATIVE)
BLENDER = os.environ.get("BLENDER", shutil.which("blender") or "blender")


def blender_version():
    """(major, minor, patch) of the Blender the tests run, from `blender --version`."""
    global _VERSION
    if _VERSION is None:
        out = subprocess.run([BLENDER, "--version"], capture_output=True, text=True, timeout=120).stdout
        m = re.search(r"Blender (\d+)\.(\d+)\.(\d+)", out)
        assert m, "cannot read the version of %s: %r" % (BLENDER, out[:300])
        _VERSION = tuple(int(g) for g in m.groups())
    return _VERSION


_VERSION = None


def blender_env():
    env = dict(os.environ, IBLBAKE_CORE_DIR=BUILD_NATIVE)
    env.setdefault("IBLBAKE_CACHE_DIR", os.path.join(ROOT, "build", "tests", "lut-cache"))
    return env


def run_blender(args, timeout=600):
    """blender -b --factory-startup ARGS; returns the CompletedProcess."""
    return subprocess.run([BLENDER, "-b", "--factory-startup", *args], capture_output=True, text=True,
                          env=blender_env(), timeout=timeout)


# Blender's own studio HDRI, and the headless script the tests drive.
FOREST = "/usr/share/blender/datafiles/studiolights/world/forest.exr"
BAKE_WORLD = os.path.join(ROOT, "blender_scripts", "bake_world.py")


def bake_world(*args):
    """blender_scripts/bake_world.py -- ARGS in headless Blender."""
    return run_blender(["--python", BAKE_WORLD, "--", *args])


@pytest.fixture
def case(tmp_path):
    """case(name, **params) -> (result dict, work folder)."""
    def run(name, **params):
        work = tmp_path / name
        p = run_blender(["--python-exit-code", "1", "--python", os.path.join(HERE, "cases.py"), "--", name,
                         str(work), *("%s=%s" % kv for kv in params.items())])
        assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
        with open(work / "result.json") as f:
            return json.load(f), work
    return run


# Faces of the horizontal cross (SPEC.md 2): face index -> (column, row).
CROSS_CELLS = {0: (2, 1), 1: (0, 1), 2: (1, 0), 3: (1, 2), 4: (1, 1), 5: (3, 1)}


def sample_cross(cross, blender_dir):
    """Bilinear lookup (within the face) of a cross image at a Blender direction."""
    import iblbake_core as ib
    n = cross.shape[0] // 3
    x, y, z = blender_dir
    face, s, t = ib.direction_to_face(x, z, -y)  # engine = (x, z, -y)
    col, row = CROSS_CELLS[face]
    fx = min(max(s * n - 0.5, 0.0), n - 1.0)
    fy = min(max(t * n - 0.5, 0.0), n - 1.0)
    x0, y0 = int(fx), int(fy)
    x1, y1 = min(x0 + 1, n - 1), min(y0 + 1, n - 1)
    ax, ay = fx - x0, fy - y0
    f = cross[row * n:(row + 1) * n, col * n:(col + 1) * n]
    top = f[y0, x0] * (1 - ax) + f[y0, x1] * ax
    bottom = f[y1, x0] * (1 - ax) + f[y1, x1] * ax
    return top * (1 - ay) + bottom * ay


def read(path):
    import iblbake_core as ib
    return ib.read_image(str(path))


def manifest(folder):
    with open(os.path.join(folder, "manifest.json")) as f:
        return json.load(f)


__all__ = ["blender_version", "run_blender", "sample_cross", "read", "manifest", "np", "ROOT", "BUILD_NATIVE"]
