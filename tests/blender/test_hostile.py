"""Issue 15 in headless Blender: bake_world.py with hostile input (D2, D3,
D13, D14, D17), and issue 24 (E2, E8, E12, E13, E15)."""
import json
import os

import pytest

from blender_helpers import BAKE_WORLD, BLENDER, FOREST, bake_world, blender_env, manifest, run_blender

SMALL = ["--face-size", "16", "--irradiance-size", "8", "--lut-size", "16"]


def error_lines(p):
    return [line for line in p.stderr.splitlines() if line.startswith("iblbake: error:")]


@pytest.mark.parametrize("name, data", [
    ("notes.txt", b"these are my notes\n" * 50),
    ("notes.png", b"these are my notes\n" * 50),
    ("scene.blend", b"BLENDER-v300" + bytes(4000)),
])
def test_d2_an_image_blender_cannot_load_is_an_error_not_a_magenta_render(tmp_path, name, data):
    src = tmp_path / name
    src.write_bytes(data)
    out = tmp_path / "out"
    p = bake_world("--hdri", str(src), "--out", str(out), *SMALL)
    assert p.returncode == 1, p.stdout[-2000:] + p.stderr[-2000:]
    assert any("cannot be read" in line for line in error_lines(p)), p.stderr
    assert not out.exists()


@pytest.mark.parametrize("args, message", [
    (["--face-size", "100000"], "face_size must be in 1..4096"),
    (["--mips", "100"], "mip_count must be in 0..20"),
    (["--lut-size", "5000"], "lut_size must be in 1..4096"),
    (["--irradiance-size", "9999"], "irradiance_size must be in 1..4096"),
    (["--render-width", "99999"], "render_width must be in 16..16384"),
    (["--strength", "nan"], "must be a finite number"),
    (["--exposure", "inf"], "must be a finite number"),
])
def test_d13_d14_out_of_range_options_fail_like_the_cli(tmp_path, args, message):
    out = tmp_path / "out"
    p = bake_world("--hdri", FOREST, "--out", str(out), *args)
    assert p.returncode == 1, p.stdout[-2000:] + p.stderr[-2000:]
    lines = error_lines(p)
    assert len(lines) == 1 and message in lines[0], p.stderr
    assert not out.exists()


def test_d3_a_truncated_output_is_baked_again(tmp_path):
    out = tmp_path / "out"
    p = bake_world("--hdri", FOREST, "--out", str(out), *SMALL)
    assert p.returncode == 0, p.stderr
    spec0 = out / "specular_0.exr"
    size = spec0.stat().st_size
    spec0.write_bytes(spec0.read_bytes()[:300])
    p = bake_world("--hdri", FOREST, "--out", str(out), *SMALL)
    assert p.returncode == 0, p.stderr
    assert "nothing to do" not in p.stdout
    assert spec0.stat().st_size == size
    p = bake_world("--hdri", FOREST, "--out", str(out), *SMALL)  # negative control: now unchanged
    assert "nothing to do" in p.stdout, p.stdout[-2000:]


def test_d17_negative_strength_and_square_source_warn(tmp_path):
    square = tmp_path / "square.exr"
    import subprocess
    subprocess.run(["oiiotool", FOREST, "--resize", "256x256", "-o", str(square)], check=True, capture_output=True)
    out = tmp_path / "out"
    p = bake_world("--hdri", str(square), "--out", str(out), "--strength", "-1", *SMALL)
    assert p.returncode == 0, p.stderr
    warnings = [line for line in p.stderr.splitlines() if line.startswith("iblbake: warning:")]
    assert any("Strength" in w for w in warnings) and any("2:1" in w for w in warnings), p.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert any("Strength" in w for w in m["warnings"]) and any("2:1" in w for w in m["warnings"])


# --- issue 24 ---------------------------------------------------------------------------------------

def hostile_blend(case, kind, **params):
    _, work = case("save_hostile_world", kind=kind, **params)
    return str(work / "scene.blend"), work


@pytest.mark.parametrize("kind, words", [
    ("udim", "UDIM"),
    ("udim_1001", "UDIM"),
    ("sequence_gap", "frame 1"),
    ("mix_missing", "gone.exr"),
])
def test_e2_images_without_pixels_are_refused_not_baked_magenta(case, tmp_path, kind, words):
    blend, work = hostile_blend(case, kind)
    out = tmp_path / "out"
    p = run_blender([blend, "--python", BAKE_WORLD, "--", "--out", str(out), *SMALL])
    assert p.returncode == 1, p.stdout[-2000:] + p.stderr[-2000:]
    lines = error_lines(p)
    assert lines and words in lines[-1], p.stderr
    assert not out.exists()


def test_e2_the_magenta_share_of_a_render_is_measured(tmp_path):
    from blender_helpers import ROOT
    # world_reader needs bpy: its magenta measure is checked on an array in Blender here.
    code = ("import sys; sys.path.insert(0, %r); import numpy as np; from iblbake import world_reader as w; "
            "a = np.zeros((32, 64, 3), np.float32); a[:, :40] = (1, 0, 1); print(round(w.magenta_share(a), 3))"
            % os.path.join(ROOT, "addon"))
    p = run_blender(["--python-expr", code])
    assert "0.625" in p.stdout, p.stdout[-2000:] + p.stderr[-2000:]


def test_e13_a_mapping_that_is_not_a_number_names_its_node(case, tmp_path):
    blend, _ = hostile_blend(case, "mapping_nan")
    out = tmp_path / "out"
    p = run_blender([blend, "--python", BAKE_WORLD, "--", "--out", str(out), *SMALL])
    assert p.returncode == 1, p.stderr[-3000:]
    lines = error_lines(p)
    assert len(lines) == 1 and "Sky Turn" in lines[0] and "Rotation" in lines[0], p.stderr
    assert not out.exists()


def test_e8_a_float_image_in_srgb_is_rendered_not_read_clamped(case, tmp_path):
    blend, _ = hostile_blend(case, "srgb_float", value=1000)
    out = tmp_path / "out"
    p = run_blender([blend, "--python", BAKE_WORLD, "--", "--out", str(out), *SMALL])
    assert p.returncode == 0, p.stderr[-3000:]
    m = manifest(out)
    assert m["blender"]["path"] == "cycles_render", m["blender"]["path"]
    # Cycles decodes 1000 as sRGB to ((1000 + 0.055) / 1.055)^2.4 = 1.39e7; Blender's buffer held 40.5.
    assert min(m["mean_radiance"]) > 1e7, m["mean_radiance"]


def test_e12_a_black_world_from_a_driver_that_did_not_run_warns(case, tmp_path):
    blend, _ = hostile_blend(case, "driver_black")
    out = tmp_path / "out"
    p = run_blender([blend, "--python", BAKE_WORLD, "--", "--out", str(out), *SMALL])
    assert p.returncode == 0, p.stderr[-3000:]
    warnings = manifest(out)["warnings"]
    assert any("black" in w for w in warnings), warnings
    assert any("driver" in w and "Strength" in w for w in warnings), warnings


def test_e15_a_quoted_tilde_out_is_the_home_folder(tmp_path):
    import subprocess
    env = dict(blender_env(), HOME=str(tmp_path / "home"))
    os.makedirs(env["HOME"])
    p = subprocess.run([BLENDER, "-b", "--factory-startup", "--python", BAKE_WORLD, "--", "--hdri", FOREST,
                        "--out", "~/bakes/x", *SMALL], capture_output=True, text=True, env=env, cwd=str(tmp_path),
                       timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    assert (tmp_path / "home" / "bakes" / "x" / "manifest.json").is_file()
    assert not (tmp_path / "~").exists()


def test_e15_worlds_whose_names_leave_nothing_bake_into_distinct_folders(case, tmp_path):
    folders = set()
    for name in ("\U0001F600\U0001F30D", "..", "."):
        blend, _ = hostile_blend(case, "emoji_name", world_name=name)
        p = run_blender([blend, "--python", BAKE_WORLD, "--", "--out", str(tmp_path / "{world}"), *SMALL])
        assert p.returncode == 0, p.stderr[-3000:]
    folders = {n for n in os.listdir(tmp_path) if os.path.isfile(tmp_path / n / "manifest.json")}
    assert len(folders) == 3, sorted(os.listdir(tmp_path))


def test_e15_an_unknown_placeholder_is_refused(tmp_path):
    out = tmp_path / "{unknown}"
    p = bake_world("--hdri", FOREST, "--out", str(out), *SMALL)
    assert p.returncode == 1, p.stderr[-2000:]
    assert any("{unknown}" in line for line in error_lines(p)), p.stderr
    assert not out.exists()
