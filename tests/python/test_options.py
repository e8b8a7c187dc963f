"""One table of options (native/include/iblbake/pipeline/options.h): the
CLI's flags, Python's keyword arguments and the add-on's settings are the
table's, nothing more and nothing less (bake_world.py's and the add-on's
properties are checked in tests/blender/test_addon.py)."""
import os
import re
import subprocess
import sys

import pytest

import iblbake_core as ib

HERE = os.path.dirname(os.path.abspath(__file__))
CLI = os.environ.get("IBLBAKE_CLI", os.path.join(HERE, "..", "..", "build", "native", "iblbake"))
ROWS = ib.options()
# What the CLI has that is not an option of the bake: its call's own arguments.
CLI_OWN = {"--help", "--output", "--cache-dir", "--no-cache", "--quiet",
           "--list", "--jobs", "--shard", "--force"}  # the batch's own (cli/batch.h)


def cli_flags():
    text = subprocess.run([CLI, "bake", "--help"], capture_output=True, text=True, check=True).stdout
    return set(re.findall(r"(?:^|,)\s*(--[a-z0-9-]+)", text, re.M))


def test_the_table_describes_every_row():
    assert len({r["name"] for r in ROWS}) == len(ROWS)
    for r in ROWS:
        assert r["kind"] in ("int", "float", "bool", "choice", "list"), r
        assert r["label"] and r["help"] and "\n" not in r["help"], r
        if r["kind"] in ("choice", "list"):
            assert r["choices"] and all(c["value"] and c["label"] for c in r["choices"]), r
        if r["kind"] == "choice":
            assert r["default"] in [c["value"] for c in r["choices"]], r
        if "min" in r and r["max"] is not None:
            assert r["min"] <= r["default"] <= r["max"], r


def test_the_clis_flags_are_the_tables():
    expected = {r["cli"] for r in ROWS if r["cli"]}
    assert cli_flags() - CLI_OWN == expected


def test_pythons_keywords_are_the_tables():
    for r in ROWS:  # every row's default is taken as it is ...
        ib.check_options(**{r["name"]: r["default"]})
    with pytest.raises(ValueError, match="unknown option 'face_sizes'"):
        ib.check_options(face_sizes=256)  # ... and nothing else
    # The table's ranges and choices are the checks every surface makes.
    for r in ROWS:
        if r["kind"] == "int" and "min" in r:
            with pytest.raises(ValueError, match=r["name"]):
                ib.check_options(**{r["name"]: int(r["min"]) - 1})
        if r["kind"] == "choice":
            with pytest.raises(ValueError, match=r["name"]):
                ib.check_options(**{r["name"]: "no-such-" + r["name"]})


def test_the_cli_and_python_refuse_alike(tmp_path):
    """One value out of range: the same words from both (the CLI's spelled
    as its flag would be in a warning, the message names the option)."""
    src = tmp_path / "s.exr"
    ib.write_exr(str(src), __import__("numpy").full((16, 32, 3), 0.5, "float32"))
    p = subprocess.run([CLI, "bake", str(src), "-o", str(tmp_path / "o"), "--face-size", "5000"],
                       capture_output=True, text=True)
    assert p.returncode == 1 and "face_size must be in 1..4096" in p.stderr, p.stderr
    with pytest.raises(ValueError, match=r"face_size must be in 1\.\.4096"):
        ib.check_options(face_size=5000)


def test_an_option_of_the_other_method_warns_on_both_surfaces(tmp_path):
    src = tmp_path / "s.exr"
    ib.write_exr(str(src), __import__("numpy").full((16, 32, 3), 0.5, "float32"))
    p = subprocess.run([CLI, "bake", str(src), "-o", str(tmp_path / "o"), "--face-size", "8", "--rings", "4", "-q"],
                       capture_output=True, text=True)
    assert p.returncode == 0 and "--rings applies to --specular-method fis only: ignored" in p.stderr, p.stderr
    m = ib.bake(__import__("numpy").full((16, 32, 3), 0.5, "float32"), None, face_size=8, eps=0.3,
                specular_method="fis")["manifest"]
    assert "eps applies to specular_method hierarchical only: ignored" in m["warnings"]


def test_presets_are_listed_once_in_the_table():
    """The presets row's choices are the preset table's names (the CLI's
    help and the add-on's engine toggles are made from them)."""
    row = [r for r in ROWS if r["name"] == "presets"][0]
    assert [c["value"] for c in row["choices"]] == [p["name"] for p in ib.presets()]
    assert "three" in subprocess.run([CLI, "bake", "--help"], capture_output=True, text=True).stdout


if __name__ == "__main__":
    sys.exit(pytest.main([__file__]))


def test_rotation_turns_the_world_about_its_up_axis():
    """The worked example of a new option (one row, bake/options.cpp, plus
    its use, bake.cpp's orient()): a turn by whole texels is the source's
    columns shifted (Blender's Mapping node, Point, Z: direction d shows
    L(Rz d), so +45 degrees on a 64-texel-wide source reads 8 columns on)."""
    np = pytest.importorskip("numpy")
    src = np.random.default_rng(1).random((32, 64, 3), dtype=np.float32) + 0.1
    turned = ib.bake(src, None, face_size=16, mip_count=3, rotation=45.0, lut=False)
    shifted = ib.bake(np.ascontiguousarray(np.roll(src, 8, axis=1)), None, face_size=16, mip_count=3, lut=False)
    for a, b in zip(turned["specular"] + [turned["irradiance"]], shifted["specular"] + [shifted["irradiance"]]):
        np.testing.assert_allclose(a, b, rtol=2e-6)
    np.testing.assert_allclose(turned["sh9"][:, 0], shifted["sh9"][:, 0], rtol=1e-5)
    assert turned["manifest"]["options"]["rotation_degrees"] == 45.0
    assert "rotation_degrees" not in shifted["manifest"]["options"]  # an unturned bake's manifest is as before
    with pytest.raises(ValueError, match=r"rotation must be in -360\.\.360"):
        ib.check_options(rotation=400.0)
