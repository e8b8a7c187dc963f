"""The CLI: help, success, and one-line failures that leave outputs alone."""
import json
import os
import subprocess

import numpy as np
import pytest

import iblbake_core as ib

CLI = os.environ.get("IBLBAKE_CLI") or os.path.join(os.path.dirname(__file__), "..", "..", "build", "native", "iblbake")
FOREST = "/usr/share/blender/datafiles/studiolights/world/forest.exr"


def run(*args):
    return subprocess.run([CLI, *args], capture_output=True, text=True)


def test_help_lists_every_option():
    r = run("bake", "--help")
    assert r.returncode == 0
    for opt in ["--face-size", "--irradiance-size", "--mips", "--lut-size", "--lut-model", "--samples",
                "--format", "--float32", "--png-encoding", "--exposure", "--threads", "--strict"]:
        assert opt in r.stdout, opt


@pytest.mark.skipif(not os.path.exists(FOREST), reason="blender-data not installed")
def test_bakes_a_real_hdri_like_the_module(tmp_path):
    out = tmp_path / "forest"
    r = run("bake", FOREST, "-o", str(out), "--face-size", "32", "--irradiance-size", "8", "--lut-size", "32")
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert m["source"]["width"] == 1024 and m["source"]["height"] == 512
    # The module's bake of the same pixels gives the same irradiance.
    img = ib.read_image(FOREST)
    res = ib.bake(img, face_size=32, irradiance_size=8, lut_size=32)
    np.testing.assert_allclose(res["manifest"]["sh9"], m["sh9"], rtol=1e-9)
    assert m["bad_input"] == res["manifest"]["bad_input"]


def test_failures_are_one_line_and_keep_outputs(tmp_path):
    out = tmp_path / "o"
    bad = tmp_path / "bad.hdr"
    bad.write_bytes(b"#?RADIANCE\ngarbage")
    for args in [("bake", str(tmp_path / "nope.exr"), "-o", str(out)),
                 ("bake", str(bad), "-o", str(out)),
                 ("bake", FOREST, "-o", str(out), "--lut-model", "x")]:
        r = run(*args)
        assert r.returncode != 0
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("iblbake: error:"), r.stderr
    assert not out.exists()


@pytest.mark.skipif(not os.path.exists(FOREST), reason="blender-data not installed")
def test_a_bake_replaces_the_folder_and_says_what_went(tmp_path):
    """Scripts expect the folder replaced; the CLI says what the earlier bake
    had that this one has not (issue 26), and nothing when nothing went."""
    out = str(tmp_path / "o")
    small = ["--irradiance-size", "8", "--lut-size", "32"]
    r = run("bake", FOREST, "-o", out, *small, "--face-size", "32", "--preset", "three", "--preset", "khronos")
    assert r.returncode == 0 and "replaced" not in r.stdout, r.stdout
    r = run("bake", FOREST, "-o", out, *small, "--face-size", "16")
    assert r.returncode == 0, r.stderr
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("replaced the earlier bake in")]
    assert line == ["replaced the earlier bake in %s: removed specular_5.exr, khronos/ (3 files), three/ (1 file)"
                    % out], r.stdout
    assert not os.path.exists(os.path.join(out, "three"))
    r = run("bake", FOREST, "-o", out, *small, "--face-size", "16")
    assert "replaced" not in r.stdout, r.stdout
    other = str(tmp_path / "other.exr")
    ib.write_exr(other, ib.read_image(FOREST) * 2)
    r = run("bake", other, "-o", out, *small, "--face-size", "16")
    assert "replaced the earlier bake in %s: the bake of forest.exr\n" % out in r.stdout, r.stdout
    assert "replaced" not in run("bake", FOREST, "-o", out, "-q", *small, "--face-size", "32").stdout  # -q: silent
