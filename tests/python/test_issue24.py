"""Issue 24's defects (E1..E15 of the third hostile round), each reproduced
through the CLI. The files come from tests/hostile/corpus.py's generators
(the corpus holds the same families)."""
import fcntl
import json
import os
import shutil
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "hostile"))
import corpus  # noqa: E402

CLI = os.environ.get("IBLBAKE_CLI") or os.path.join(HERE, "..", "..", "build", "native", "iblbake")
SMALL = ["--face-size", "16", "--irradiance-size", "8", "--lut-size", "16", "--mips", "3"]


def bake(src, out, *extra, cache=None, timeout=120):
    """The CLI's bake with SMALL's sizes, less those `extra` gives itself."""
    small = [a for i, a in enumerate(SMALL) if SMALL[i - (i % 2)] not in extra]
    args = [CLI, "bake", str(src), "-o", str(out), *small, *extra]
    args += ["--cache-dir", str(cache)] if cache else ["--no-cache"]
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout)


def manifest(out):
    with open(os.path.join(out, "manifest.json")) as f:
        return json.load(f)


def one_line_error(r, *words):
    errors = [ln for ln in r.stderr.strip().splitlines() if not ln.startswith("iblbake: warning:")]
    assert r.returncode == 1 and len(errors) == 1 and errors[0].startswith("iblbake: error:"), r.stderr
    for w in words:
        assert w in errors[0], errors[0]
    return errors[0]


def write(path, data):
    with open(path, "wb") as f:
        f.write(data)
    return path


# --- E1: EXR channels ------------------------------------------------------------------------------

ORANGE = (0.9, 0.3, 0.05)


@pytest.mark.parametrize("name", ["blender_multilayer", "layer_diffuse", "lowercase_rgb"])
def test_e1_layer_and_lowercase_channels_bake_as_colour(tmp_path, name):
    src = write(tmp_path / "src.exr", corpus.LOOKS_RIGHT_EXR[name]())
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(manifest(tmp_path / "out")["mean_radiance"], ORANGE, rtol=1e-3)


@pytest.mark.parametrize("name", ["alpha_only", "depth_only", "aov_only", "z_and_depth", "two_layers"])
def test_e1_no_colour_is_a_clear_refusal(tmp_path, name):
    src = write(tmp_path / "src.exr", corpus.LOOKS_RIGHT_EXR[name]())
    one_line_error(bake(src, tmp_path / "out"), str(src))


def test_e1_luminance_only_bakes_grey_with_a_warning(tmp_path):
    src = write(tmp_path / "src.exr", corpus.exr_bytes(channels=("Y",), value=0.5))
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert any("luminance" in w for w in manifest(tmp_path / "out")["warnings"])


def test_e1_multipart_depth_first_bakes_the_colour_part(tmp_path):
    src = tmp_path / "src.exr"
    corpus.make_multipart_depth_first(str(src))
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(manifest(tmp_path / "out")["mean_radiance"], ORANGE, rtol=1e-3)


# --- E3 and E11: the output folder during a bake ------------------------------------------------

def slow_bake_args(tmp_path):
    """A source and options that bake for a few seconds on this machine."""
    src = tmp_path / "big.exr"
    corpus.make_gradient_exr(str(src), 1024, 512)
    return src, ["--face-size", "256", "--irradiance-size", "32", "--lut-size", "64"]


def bake_while(tmp_path, out, action):
    """Bakes into `out` and runs `action()` once the staging folder exists."""
    src, opts = slow_bake_args(tmp_path)
    p = subprocess.Popen([CLI, "bake", str(src), "-o", str(out), *opts, "--no-cache"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not any(".iblbake-" in n for n in os.listdir(os.path.dirname(out))) and p.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    action()
    _, err = p.communicate(timeout=300)
    return p.returncode, err


def test_e3_a_file_added_to_the_bake_folder_during_a_bake_is_kept(tmp_path, src_exr=None):
    out = tmp_path / "out"
    src = write(tmp_path / "s.exr", corpus.exr_bytes())
    assert bake(src, out).returncode == 0
    rc, err = bake_while(tmp_path, out, lambda: write(out / "notes.txt", b"notes"))
    assert (out / "notes.txt").read_bytes() == b"notes", "the user's file was deleted"
    assert rc == 1 and "notes.txt" in err, err


def test_e3_a_folder_made_at_the_output_path_during_a_bake_is_kept(tmp_path):
    out = tmp_path / "out"

    def make():
        os.mkdir(out)
        write(out / "thesis.tex", b"mine")
    rc, err = bake_while(tmp_path, out, make)
    assert (out / "thesis.tex").read_bytes() == b"mine"
    assert rc == 1 and str(out) in err, err


def test_e3_negative_control_an_untouched_folder_is_replaced(tmp_path):
    out = tmp_path / "out"
    rc, err = bake_while(tmp_path, out, lambda: None)
    assert rc == 0, err
    assert not [n for n in os.listdir(tmp_path) if ".iblbake-" in n]


def test_e11_a_locked_staging_folder_of_another_pid_namespace_is_not_stale(tmp_path):
    p = subprocess.Popen(["true"])
    p.wait()
    staging = tmp_path / (".other.iblbake-%d-0123abcd" % p.pid)  # a PID this namespace does not have
    staging.mkdir()
    write(staging / "specular_0.exr", b"half written")
    fd = os.open(staging, os.O_RDONLY | os.O_DIRECTORY)
    fcntl.flock(fd, fcntl.LOCK_EX)  # as the running bake holds it
    try:
        assert bake(write(tmp_path / "s.exr", corpus.exr_bytes()), tmp_path / "out").returncode == 0
        assert (staging / "specular_0.exr").exists(), "a running bake's staging folder was deleted"
    finally:
        os.close(fd)
    # Its lock released (the bake ended), it is stale: the next bake removes it.
    assert bake(tmp_path / "s.exr", tmp_path / "out").returncode == 0
    assert not staging.exists()


# --- E4 and E5: the LUT cache ---------------------------------------------------------------------

def cache_entries(cache, ext):
    return sorted(n for n in os.listdir(cache) if n.endswith(ext))


def test_e4_swapped_encoded_entries_are_not_used(tmp_path):
    cache = tmp_path / "cache"
    src = write(tmp_path / "s.exr", corpus.exr_bytes())
    assert bake(src, tmp_path / "a", "--format", "exr,png", cache=cache).returncode == 0
    enc = cache_entries(cache, ".enc")
    exr = [n for n in enc if "-exr-" in n]
    png = [n for n in enc if "-png-" in n]
    assert len(exr) == 1 and len(png) == 1, enc
    os.rename(cache / exr[0], cache / "x")
    os.rename(cache / png[0], cache / exr[0])
    os.rename(cache / "x", cache / png[0])
    r = bake(src, tmp_path / "b", "--format", "exr,png", cache=cache)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "b" / "brdf_lut.exr").read_bytes()[:4] == b"\x76\x2f\x31\x01", "PNG bytes in brdf_lut.exr"
    assert (tmp_path / "b" / "brdf_lut.png").read_bytes()[:4] == b"\x89PNG"


def test_e4_swapped_lut_entries_are_not_used(tmp_path):
    cache = tmp_path / "cache"
    src = write(tmp_path / "s.exr", corpus.exr_bytes())
    for model in ("karis", "height-correlated"):
        assert bake(src, tmp_path / model, "--lut-model", model, cache=cache).returncode == 0
    luts = cache_entries(cache, ".lut")
    assert len(luts) == 2, luts
    os.rename(cache / luts[0], cache / "x")
    os.rename(cache / luts[1], cache / luts[0])
    os.rename(cache / "x", cache / luts[1])
    r = bake(src, tmp_path / "again", "--lut-model", "karis", cache=cache)
    assert r.returncode == 0, r.stderr
    assert manifest(tmp_path / "again")["brdf_lut"]["from_cache"] is False
    assert (tmp_path / "again" / "brdf_lut.exr").read_bytes() == (tmp_path / "karis" / "brdf_lut.exr").read_bytes()


@pytest.mark.parametrize("ext", [".lut", ".enc"])
def test_e5_a_fifo_named_like_a_cache_entry_does_not_hang(tmp_path, ext):
    cache = tmp_path / "cache"
    src = write(tmp_path / "s.exr", corpus.exr_bytes())
    assert bake(src, tmp_path / "a", cache=cache).returncode == 0
    for name in cache_entries(cache, ext):
        os.remove(cache / name)
        os.mkfifo(cache / name)
    try:
        r = bake(src, tmp_path / "b", cache=cache, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("the bake hung on a FIFO in the cache")
    assert r.returncode == 0, r.stderr


# --- E6, E14: presets -----------------------------------------------------------------------------

@pytest.mark.parametrize("preset", ["three", "filament"])
def test_e6_presets_that_would_hold_the_mirror_level_alone_are_refused(tmp_path, preset):
    src = write(tmp_path / "s.exr", corpus.exr_bytes())
    one_line_error(bake(src, tmp_path / "out", "--preset", preset), preset, "of 32 or more")
    r = bake(src, tmp_path / "ok", "--preset", preset, "--face-size", "32")
    assert r.returncode == 0, r.stderr
    levels = manifest(tmp_path / "ok")["presets"][preset]["specular"]
    assert levels[0]["roughness"] == 0 and levels[-1]["roughness"] == 1


@pytest.mark.parametrize("spec", ["khronos:rgba32f:rgba16f", "khronos:zstd:nozstd", "khronos:", "", "three,,khronos"])
def test_e14_contradictory_or_empty_presets_are_refused(tmp_path, spec):
    src = write(tmp_path / "s.exr", corpus.exr_bytes())
    one_line_error(bake(src, tmp_path / "out", "--preset", spec, "--face-size", "32"))


def test_e14_clamping_is_noted_on_stderr(tmp_path):
    src = write(tmp_path / "s.exr", corpus.exr_bytes(value=1e6))
    r = bake(src, tmp_path / "out", "--preset", "khronos:e5b9g9r9,babylon", "--face-size", "32")
    assert r.returncode == 0, r.stderr
    notes = [ln for ln in r.stderr.splitlines() if "clamped" in ln]
    assert notes and all(ln.startswith("iblbake: warning:") for ln in notes), r.stderr


# --- E7: orientation ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(corpus.HDR_ORIENTATIONS))
def test_e7_radiance_hdr_orientation_is_applied(tmp_path, name):
    ref = write(tmp_path / "ref.hdr", corpus.hdr_oriented("-Y H +X W"))
    src = write(tmp_path / "src.hdr", corpus.hdr_oriented(corpus.HDR_ORIENTATIONS[name]))
    assert bake(ref, tmp_path / "ref").returncode == 0
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(manifest(tmp_path / "out")["sh9"], manifest(tmp_path / "ref")["sh9"], rtol=1e-5,
                               atol=1e-6)


@pytest.mark.parametrize("orientation", [2, 3, 5, 6, 7, 8])
def test_e7_tiff_orientation_is_applied(tmp_path, orientation):
    src, ref = str(tmp_path / "src.tif"), str(tmp_path / "ref.exr")
    corpus.make_oriented_tiff(src, orientation)
    corpus.reoriented_tiff(ref, orientation)
    assert bake(ref, tmp_path / "ref").returncode == 0
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(manifest(tmp_path / "out")["sh9"], manifest(tmp_path / "ref")["sh9"], rtol=1e-4,
                               atol=1e-6)


# --- E9: RGBE's range -----------------------------------------------------------------------------

def test_e9_source_hdr_clamps_to_rgbe_largest_not_black(tmp_path):
    import iblbake_core as ib
    src = write(tmp_path / "s.exr", corpus.exr_bytes(value=3.0e38))
    r = bake(src, tmp_path / "out", "--preset", "source")
    assert r.returncode == 0, r.stderr
    img = ib.read_image(str(tmp_path / "out" / "source" / "source.hdr"))
    assert float(img.min()) > 1e38, "texels above RGBE's range were written black"
    written = {w["file"]: w for w in manifest(tmp_path / "out")["presets"]["source"]["written"]}
    assert written["source.hdr"]["clamped_texels"] == 64 * 32
    assert "clamped" in r.stderr


# --- E10: alpha -----------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt", ["png", "tif", "tga"])
def test_e10_straight_alpha_is_applied_as_cycles_does(tmp_path, fmt):
    """A straight alpha (PNG, Targa) multiplies the colour; a TIFF's associated alpha is read as stored (the
    TIFF is written by corpus.make_alpha_tif: oiiotool 2.4 and 2.5 store different colours for it)."""
    src = str(tmp_path / ("a." + fmt))
    if fmt == "tif":
        corpus.make_alpha_tif(src)
    else:
        png = str(tmp_path / "a.png")
        corpus.make_alpha_png(png)
        if fmt == "tga":  # Targa keeps it straight
            subprocess.run(["oiiotool", "--iconfig", "oiio:UnassociatedAlpha", "1", png, "-o", src], check=True,
                           capture_output=True)
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(manifest(tmp_path / "out")["mean_radiance"], corpus.ALPHA_PNG_RADIANCE, rtol=0.02)


# --- E15: output names (the add-on's bpy-free core; bake_world.py in tests/blender) -------------------

def addon_names():
    sys.path.insert(0, os.path.join(HERE, "..", "..", "addon"))
    from iblbake.core import names
    return names


def test_e15_names_that_leave_nothing_stay_distinct():
    names = addon_names()
    got = [names.safe_component(n) for n in ("\U0001F600\U0001F30D", "..", ".", "\U0001F30D")]
    assert len(set(got)) == 4 and not {".", "..", ""} & set(got), got
    assert names.safe_component("My World") == "My_World"  # names that keep something are unchanged


def test_e15_an_unknown_placeholder_is_refused():
    names = addon_names()
    with pytest.raises(names.TemplateError, match=r"\{unknown\}"):
        names.fill_template("//ibl/{unknown}", "scene", "Scene", "World")
    assert names.fill_template("//ibl/{world}", "b", "s", "World 1") == "//ibl/World_1"


# --- E12: a black world; E13: messages ------------------------------------------------------------

def test_e12_a_black_world_warns(tmp_path):
    src = write(tmp_path / "s.exr", corpus.exr_bytes(value=0.0))
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert any("black" in w for w in manifest(tmp_path / "out")["warnings"])
    assert "iblbake: warning: the world is black" in r.stderr


def test_e13_manifest_extra_errors_are_one_line():
    r = subprocess.run([sys.executable, "-c", "import iblbake_core as ib, numpy as np\n"
                        "try:\n    ib.bake(np.ones((32, 64, 3), np.float32), None, face_size=8, "
                        "manifest_extra={'a': object()})\nexcept ValueError as e:\n    print(repr(str(e)))"],
                       capture_output=True, text=True, env=dict(os.environ))
    assert r.returncode == 0 and "manifest_extra" in r.stdout, r.stdout + r.stderr
    assert "Traceback" not in r.stdout and "\\n" not in r.stdout.strip(), r.stdout


@pytest.mark.parametrize("name, data, words", [
    ("xyz.hdr", corpus.hdr_bytes(64, 32).replace(b"32-bit_rle_rgbe", b"32-bit_rle_xyze"), "XYZ"),
    ("texture.dds", b"DDS " + bytes(300), "not a lat-long source"),
], ids=["xyze_hdr", "dds"])
def test_e13_unreadable_kinds_are_named(tmp_path, name, data, words):
    src = write(tmp_path / name, data)
    one_line_error(bake(src, tmp_path / "out"), str(src), words)


@pytest.mark.parametrize("make, words", [(corpus.make_deep_exr, "a deep OpenEXR file"),
                                         (lambda p: write(p, corpus.exr_subsampled_bytes()), "is subsampled, which")],
                         ids=["deep", "subsampled"])
def test_e13_deep_and_subsampled_exr_are_named(tmp_path, make, words):
    src = str(tmp_path / "src.exr")
    make(src)
    one_line_error(bake(src, tmp_path / "out"), src, words)


def test_e13_a_full_disk_names_the_output_folder_and_the_reason(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("a small tmpfs needs root to mount")
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=600k", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("mount -t tmpfs is not permitted here")
    try:
        src = write(tmp_path / "s.exr", corpus.exr_bytes())
        r = bake(src, mnt / "out", "--face-size", "128", "--preset", "filament,khronos:rgba32f,bevy")
        line = one_line_error(r)
        assert ".iblbake-" not in line and str(mnt / "out") in line, line
        assert "No space left on device" in line, line
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
