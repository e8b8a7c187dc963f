"""The add-on's bpy-free core (addon/iblbake/core), without Blender."""
import json
import math
import os
import sys
import threading

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
import iblbake_core as ib  # noqa: E402
from iblbake.core import needs as N  # noqa: E402
from iblbake.core import pipeline  # noqa: E402
from iblbake.core.job import BakeJob  # noqa: E402
from iblbake.core.settings import BakeSettings  # noqa: E402
from iblbake.core.world import COLOR, IMAGE, RENDER, Mapping, WorldSource, euler_xyz_matrix, prepare_pixels, srgb_to_linear  # noqa: E402,E501


def test_levels_cover_the_roughness_an_engine_reads():
    # 9 levels, r_m = m / 8: lod = 8 r, blended between floor and ceil.
    assert N.levels_for_roughness((0.5, 0.5), 9) == (4, 4)
    assert N.levels_for_roughness((0.3, 0.55), 9) == (2, 5)
    assert N.levels_for_roughness((0.0, 1.0), 9) == (0, 8)
    assert N.levels_for_roughness((0.2, 0.2), 6) == (1, 1)
    assert N.levels_for_roughness((0.3, 0.3), 6) == (1, 2)
    assert N.levels_for_roughness((-1, 3), 6) == (0, 5)
    assert N.levels_for_roughness((0.4, 0.4), 1) == (0, 0)


def test_principled_rules():
    kinds = lambda lobes: sorted(lb.kind for lb in lobes)  # noqa: E731
    assert kinds(N.principled_lobes("m", (0.5, 0.5), (0, 0), (0.5, 0.5))) == ["diffuse", "glossy"]
    assert kinds(N.principled_lobes("m", (0.5, 0.5), (1, 1), (0.5, 0.5))) == ["glossy"]       # metal
    assert kinds(N.principled_lobes("m", (0.5, 0.5), (0, 0), (0, 0))) == ["diffuse"]         # no specular
    assert kinds(N.principled_lobes("m", (0.5, 0.5), (0, 1), (0, 0))) == ["diffuse", "glossy"]  # textured metallic
    coat = N.principled_lobes("m", (0.8, 0.8), (1, 1), (0.5, 0.5), coat=(1, 1), coat_roughness=(0.05, 0.05))
    assert sorted(lb.roughness for lb in coat if lb.kind == "glossy") == [(0.05, 0.05), (0.8, 0.8)]
    assert N.node_lobes("ShaderNodeEmission", "e") == []
    assert [lb.kind for lb in N.node_lobes("ShaderNodeBsdfDiffuse", "d")] == ["diffuse"]
    unknown = N.node_lobes("ShaderNodeSomethingNew", "x")
    assert {lb.kind for lb in unknown} == {"diffuse", "glossy"} and all(lb.roughness == N.FULL for lb in unknown)


def test_needs_from_lobes():
    n = N.needs_from_lobes([N.Lobe("diffuse")], 9, objects=1)
    assert (n.irradiance, n.specular, n.lut) == (True, False, False)
    assert "glossy" in n.reasons["specular"]
    n = N.needs_from_lobes([N.Lobe("glossy", (0.2, 0.3)), N.Lobe("glossy", (0.6, 0.6))], 9, objects=2)
    assert (n.irradiance, n.specular, n.levels, n.roughness) == (False, True, (1, 5), (0.2, 0.6))
    assert "specular_levels" in n.reasons
    assert N.needs_from_lobes([], 9, objects=0).analysed is False  # nothing to inspect: bake everything


def test_native_options_apply_needs_only_with_auto_skip():
    needs = N.needs_from_lobes([N.Lobe("glossy", (0.5, 0.5))], 9, objects=1)
    s = BakeSettings(out_dir="x")
    o = pipeline.native_options(s, needs)
    assert o["irradiance"] is False and o["specular"] and (o["first_level"], o["last_level"]) == (4, 4)
    assert "irradiance" in o["skip_reasons"] and "specular_levels" in o["skip_reasons"]
    s.auto_skip = False
    o = pipeline.native_options(s, needs)
    assert o["irradiance"] and "first_level" not in o and "skip_reasons" not in o


def test_euler_matches_blender_convention():
    # Blender's XYZ Euler: rotate about X, then Y, then Z (matrix Rz Ry Rx).
    rz = euler_xyz_matrix((0, 0, math.pi / 2))
    np.testing.assert_allclose(rz @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    m = euler_xyz_matrix((0.3, -0.7, 1.1))
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(m, euler_xyz_matrix((0, 0, 1.1)) @ euler_xyz_matrix((0, -0.7, 0))
                               @ euler_xyz_matrix((0.3, 0, 0)), atol=1e-12)


def test_mapping_types_are_blenders_formulas():
    d = np.array([0.3, -0.5, 0.8])
    loc, rot, scale = (0.1, 0.2, -0.3), (0.2, 0.4, -0.6), (2.0, 0.5, 1.5)
    r = euler_xyz_matrix(rot)
    for kind, expect in [("POINT", r @ (d * scale) + loc), ("VECTOR", r @ (d * scale)),
                         ("TEXTURE", (r.T @ (d - loc)) / scale), ("NORMAL", r @ (d / scale))]:
        a, b = Mapping(kind, loc, rot, scale).affine()
        np.testing.assert_allclose(a @ d + b, expect, atol=1e-12, err_msg=kind)
    assert Mapping().is_identity() and not Mapping(rotation=(0, 0, 0.1)).is_identity()


def test_prepare_pixels_flips_linearises_rotates_and_scales():
    h, w = 8, 16
    rng = np.random.default_rng(1)
    top_down = rng.random((h, w, 3)).astype(np.float32)
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = top_down[::-1]  # Blender stores rows bottom-up
    src = WorldSource(IMAGE, is_float=True, strength=2.0)
    np.testing.assert_allclose(prepare_pixels(src, rgba.reshape(-1), w, h), 2 * top_down, rtol=1e-6)
    byte = WorldSource(IMAGE, is_float=False, colorspace="sRGB")
    np.testing.assert_allclose(prepare_pixels(byte, rgba.reshape(-1), w, h), srgb_to_linear(top_down), rtol=1e-6)
    assert srgb_to_linear(np.float32([0.5]))[0] == pytest.approx(0.21404, abs=1e-5)
    turned = WorldSource(IMAGE, mapping=Mapping(rotation=(0, 0, math.pi / 2)))
    out = prepare_pixels(turned, rgba.reshape(-1), w, h, remap=ib.remap_latlong)
    np.testing.assert_allclose(out, np.roll(top_down, w // 4, axis=1), atol=1e-5)
    odd = WorldSource(IMAGE, is_float=False, colorspace="Filmic Log")
    with pytest.raises(ValueError):
        odd.check_colorspace()


def small(tmp_path, **kw):
    kw.setdefault("out_dir", str(tmp_path / "out"))
    return BakeSettings(face_size=8, irradiance_size=4, lut_size=8, lut_cache_dir=str(tmp_path / "cache"), **kw)


def sky(h=16, w=32):
    rng = np.random.default_rng(3)
    return (0.5 + rng.random((h, w, 3))).astype(np.float32)


def test_pipeline_skips_an_unchanged_world_and_rebakes_a_changed_one(tmp_path):
    src, px = WorldSource(IMAGE, world="w"), sky()
    first = pipeline.bake(src, px, small(tmp_path))
    assert first.status == "baked" and first.manifest["blender"]["content_hash"] == first.content_hash
    again = pipeline.bake(src, px.copy(), small(tmp_path))
    assert again.status == "unchanged" and again.content_hash == first.content_hash
    assert "unchanged" in again.summary()
    changed = px.copy()
    changed[3, 4, 1] += 0.25
    assert pipeline.bake(src, changed, small(tmp_path)).status == "baked"
    assert pipeline.bake(src, changed, small(tmp_path, lut_model="multiscatter")).status == "baked"
    assert pipeline.bake(src, changed, small(tmp_path, lut_model="multiscatter", force=True)).status == "baked"
    # A damaged folder (a file gone) is baked again.
    os.remove(tmp_path / "out" / "specular_1.exr")
    assert pipeline.bake(src, changed, small(tmp_path, lut_model="multiscatter")).status == "baked"


def test_pipeline_plain_colour_and_errors(tmp_path):
    rep = pipeline.bake(WorldSource(COLOR, color=(0.5, 1.0, 2.0)), None, small(tmp_path))
    m = json.load(open(tmp_path / "out" / "manifest.json"))
    assert rep.status == "baked" and m["blender"]["path"] == "plain_colour" and "constant" in m["timings"]
    with pytest.raises(pipeline.BakeError, match="output folder"):
        pipeline.bake(WorldSource(IMAGE), sky(), BakeSettings())
    with pytest.raises(pipeline.BakeError, match="float32"):
        pipeline.bake(WorldSource(IMAGE), sky().astype(np.float64), small(tmp_path, force=True))
    (tmp_path / "notabake").mkdir()
    (tmp_path / "notabake" / "precious.txt").write_text("keep me")
    with pytest.raises(pipeline.BakeError):
        pipeline.bake(WorldSource(IMAGE), sky(), small(tmp_path, out_dir=str(tmp_path / "notabake")))
    assert (tmp_path / "notabake" / "precious.txt").read_text() == "keep me"


def test_job_cancels_between_stages_and_keeps_the_earlier_bake(tmp_path):
    src = WorldSource(IMAGE)
    pipeline.bake(src, sky(), small(tmp_path))
    before = (tmp_path / "out" / "manifest.json").read_text()
    seen = []
    gate = threading.Event()

    def work(progress):
        def watch(stage, f):
            seen.append(stage)
            if stage == "irradiance":
                job.cancel()
            return progress(stage, f)
        gate.wait(5)
        return pipeline.bake(src, sky() * 2, small(tmp_path), progress=watch)

    job = BakeJob(work).start()
    gate.set()
    assert job.wait(60)
    assert job.cancelled and job.error is None and job.result is None
    assert seen[-1] == "irradiance"
    assert (tmp_path / "out" / "manifest.json").read_text() == before
    assert sorted(os.listdir(tmp_path)) == ["cache", "out"]


def test_a_scene_that_uses_nothing_is_refused_not_emptied(tmp_path):
    src = WorldSource(IMAGE)
    pipeline.bake(src, sky(), small(tmp_path))
    before = (tmp_path / "out" / "manifest.json").read_text()
    only_emission = N.needs_from_lobes([], 9, objects=1)
    with pytest.raises(pipeline.BakeError, match="nothing to bake"):
        pipeline.bake(src, sky() * 3, small(tmp_path), needs=only_emission)
    assert (tmp_path / "out" / "manifest.json").read_text() == before
    assert pipeline.bake(src, sky() * 3, small(tmp_path, auto_skip=False), needs=only_emission).status == "baked"


def test_hash_ignores_what_changes_no_file(tmp_path):
    src, px = WorldSource(IMAGE), sky()
    base = pipeline.bake(src, px, small(tmp_path))
    assert pipeline.bake(src, px, small(tmp_path, exposure=2.0, render_width=64)).status == "unchanged"
    assert pipeline.bake(src, px, small(tmp_path, formats=["exr", "png"])).status == "baked"
    assert pipeline.bake(src, px, small(tmp_path, formats=["exr", "png"], exposure=2.0)).status == "baked"
    assert base.status == "baked"


# --- what the panel says (core/describe.py) and the off-main-thread file read (core/world.py) ---
from iblbake.core import describe as D  # noqa: E402
from iblbake.core.world import FileNotAsBlenderShowsIt, read_file_pixels  # noqa: E402


def test_panel_says_in_words_what_is_skipped_and_why():
    cube = N.needs_from_lobes(N.principled_lobes("Material", (0.5, 0.5), (0, 0), (0.5, 0.5)), 9, 1)
    assert D.needs_sentences(cube, 9, scene_only=True) == [
        "Only 1 of 9 specular levels (level 4): this scene's materials all use roughness 0.5"]
    assert D.needs_sentences(cube, 9, scene_only=False) == [
        "Everything: irradiance, all 9 specular levels, the BRDF LUT"]
    # Engine presets need every level, whatever the scene reads.
    assert D.needs_sentences(cube, 9, True, ("three",)) == ["Everything: the engines ticked (three.js) need every level"]
    metal = N.needs_from_lobes([N.Lobe("glossy", (0.2, 0.6), "m")], 9, 1)
    assert D.needs_sentences(metal, 9, True) == [
        "No irradiance: no visible material is diffuse",
        "Only 5 of 9 specular levels (levels 1-5): this scene's materials use roughness 0.2 to 0.6"]
    assert D.needs_sentences(N.needs_from_lobes([], 9, 0), 9, True) == [
        "Everything: no visible object to read materials from"]


def test_long_paths_keep_their_end():
    path = "/home/someone/projects/a very long project name/renders/ibl/World"
    short = D.shorten_middle(path, 30)
    assert len(short) == 30 and short.endswith("/renders/ibl/World") and short.startswith("/home")
    assert "\u2026" in short
    assert D.shorten_middle("/tmp/x", 30) == "/tmp/x"


def test_bake_files_are_listed_with_sizes_and_levels_grouped(tmp_path):
    for name, size in (("manifest.json", 10), ("preview.png", 20), ("irradiance.exr", 30), ("specular_0.exr", 40),
                       ("specular_1.exr", 50), ("specular_2.exr", 60), ("brdf_lut.exr", 70)):
        (tmp_path / name).write_bytes(b"x" * size)
    files, total = D.bake_files(str(tmp_path))
    assert total == 280 and files[0] == ("manifest.json", 10) and files[1] == ("preview.png", 20)
    assert D.grouped_files(files)[-1] == ("specular_0-2.exr", 150)
    assert D.human_size(512) == "512 B" and D.human_size(3 * 1024 * 1024) == "3.0 MB"
    assert D.bake_files(str(tmp_path / "missing")) == ([], 0)


def test_a_manifest_is_read_only_as_a_regular_file(tmp_path):
    """describe.manifest_of (the panel, Add Sun Lamp): a FIFO named
    manifest.json never hangs Blender, a link is not followed."""
    for name in ("fifo", "link", "good"):
        (tmp_path / name).mkdir()
    (tmp_path / "good" / "manifest.json").write_text('{"sun": null}')
    os.mkfifo(str(tmp_path / "fifo" / "manifest.json"))
    os.symlink(str(tmp_path / "good" / "manifest.json"), str(tmp_path / "link" / "manifest.json"))
    assert D.manifest_of(str(tmp_path / "good")) == {"sun": None}
    assert D.manifest_of(str(tmp_path / "fifo")) is None
    assert D.manifest_of(str(tmp_path / "link")) is None
    assert D.manifest_of(str(tmp_path / "missing")) is None


def test_file_read_off_the_main_thread_matches_blenders_pixels(tmp_path):
    """The Environment Texture's file read by the native reader is what
    Blender's buffer gives, after the nodes (here Strength); a file whose
    pixels Blender would show otherwise is refused."""
    rgb = np.random.default_rng(1).random((16, 32, 3), dtype=np.float32) * 4
    path = str(tmp_path / "sky.exr")
    ib.write_exr(path, rgb)
    src = WorldSource(IMAGE, image_path=path, colorspace="Linear", is_float=True, strength=2.0)
    np.testing.assert_array_equal(read_file_pixels(src, ib.read_image), rgb * 2)
    # As Blender hands it over: flat RGBA rows bottom-up.
    flat = np.concatenate([rgb, np.ones((16, 32, 1), np.float32)], -1)[::-1].reshape(-1)
    np.testing.assert_array_equal(prepare_pixels(src, flat, 32, 16), rgb * 2)
    with pytest.raises(FileNotAsBlenderShowsIt):  # Blender would convert from this colour space
        read_file_pixels(WorldSource(IMAGE, image_path=path, colorspace="Filmic Log", is_float=True), ib.read_image)
    # A file with an alpha channel: Cycles may multiply by it, so Blender's buffer is read instead.
    import subprocess
    alpha = str(tmp_path / "alpha.exr")
    subprocess.run(["oiiotool", "--pattern", "constant:color=1,1,1,0.5", "32x16", "4", "-o", alpha], check=True)
    from iblbake.core.world import exr_channels
    assert exr_channels(alpha) == ["A", "B", "G", "R"] and exr_channels(path) == ["B", "G", "R"]
    assert exr_channels(__file__) == []
    with pytest.raises(FileNotAsBlenderShowsIt):
        read_file_pixels(WorldSource(IMAGE, image_path=alpha, colorspace="Linear", is_float=True), ib.read_image)
    img = read_file_pixels(WorldSource(IMAGE, image_path=alpha, colorspace="Linear", is_float=True), ib.read_image,
                           alpha_matters=False)  # channel-packed alpha: the colour is read as it is
    assert img.shape == (16, 32, 3) and float(img.min()) == 1.0


def test_engine_presets_and_the_preview_are_in_the_content_hash():
    """Ticking an engine or the preview sheet changes the files, so the hash;
    presets switch the scene's skipping off (engines need every level)."""
    src = WorldSource(IMAGE)
    base = BakeSettings(out_dir="/x")
    cube = N.needs_from_lobes(N.principled_lobes("m", (0.5, 0.5), (0, 0), (0.5, 0.5)), 9, 1)

    def digest(s):
        return pipeline.content_hash(src, "0" * 64, pipeline.native_options(s, cube), s, "1")
    three = BakeSettings(out_dir="/x", presets=["three"])
    assert digest(base) != digest(three) != digest(BakeSettings(out_dir="/x", presets=["three", "bevy"]))
    assert digest(base) != digest(BakeSettings(out_dir="/x", preview=False))
    assert digest(base) == digest(BakeSettings(out_dir="/elsewhere"))
    assert pipeline.native_options(base, cube)["first_level"] == 4  # auto_skip on: level 4 of 9 only
    opts = pipeline.native_options(three, cube)
    assert "first_level" not in opts and opts["presets"] == ["three"] and opts["preview"] is True


def test_thumbnail_is_small_srgb_and_bottom_up():
    img = np.zeros((100, 300, 3), np.float32)
    img[:50] = 0.214  # linear 0.214 is sRGB 0.5; the top half
    t = D.thumbnail(img, 150)
    assert t.shape == (50, 150, 4) and t.dtype == np.float32
    np.testing.assert_allclose(t[-1, :, :3], 0.5, atol=2e-3)  # the top row is last (bottom-up)
    np.testing.assert_allclose(t[0, :, :3], 0.0)
    assert (t[..., 3] == 1).all()


# --- what a bake's folder holds and what a new bake would remove (core/folder.py, issue 26) ---
from iblbake.core import folder as F  # noqa: E402


def test_a_bake_says_what_it_would_remove_from_the_folder(tmp_path):
    """Every roughness with two engines, then This Scene's Materials for a
    roughness-0.5 cube: levels 0-3 and 5-8 and both engine folders would
    go (with their sizes); the same bake again removes nothing; another
    world's bake is named as such."""
    src = WorldSource(IMAGE, world="World", image_name="forest.exr", image_path="/hdri/forest.exr")
    full = BakeSettings(out_dir=str(tmp_path / "out"), face_size=256, irradiance_size=4, lut_size=8,
                        lut_cache_dir=str(tmp_path / "cache"), presets=["three", "khronos"], auto_skip=False)
    pipeline.bake(src, sky(64, 128), full)
    old = F.read_folder(str(tmp_path / "out"))
    assert old.outputs == F.Outputs(True, tuple(range(9)), True, ("khronos", "three"), True, ("exr",))
    assert old.source_words == "forest.exr" and old.total_bytes > 0
    cube = N.needs_from_lobes(N.principled_lobes("Material", (0.5, 0.5), (0, 0), (0.5, 0.5)), 9, 1)
    scene_only = BakeSettings(**dict(vars(full), presets=[], auto_skip=True))
    planned = F.planned_outputs(pipeline.native_options(scene_only, cube), 9)
    assert planned.levels == (4,) and planned.irradiance and not planned.presets
    gone = F.losses(old, planned, src)
    assert [g.split(" (")[0] for g in gone] == ["specular levels 0-3 and 5-8", "the three.js and Khronos folders"]
    assert all(g.endswith("B)") for g in gone)  # each with its size
    assert F.losses(old, old.outputs, src) == []
    sky_world = WorldSource(RENDER, "a Sky Texture", world="Sky")
    assert F.losses(old, old.outputs, sky_world)[0].startswith("the bake of forest.exr (")
    png_only = F.Outputs(True, tuple(range(9)), True, ("khronos", "three"), True, ("png",))
    assert [g.split(" (")[0] for g in F.losses(old, png_only, src)] == [
        "9 specular levels as EXR", "the irradiance", "the BRDF LUT"]


def test_the_panel_says_when_and_what_was_baked_and_whether_it_is_up_to_date(tmp_path):
    src = WorldSource(IMAGE, world="World", image_name="forest.exr", image_path="/hdri/forest.exr")
    settings = small(tmp_path)
    pipeline.bake(src, sky(), settings, extra={"world_fingerprint": "abc"})
    old = F.read_folder(settings.out_dir)
    digest = pipeline.settings_hash(src, settings)
    assert old.blender["settings_hash"] == digest
    assert F.freshness(old, "abc", digest) == F.UP_TO_DATE
    assert F.freshness(old, "abd", digest) == F.WORLD_CHANGED
    assert F.freshness(old, "abc", pipeline.settings_hash(src, small(tmp_path, lut_model="multiscatter"))) == F.SETTINGS_CHANGED
    now = old.modified + 60
    assert F.last_bake_line(old, F.UP_TO_DATE, now) == (
        "Last bake: %s, forest.exr: irradiance, 4 specular levels, BRDF LUT; up to date" % F.when(old.modified, now))
    assert F.when(0, 365 * 86400 * 3).endswith("1970")
    # A bake by the command line (no blender section): when and what, no verdict.
    cli = tmp_path / "cli"
    import subprocess
    exr = str(tmp_path / "sky.exr")
    ib.write_exr(exr, sky())
    subprocess.run([os.environ.get("IBLBAKE_CLI", os.path.join(os.path.dirname(__file__), "..", "..", "build",
                                                                "native", "iblbake")),
                    "bake", exr, "-o", str(cli), "--face-size", "8", "-q"], check=True,
                   env=dict(os.environ, IBLBAKE_CACHE_DIR=str(tmp_path / "cache")))
    by_cli = F.read_folder(str(cli))
    assert by_cli.source_words == "sky.exr (by the command line)" and F.freshness(by_cli, "abc", digest) == ""
    assert F.read_folder(str(tmp_path / "nothing")) is None


def test_file_lists_count_the_engine_folders(tmp_path):
    for name, size in (("manifest.json", 10), ("specular_0.exr", 40), ("three/specular.ktx2", 500),
                       ("khronos/diffuse.ktx2", 300), ("khronos/specular.ktx2", 700)):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_bytes(b"x" * size)
    files, total = D.bake_files(str(tmp_path))
    assert total == 1550 and len(files) == 5 and files[0] == ("manifest.json", 10)
    assert D.grouped_files(files)[-2:] == [("khronos/ (2 files)", 1000), ("three/ (1 file)", 500)]
    assert D.levels_words([4]) == "specular level 4" and D.levels_words(range(9)) == "9 specular levels"
    assert D.levels_words([0, 1, 2, 3, 5, 6]) == "specular levels 0-3 and 5-6"


def test_a_bake_without_the_sun_split_says_it_removes_the_suns_files(tmp_path):
    """Issue 27's sun in issue 26's folder logic: a bake with Sun: Split holds
    sun.json (and sun.gltf when found); the Last bake line says so, and a bake
    with Sun: Off would remove them (the panel asks first)."""
    src = WorldSource(IMAGE, world="World", image_name="sunset.exr", image_path="/hdri/sunset.exr")
    split = small(tmp_path, sun="split")
    pipeline.bake(src, sky(), split)
    old = F.read_folder(split.out_dir)
    assert old.outputs.sun and "sun.json" in dict(old.files)
    assert old.outputs.words().endswith(", Sun: Split")
    off = F.planned_outputs(pipeline.native_options(small(tmp_path), None), 4)
    assert not off.sun and F.planned_outputs(pipeline.native_options(split, None), 4).sun
    assert [g.split(" (")[0] for g in F.losses(old, off, src)] == ["the sun's files"]
    assert F.losses(old, old.outputs, src) == []
