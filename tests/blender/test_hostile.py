"""Issue 15 in headless Blender: bake_world.py with hostile input (D2, D3,
D13, D14, D17)."""
import json

import pytest

from blender_helpers import FOREST, bake_world

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
