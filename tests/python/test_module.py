"""The Python module: arguments, results, errors, files, the GIL."""
import hashlib
import json
import math
import os
import threading
import time

import numpy as np
import pytest

import iblbake_core as ib

SMALL = dict(face_size=16, irradiance_size=8, lut_size=16)


def latlong(h=32, w=64, value=1.0, channels=3):
    return np.full((h, w, channels), value, dtype=np.float32)


def test_constant_world_gives_one_everywhere():
    r = ib.bake(latlong(), **SMALL)
    assert r["irradiance"].shape == (6, 8, 8, 3)
    np.testing.assert_allclose(r["irradiance"], 1.0, atol=1e-3)
    assert len(r["specular"]) == 5
    for level in r["specular"]:
        np.testing.assert_allclose(level, 1.0, atol=1e-3)
    assert r["roughness"] == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert r["brdf_lut"].shape == (16, 16, 3)
    sh = r["sh9"]
    assert sh.shape == (3, 9)
    np.testing.assert_allclose(sh[:, 0], 0.282095 * 4 * math.pi, rtol=1e-6)
    np.testing.assert_allclose(sh[:, 1:], 0.0, atol=1e-9)


def test_alpha_channel_is_dropped():
    rgb = ib.bake(latlong(channels=3), **SMALL)
    rgba = ib.bake(latlong(channels=4), **SMALL)
    np.testing.assert_array_equal(rgb["irradiance"], rgba["irradiance"])


@pytest.mark.parametrize(
    "image, message",
    [
        (np.ones((8, 16, 3), dtype=np.float64), "float32"),
        (np.ones((8, 16), dtype=np.float32), "shape"),
        (np.ones((8, 16, 2), dtype=np.float32), "shape"),
        (np.ones((0, 16, 3), dtype=np.float32), "1 x 1"),
        ([[1.0]], "numpy"),
    ],
)
def test_wrong_dtype_or_shape_raises_value_error(image, message):
    with pytest.raises(ValueError, match=message):
        ib.bake(image)


@pytest.mark.parametrize(
    "options, message",
    [
        (dict(face_size=0), "face_size"),
        (dict(lut_model="phong"), "phong"),
        (dict(formats=["tiff"]), "tiff"),
        (dict(png_encoding="rgbe"), "rgbe"),
        (dict(no_such_option=1), "no_such_option"),
        (dict(face_size="big"), "face_size"),
        (dict(progress=5), "callable"),
    ],
)
def test_bad_options_raise_value_error(options, message):
    with pytest.raises(ValueError, match=message):
        ib.bake(latlong(), **options)


def test_nan_inf_negative_are_counted_and_zeroed():
    img = latlong()
    img[1, 1, 0] = np.nan
    img[2, 2, 1] = np.inf
    img[3, 3, 2] = -np.inf
    img[4, 4, 0] = -1.0
    r = ib.bake(img, **SMALL)
    assert r["bad_input"] == {"nan": 1, "inf": 2, "negative": 1, "pixels": 4}
    assert r["manifest"]["bad_input"]["pixels"] == 4
    for level in [r["irradiance"], *r["specular"]]:
        assert np.isfinite(level).all()
    with pytest.raises(ValueError, match="bad pixels"):
        ib.bake(img, strict=True, **SMALL)


def test_input_array_is_not_modified():
    img = latlong()
    img[0, 0, 0] = np.nan
    ib.bake(img, **SMALL)
    assert np.isnan(img[0, 0, 0])


def test_bad_rows_cleaned_without_copy_match_a_zeroed_source():
    # The array is read in place; the rows holding bad values are cleaned in a
    # side store. The result must be the bake of the zeroed image, bit for bit,
    # for RGB (in place) and RGBA (copied) arrays alike.
    rng = np.random.default_rng(3)
    img = rng.uniform(0.1, 2.0, (64, 128, 3)).astype(np.float32)
    img[5, 7, 0], img[5, 90, 2], img[40, 3, 1], img[63, 127, 0] = np.nan, np.inf, -2.0, -np.inf
    zeroed = np.nan_to_num(img, nan=0.0, posinf=0.0, neginf=0.0).clip(min=0.0)
    opts = dict(face_size=32, irradiance_size=8, lut=False)
    got, want = ib.bake(img, **opts), ib.bake(zeroed, **opts)
    rgba = ib.bake(np.concatenate([img, np.ones_like(img[..., :1])], axis=2), **opts)
    for r in (got, rgba):
        assert r["bad_input"]["pixels"] == 4
        assert np.array_equal(r["irradiance"], want["irradiance"])
        for a, b in zip(r["specular"], want["specular"]):
            assert np.array_equal(a, b)
        assert np.array_equal(r["sh9"], want["sh9"])
    assert np.isnan(img[5, 7, 0]) and img[40, 3, 1] == -2.0  # the caller's array is untouched


def test_source_sha256_only_when_written_or_given(tmp_path):
    img = latlong()
    assert ib.bake(img, **SMALL)["manifest"]["source"]["sha256"] is None
    import hashlib
    want = hashlib.sha256(img.tobytes()).hexdigest()
    m = ib.bake(img, str(tmp_path / "a"), **SMALL)["manifest"]
    assert m["source"]["sha256"] == want
    given = "ab" * 32
    assert ib.bake(img, str(tmp_path / "b"), source_sha256=given, **SMALL)["manifest"]["source"]["sha256"] == given
    with pytest.raises(ValueError, match="64 hex digits"):
        ib.bake(img, source_sha256="xyz", **SMALL)


def test_writes_files_atomically_and_returns_manifest(tmp_path):
    out = tmp_path / "bake"
    r = ib.bake(latlong(), str(out), formats=["exr", "png"], **SMALL)
    m = r["manifest"]
    assert json.loads((out / "manifest.json").read_text()) == m
    assert m["contract"] == 1
    assert m["source"]["path"] is None and len(m["source"]["sha256"]) == 64
    for name in m["encodings"]:
        assert (out / name).is_file(), name
    # A failing bake into the same folder leaves it as it was.
    before = sorted(os.listdir(out))
    with pytest.raises(ValueError):
        ib.bake(latlong(), str(out), face_size=-1)
    with pytest.raises(RuntimeError):
        ib.bake_file(str(tmp_path / "missing.exr"), str(out))
    assert sorted(os.listdir(out)) == before
    assert [p.name for p in tmp_path.iterdir()] == ["bake"]


def test_refuses_an_unrelated_folder_and_empty_path(tmp_path):
    precious = tmp_path / "precious"
    precious.mkdir()
    (precious / "notes.txt").write_text("keep")
    with pytest.raises(RuntimeError, match="refusing"):
        ib.bake(latlong(), str(precious), **SMALL)
    assert (precious / "notes.txt").read_text() == "keep"
    with pytest.raises(ValueError, match="non-empty"):
        ib.bake(latlong(), "", **SMALL)
    with pytest.raises(ValueError, match="exposure"):
        ib.bake(latlong(), str(tmp_path / "x"), exposure=float("nan"), **SMALL)


def test_progress_and_cancel(tmp_path):
    seen = []
    ib.bake(latlong(), progress=lambda stage, f: seen.append((stage, f)) or True, **SMALL)
    assert seen[0][1] == 0.0 and seen[-1] == ("done", 1.0)
    assert all(b[1] >= a[1] for a, b in zip(seen, seen[1:]))
    out = tmp_path / "cancelled"
    with pytest.raises(ib.Cancelled):
        ib.bake(latlong(), str(out), progress=lambda stage, f: f < 0.5, **SMALL)
    assert not out.exists()


def test_gil_is_released_during_the_bake():
    """A Python thread keeps running while the native bake works."""
    img = np.random.default_rng(1).random((256, 512, 3), dtype=np.float32)
    ticks = []
    done = threading.Event()

    def ticker():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    start = time.perf_counter()
    ib.bake(img, face_size=64, irradiance_size=16, lut=False, threads=1)
    end = time.perf_counter()
    done.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    # With the GIL held the ticker could not run at all during the bake.
    assert len(during) >= 5, (len(during), end - start)


def test_brdf_lut_function_matches_bake():
    lut = ib.brdf_lut(16)
    r = ib.bake(latlong(), **SMALL)
    np.testing.assert_array_equal(lut, r["brdf_lut"])
    a, b = ib.integrate_brdf(0.5, 0.5)
    assert abs(a - 0.7285345) < 2e-4 and abs(b - 0.0185464) < 2e-4


def test_lut_cache_dir_reuses_the_lut(tmp_path):
    a = ib.bake(latlong(), lut_cache_dir=str(tmp_path), specular=False, irradiance=False, lut_size=8)
    b = ib.bake(latlong(), lut_cache_dir=str(tmp_path), specular=False, irradiance=False, lut_size=8)
    assert not a["manifest"]["brdf_lut"]["from_cache"] and b["manifest"]["brdf_lut"]["from_cache"]
    np.testing.assert_array_equal(a["brdf_lut"], b["brdf_lut"])
    assert len(list(tmp_path.iterdir())) == 1


def test_lut_cache_dir_also_keeps_the_written_lut_file(tmp_path):
    cache = tmp_path / "cache"
    for out in ("a", "b"):
        ib.bake(latlong(), str(tmp_path / out), lut_cache_dir=str(cache), specular=False, irradiance=False, lut_size=8)
    assert len(list(cache.glob("*.enc"))) == 1  # the second bake copied the first one's file
    data = (tmp_path / "b" / "brdf_lut.exr").read_bytes()
    assert data == (tmp_path / "a" / "brdf_lut.exr").read_bytes()
    m = json.loads((tmp_path / "b" / "manifest.json").read_text())
    assert m["files"]["brdf_lut.exr"]["sha256"] == hashlib.sha256(data).hexdigest()


def test_orientation_helpers_follow_the_contract():
    # Blender +X, +Z, -Y -> engine faces +X (0), +Y (2), +Z (4).
    for blender, face in [((1, 0, 0), 0), ((0, 0, 1), 2), ((0, -1, 0), 4)]:
        x, y, z = blender
        f, s, t = ib.direction_to_face(x, z, -y)
        assert (f, s, t) == (face, 0.5, 0.5)
    d = ib.texel_direction(4, 0, 0, 2)  # +Z face, top-left texel: -X and +Y
    assert d[0] < 0 and d[1] > 0 and d[2] > 0


def test_read_image_linearises_8bit_png(tmp_path):
    img = latlong(8, 16, 0.5)
    out = tmp_path / "b"
    ib.bake(img, str(out), formats=["png"], **SMALL)
    png = ib.read_image(str(out / "specular_0.png"))
    # 0.5 linear -> sRGB 8-bit -> back to linear.
    assert abs(float(png[0, 20, 0]) - 0.5) < 0.01


def test_image_format_names_the_reader_a_file_gets(tmp_path):
    """image_format(path): the format read_image takes a file for (its first
    bytes first, then its extension) and whether this build reads it; the
    build's module has the OpenImageIO plugin, so a Radiance .hdr is readable
    (a wheel's is not: scripts/check_wheels.sh checks that side)."""
    ib.bake(latlong(8, 16, 0.5), str(tmp_path / "b"), formats=["exr", "png"], **SMALL)
    assert ib.image_format(str(tmp_path / "b" / "specular_0.exr")) == ("openexr", True)
    assert ib.image_format(str(tmp_path / "b" / "specular_0.png")) == ("png", True)
    hdr = tmp_path / "named.exr"  # the first bytes win over the extension
    hdr.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n\x80\x80\x80\x80")
    assert ib.image_format(str(hdr)) == ("hdr", True)
    assert ib.image_format(str(tmp_path / "missing.tif")) == ("tiff", True)
    (tmp_path / "notes.txt").write_text("not an image")
    assert ib.image_format(str(tmp_path / "notes.txt")) == ("", False)
