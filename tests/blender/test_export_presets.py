"""bake_world.py --preset in headless Blender: the presets' folders, the
content hash, one-line failures."""

from blender_helpers import FOREST, bake_world, manifest

OPTS = ["--face-size", "32", "--irradiance-size", "8", "--lut-size", "32"]


def test_bake_world_presets(tmp_path):
    out = tmp_path / "forest"
    p = bake_world("--hdri", FOREST, "--out", str(out), *OPTS, "--preset", "three,babylon", "--preset", "unity")
    assert p.returncode == 0, p.stdout + p.stderr
    m = manifest(out)
    assert sorted(m["presets"]) == ["babylon", "three", "unity"]
    for name, entry in m["presets"].items():
        for f in entry["files"].values():
            assert (out / name / f).is_file()
    first = m["blender"]["content_hash"]
    p = bake_world("--hdri", FOREST, "--out", str(out), *OPTS, "--preset", "three,babylon,unity")
    assert p.returncode == 0 and "unchanged" in p.stdout
    p = bake_world("--hdri", FOREST, "--out", str(out), *OPTS, "--preset", "three")
    assert p.returncode == 0, p.stdout + p.stderr
    assert sorted(manifest(out)["presets"]) == ["three"] and manifest(out)["blender"]["content_hash"] != first
    p = bake_world("--hdri", FOREST, "--out", str(out), "--face-size", "24", "--preset", "babylon")
    assert p.returncode == 1
    assert "power-of-two face size" in p.stderr
    assert sorted(manifest(out)["presets"]) == ["three"]  # the earlier bake stays
