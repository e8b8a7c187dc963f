"""The Blender add-on in headless Blender (see cases.py for the scenes)."""
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from blender_helpers import (BAKE_WORLD, BLENDER, FOREST, ROOT, bake_world, blender_version, manifest, read,
                             run_blender, sample_cross)

CLI = os.environ.get("IBLBAKE_CLI", os.path.join(ROOT, "build", "native", "iblbake"))


def test_hdri_world_bakes_like_the_cli(tmp_path):
    opts = ["--face-size", "32", "--irradiance-size", "8", "--lut-size", "32"]
    p = bake_world("--hdri", FOREST, "--out", str(tmp_path / "addon"), *opts)
    assert p.returncode == 0, p.stdout + p.stderr
    env = dict(os.environ, IBLBAKE_CACHE_DIR=str(tmp_path / "cache"))
    subprocess.run([CLI, "bake", FOREST, "-o", str(tmp_path / "cli"), *opts, "-q", "--preview"], check=True, env=env)
    a, c = manifest(tmp_path / "addon"), manifest(tmp_path / "cli")
    assert a["blender"]["path"] == "environment_texture"
    assert a["source"]["sha256"] == c["source"]["sha256"]
    assert [e["file"] for e in a["specular"]] == [e["file"] for e in c["specular"]]
    for name in ["irradiance.exr", "brdf_lut.exr"] + [e["file"] for e in c["specular"]]:
        x, y = read(tmp_path / "addon" / name), read(tmp_path / "cli" / name)
        np.testing.assert_allclose(x, y, rtol=1e-3, atol=1e-5, err_msg=name)
    np.testing.assert_allclose(a["sh9"], c["sh9"], rtol=1e-5, atol=1e-7)
    # The same preview sheet (one native renderer), read through OpenImageIO.
    pa, pc = read(tmp_path / "addon" / "preview.png"), read(tmp_path / "cli" / "preview.png")
    assert pa.shape == pc.shape and pa.shape[1] >= 400
    np.testing.assert_allclose(pa, pc, atol=2.5 / 255)


@pytest.mark.parametrize("rotation,strength,mapping_type,fmt", [
    ("0,0,0", 1.0, "POINT", "exr"),
    ("10,-20,30", 2.5, "POINT", "exr"),
    ("0,15,-60", 1.0, "TEXTURE", "exr"),
    ("0,0,0", 1.0, "POINT", "png"),
])
def test_specular_mip0_matches_cycles_along_the_axes(case, rotation, strength, mapping_type, fmt):
    """A world whose colour codes its direction, baked by the add-on, against
    Cycles' own renders of it along +-X, +-Y, +-Z and two oblique directions:
    orientation, the Mapping node, Strength and an 8-bit sRGB image's
    decoding as Cycles applies them."""
    res, work = case("orientation", rotation=rotation, strength=strength, mapping_type=mapping_type, format=fmt)
    assert res["error"] == "", res
    m = manifest(work / "out")
    assert m["blender"]["path"] == "environment_texture"
    assert m["blender"]["image"]["linearised_from_srgb"] is (fmt == "png")
    assert m["blender"]["strength"] == pytest.approx(strength)
    if rotation != "0,0,0":
        assert m["blender"]["mapping"]["type"] == mapping_type
    mip0 = read(work / "out" / "specular_0.exr")
    for d, seen in zip(res["probes"], res["cycles"]):
        baked = sample_cross(mip0, d)
        np.testing.assert_allclose(baked, seen, atol=0.01 * strength, err_msg="direction %s" % (d,))


def test_sun_disc_skies_get_the_wider_render_on_every_blender(case):
    """A sky with a sun disc is rendered at least 1024 wide: Nishita's
    sky, called Single Scattering from 5.0 on (and Multiple Scattering)."""
    res, _ = case("sun_disc")
    assert any(k.split()[0] != "HOSEK_WILKIE" for k in res), res  # this Blender has a sun-disc sky
    for key, wider in res.items():
        kind, disc = key.split()
        assert wider == (disc == "True" and kind != "HOSEK_WILKIE"), key


def test_sky_texture_world_is_rendered_by_cycles_then_baked(case):
    res, work = case("sky")
    assert res["error"] == "", res
    m = manifest(work / "out")
    assert m["blender"]["path"] == "cycles_render"
    assert "Sky Texture node" in m["blender"]["why"]  # the node as Blender's UI names it
    assert m["blender"]["render"]["width"] == 256
    mip0 = read(work / "out" / "specular_0.exr")
    for d, seen in zip(res["probes"], res["cycles"]):
        np.testing.assert_allclose(sample_cross(mip0, d), seen, rtol=0.05, atol=1e-3, err_msg=str(d))
    irr = read(work / "out" / "irradiance.exr")
    assert np.isfinite(irr).all() and irr.max() > 0


def test_plain_colour_world_is_baked_in_closed_form(case):
    res, work = case("color")
    assert res["error"] == "", res
    m = manifest(work / "out")
    assert m["blender"]["path"] == "plain_colour"
    assert "constant" in m["timings"] and "specular" not in m["timings"]
    expect = np.array([0.2, 0.4, 0.8]) * 1.5
    n = m["irradiance"]["face_size"]
    irr = read(work / "out" / "irradiance.exr")
    np.testing.assert_allclose(irr[n:2 * n, :], np.broadcast_to(expect, irr[n:2 * n, :].shape), rtol=1e-3)
    np.testing.assert_allclose(np.array(m["sh9"])[:, 0], expect * 2 * np.sqrt(np.pi), rtol=1e-6)
    for level in m["specular"]:
        spec = read(work / "out" / level["file"])
        for d in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]:
            np.testing.assert_allclose(sample_cross(spec, d), expect, rtol=1e-3, err_msg=level["file"])


def test_unchanged_world_is_not_baked_again(case):
    res, work = case("unchanged")
    assert res["first"]["status"].startswith("Baked"), res
    assert "unchanged" in res["second"]["status"] and res["second"]["result"] == ["FINISHED"]
    assert res["untouched"]
    assert res["third"]["status"].startswith("Baked")
    assert res["forced"]["status"].startswith("Baked")
    assert manifest(work / "out")["brdf_lut"]["from_cache"] is True  # the LUT is made once, then reused


def test_materials_decide_what_is_baked(case):
    res, work = case("needs")
    for key, r in res.items():
        assert r["error"] == "", (key, r)
    m = manifest(work / "diffuse_only")
    assert m["specular"] == [] and m["brdf_lut"] is None and m["irradiance"] is not None
    whys = {s["what"]: s["why"] for s in m["skipped"]}
    assert "glossy" in whys["specular"] and "glossy" in whys["brdf_lut"]
    assert m["blender"]["needs"]["specular"] is False

    m = manifest(work / "principled")  # roughness 0.3 of r_m = m / 5: levels 1 and 2
    assert [e["level"] for e in m["specular"]] == [1, 2]
    assert sorted(os.listdir(work / "principled")) == [
        "brdf_lut.exr", "irradiance.exr", "manifest.json", "preview.png", "specular_1.exr", "specular_2.exr"]
    assert any(s["what"] == "specular levels 0-0, 3-5" for s in m["skipped"])

    m = manifest(work / "metal")  # fully metallic, textured roughness: no diffuse, every level
    assert m["irradiance"] is None and [e["level"] for e in m["specular"]] == [0, 1, 2, 3, 4, 5]
    m = manifest(work / "metal_all")  # skipping switched off
    assert m["irradiance"] is not None and m["blender"]["auto_skip"] is False


def test_what_the_render_shows_counts_not_what_the_viewport_shows(case):
    res, _ = case("needs_edges")
    assert res["diffuse"]["specular"] is False
    assert res["hidden_in_viewport"] == {"specular": True, "levels": [0, 1]}
    assert res["hidden_in_render"]["specular"] is False
    assert res["collection_instance"]["specular"] is True  # instanced: shown though hidden itself
    assert res["muted_mix"] == {"specular": True, "levels": [0, 0]}  # a muted Mix passes its first shader


def test_world_is_baked_as_it_lights_the_scene_not_as_the_camera_sees_it(case):
    res, work = case("light_path")
    assert res["error"] == "", res
    m = manifest(work / "out")
    assert m["blender"]["path"] == "cycles_render"
    assert any("Is Camera Ray" in n for n in m["blender"]["render"]["notes"])
    assert any("camera visibility" in n for n in m["blender"]["render"]["notes"])
    irr = read(work / "out" / "irradiance.exr")
    n = m["irradiance"]["face_size"]
    # The direction field averages 0.5 over the sphere; the backdrop is 0.05.
    assert abs(float(irr[n:2 * n].mean()) - 0.5) < 0.1


def test_cancelled_bake_keeps_the_earlier_one(case):
    res, work = case("cancel")
    assert res["first"]["error"] == ""
    assert res["finished"] and res["cancelled"] and res["error"] is None, res
    assert "specular" in res["stages"] and "brdf_lut" not in res["stages"]
    assert res["unchanged"]
    assert res["siblings"] == ["field.exr", "out"]  # no staging folder left behind


def test_missing_image_file_is_a_clear_error_and_keeps_the_earlier_bake(case, tmp_path):
    res, work = case("missing")
    assert res["first"]["error"] == ""
    assert res["second"]["result"] == ["CANCELLED"]
    assert "no file at" in res["second"]["error"] and "gone.exr" in res["second"]["error"]
    assert res["unchanged"]
    p = bake_world("--hdri", str(tmp_path / "nothing.exr"), "--out", str(tmp_path / "x"))
    assert p.returncode == 1 and "no image file at" in p.stderr
    assert not (tmp_path / "x").exists()


def test_batch_over_blend_files_and_images(case, tmp_path):
    import iblbake_core as ib
    _, work = case("save_blend")
    blend = str(work / "scene.blend")
    out = tmp_path / "batch"
    square = str(tmp_path / "square.exr")  # not 2:1: a warning, listed per world as the CLI's batch lists it
    ib.write_exr(square, np.full((32, 32, 3), 0.5, np.float32))
    p = bake_world("--batch", blend, FOREST, str(tmp_path / "missing.exr"), square, "--out", str(out),
                   "--face-size", "16", "--lut-size", "16")
    assert p.returncode == 1, p.stdout + p.stderr
    assert "missing.exr" in p.stderr
    assert "warning: square: the source is 32 x 32, not 2:1" in p.stdout, p.stdout
    assert manifest(out / "scene")["blender"]["strength"] == 2.0
    assert manifest(out / "forest")["blender"]["image"]["name"] == "forest.exr"
    assert not (out / "missing").exists()
    # the CLI's batch machinery: its names, its index and gallery, the preview sheets on
    with open(out / "index.json") as f:
        idx = json.load(f)
    assert [(w["name"], w["status"]) for w in idx["worlds"]] == [
        ("scene", "baked"), ("forest", "baked"), ("missing", "failed"), ("square", "baked")]
    assert [len(w["warnings"]) for w in idx["worlds"]] == [0, 0, 0, 1], idx["worlds"]
    assert "not 2:1" in idx["worlds"][3]["warnings"][0]
    assert idx["worlds"][1]["content_hash"] == manifest(out / "forest")["blender"]["content_hash"]
    assert "no image file at" in idx["worlds"][2]["error"]
    assert (out / "forest" / "preview.png").is_file() and 'src="forest/preview.png"' in (out / "index.html").read_text()
    # again, from a list file and one shard of two: forest alone, unchanged
    lst = tmp_path / "worlds.txt"
    lst.write_text("# two worlds\n%s\n%s\n" % (blend, FOREST))
    p = bake_world("--batch", "--list", str(lst), "--shard", "1/2", "--out", str(out), "--face-size", "16",
                   "--lut-size", "16")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "[1/1] unchanged forest" in p.stdout
    with open(out / "index.1-of-2.json") as f:
        assert [(w["name"], w["status"]) for w in json.load(f)["worlds"]] == [("forest", "unchanged")]
    # The open-file form: blender -b file.blend --python bake_world.py -- --out DIR
    p = run_blender([blend, "--python", BAKE_WORLD, "--", "--out", str(tmp_path / "one"), "--face-size", "16"])
    assert p.returncode == 0, p.stdout + p.stderr
    assert manifest(tmp_path / "one")["blender"]["blend_file"] == blend


ADDON_ZIP = os.environ.get("IBLBAKE_ADDON_ZIP", "")
EXTENSION_ZIP = os.environ.get("IBLBAKE_EXTENSION_ZIP", "")
needs_zips = pytest.mark.skipif(not (ADDON_ZIP and EXTENSION_ZIP), reason="run through CTest (the zips' paths)")
EXTENSIONS = blender_version() >= (4, 2)

# Sets the preferences, starts a new file (its settings start from them:
# issue 26, the file open when the add-on was enabled keeps its own), makes
# the world a plain colour and bakes it; prints where the module came from.
BAKE_PLAIN = (
    "import bpy, sys\n"
    "from {pkg}.core import native\n"
    "print('MODULE=' + native.load().__file__)\n"
    "prefs = bpy.context.preferences.addons[{pkg!r}].preferences\n"
    "prefs.default_output_dir = {out!r}\n"
    "prefs.face_size = 8\n"
    "bpy.ops.wm.read_homefile(app_template='')\n"
    "bpy.context.scene.world.node_tree.nodes['Background'].inputs['Color'].default_value = (1, 0.5, 0.25, 1)\n"
    "print(bpy.ops.iblbake.bake())\n")


def isolated_env(tmp_path):
    """Blender's user folders (add-ons, extensions, preferences) in tmp_path."""
    env = {k: v for k, v in os.environ.items() if k not in ("IBLBAKE_CORE_DIR", "PYTHONPATH")}
    env["BLENDER_USER_RESOURCES"] = str(tmp_path / "user")  # 4.2+: config, scripts, extensions
    env["BLENDER_USER_SCRIPTS"] = str(tmp_path / "user" / "scripts")
    env["BLENDER_USER_CONFIG"] = str(tmp_path / "user" / "config")
    env["IBLBAKE_CACHE_DIR"] = str(tmp_path / "cache")
    return env


def blender_script(tmp_path, text, env, factory=True, name="script.py"):
    script = tmp_path / name
    script.write_text(text)
    args = [BLENDER, "-b", *(["--factory-startup"] if factory else []), "--python-exit-code", "1",
            "--python", str(script)]
    return subprocess.run(args, capture_output=True, text=True, env=env, timeout=300)


def check_plain_bake(tmp_path, p, module_under):
    assert p.returncode == 0, p.stdout + p.stderr
    module = [line for line in p.stdout.splitlines() if line.startswith("MODULE=")][0][7:]
    assert module.startswith(str(module_under)), module
    m = manifest(tmp_path / "out" / "World")
    assert m["blender"]["path"] == "plain_colour" and m["options"]["face_size"] == 8
    # "Bake For" defaults to every roughness: all 4 levels, though the default
    # cube (Principled, roughness 0.5) reads only levels 1-2; and the preview sheet.
    assert [e["level"] for e in m["specular"]] == [0, 1, 2, 3]
    assert m["preview"]["file"] == "preview.png" and (tmp_path / "out" / "World" / "preview.png").is_file()


def install_as_add_on_and_bake(tmp_path, zip_path):
    """Preferences > Add-ons > Install of ZIP_PATH in a fresh user folder,
    enabled, then a plain bake: one folder iblbake/ in the add-ons folder."""
    env = isolated_env(tmp_path)
    p = blender_script(tmp_path, "import bpy, addon_utils\n"
                       "bpy.ops.preferences.addon_install(filepath=%r)\n"
                       "assert addon_utils.enable('iblbake', default_set=True) is not None\n" % zip_path
                       + BAKE_PLAIN.format(pkg="iblbake", out=str(tmp_path / "out" / "{world}")), env)
    check_plain_bake(tmp_path, p, tmp_path / "user" / "scripts")
    assert os.listdir(tmp_path / "user" / "scripts" / "addons") == ["iblbake"]


@needs_zips
def test_packaged_zip_installs_and_bakes_with_its_own_module(tmp_path):
    """The legacy add-on zip installs through Preferences > Add-ons > Install
    (every Blender; 4.2+ calls it a legacy add-on) and bakes with the module
    inside it (no checkout on the path)."""
    install_as_add_on_and_bake(tmp_path, ADDON_ZIP)


@needs_zips
@pytest.mark.skipif(not EXTENSIONS, reason="extensions are Blender 4.2+")
def test_extension_validates_installs_with_blenders_command_and_bakes(tmp_path):
    """`blender --command extension validate` accepts the zip; `extension
    install-file -r user_default -e` installs and enables it; a later
    session (the saved preferences) bakes with the module inside it."""
    env = isolated_env(tmp_path)
    p = subprocess.run([BLENDER, "--command", "extension", "validate", EXTENSION_ZIP],
                       capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    p = subprocess.run([BLENDER, "--command", "extension", "install-file", "-r", "user_default", "-e", EXTENSION_ZIP],
                       capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    pkg = "bl_ext.user_default.iblbake"
    p = blender_script(tmp_path, "import bpy\nassert %r in bpy.context.preferences.addons, "
                       "list(bpy.context.preferences.addons.keys())\n" % pkg
                       + BAKE_PLAIN.format(pkg=pkg, out=str(tmp_path / "out" / "{world}")), env, factory=False)
    check_plain_bake(tmp_path, p, tmp_path / "user" / "extensions" / "user_default" / "iblbake")


@needs_zips
@pytest.mark.skipif(EXTENSIONS, reason="Blender 4.2+ installs the extension as an extension")
def test_extension_zip_in_an_older_blender_is_one_working_add_on_folder(tmp_path):
    """Installed by mistake through 3.4's Add-ons > Install, the extension zip
    is still one folder with bl_info (never loose files), and it works."""
    install_as_add_on_and_bake(tmp_path, EXTENSION_ZIP)


@needs_zips
def test_a_zip_built_for_another_python_is_refused_with_the_reason(tmp_path):
    """A module built for another Python cannot load: enabling the add-on
    fails at once with a message that says which Python each side has,
    and nothing of it is registered."""
    import zipfile
    other = tmp_path / "other-python.zip"
    with zipfile.ZipFile(ADDON_ZIP) as src, zipfile.ZipFile(other, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            name = item.filename
            if name.startswith("iblbake/iblbake_core."):
                name = "iblbake/iblbake_core.cpython-30-x86_64-linux-gnu.so"
            dst.writestr(name, data)
    env = isolated_env(tmp_path)
    p = blender_script(tmp_path, "import bpy, addon_utils\n"
                       "bpy.ops.preferences.addon_install(filepath=%r)\n"
                       "errors = []\n"
                       "mod = addon_utils.enable('iblbake', default_set=True, handle_error=errors.append)\n"
                       "print('ENABLED=%%s' %% (mod is not None))\n"
                       "print('ERROR=%%s' %% errors[0] if errors else 'ERROR=')\n"
                       "print('REGISTERED=%%s' %% hasattr(bpy.types, 'IBLBAKE_OT_bake'))\n" % str(other), env)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "ENABLED=False" in p.stdout and "REGISTERED=False" in p.stdout, p.stdout
    error = [line for line in p.stdout.splitlines() if line.startswith("ERROR=")][0]
    assert "built for Python 3.0" in error and "this Blender runs Python 3." in error, error


def test_bake_worlds_flags_and_the_addons_properties_are_the_tables(tmp_path):
    """bake_world.py's argparse and the add-on's properties are made from
    the options table (core/options.py: the native rows offered in Blender
    and the add-on's own): a flag and a property per row, with the row's
    label, default and range."""
    p = bake_world("--help")
    assert p.returncode == 0, p.stderr
    flags = set(re.findall(r"(--[a-z0-9-]+)", p.stdout))
    script = tmp_path / "rows.py"
    script.write_text(
        "import bpy, json, sys\n"
        "sys.path.insert(0, %r)\n"
        "import iblbake\n"
        "iblbake.register()\n"
        "from iblbake.core import options\n"
        "rows = options.rows()\n"
        "props = bpy.context.scene.iblbake\n"
        "out = []\n"
        "for r in rows:\n"
        "    rna = props.bl_rna.properties.get(r['name'])\n"
        "    out.append(dict(name=r['name'], flag=options.cli_flag(r), label=rna.name if rna else None,\n"
        "                    want=r['label'], default=getattr(props, r['name'], None), row_default=r['default'],\n"
        "                    min=getattr(rna, 'hard_min', None), row_min=r.get('min')))\n"
        "print('ROWS=' + json.dumps(out, default=sorted))\n" % os.path.join(ROOT, "addon"))
    q = run_blender(["--python-exit-code", "1", "--python", str(script)])
    assert q.returncode == 0, q.stdout[-2000:] + q.stderr[-2000:]
    rows = json.loads([ln for ln in q.stdout.splitlines() if ln.startswith("ROWS=")][0][5:])
    names = {r["name"] for r in rows}
    assert {"face_size", "formats", "presets", "irradiance", "render_width"} <= names
    for r in rows:
        assert r["flag"] in flags, r
        assert r["label"] == r["want"], r
        default = sorted(r["default"]) if isinstance(r["default"], list) else r["default"]
        row_default = sorted(r["row_default"]) if isinstance(r["row_default"], list) else r["row_default"]
        assert default == pytest.approx(row_default) if isinstance(default, float) else default == row_default, r
        if r["row_min"] is not None and r["min"] is not None:
            assert r["min"] == pytest.approx(r["row_min"]), r


def test_the_clis_rotation_turns_the_world_as_blenders_mapping_node(tmp_path):
    """iblbake bake --rotation 30 and bake_world.py --rotation-z 30 (a
    Mapping node, Point, rotation Z, in front of the Environment Texture)
    bake the same lighting. forest.exr has 784 texels just below zero
    (down to -0.0016): the CLI treats them as 0 before turning the world,
    the add-on turns Blender's pixels first, so dark texels may differ by
    that much."""
    opts = ["--face-size", "32", "--irradiance-size", "8", "--no-lut"]
    p = bake_world("--hdri", FOREST, "--rotation-z", "30", "--out", str(tmp_path / "addon"), *opts)
    assert p.returncode == 0, p.stdout + p.stderr
    subprocess.run([CLI, "bake", FOREST, "-o", str(tmp_path / "cli"), "--rotation", "30", "-q", *opts], check=True,
                   env=dict(os.environ, IBLBAKE_CACHE_DIR=str(tmp_path / "cache")))
    assert manifest(tmp_path / "addon")["blender"]["mapping"]["rotation_degrees"][2] == pytest.approx(30.0)
    assert manifest(tmp_path / "cli")["options"]["rotation_degrees"] == 30.0
    for name in ["irradiance.exr"] + ["specular_%d.exr" % m for m in range(6)]:  # half floats: 2^-11 apart
        np.testing.assert_allclose(read(tmp_path / "addon" / name), read(tmp_path / "cli" / name), rtol=1e-3,
                                   atol=1.6e-3, err_msg=name)


# --- issue 26: the file's settings, the folder's bake, what a bake replaces ----------
SETTINGS_SCRIPT = r'''
import bpy, addon_utils, json, os, sys
W = {work!r}
out = {{}}
bpy.ops.preferences.addon_install(filepath={zip!r})
assert addon_utils.enable("iblbake", default_set=True) is not None
from iblbake import operators, panel, properties, scene_settings
from iblbake.core import folder
prefs = bpy.context.preferences.addons["iblbake"].preferences
prefs.face_size, prefs.presets, prefs.default_output_dir = 32, {{"three"}}, os.path.join(W, "out", "{{world}}")
bpy.ops.wm.read_homefile(app_template="")  # a new file: load_post starts its scene from the preferences
scene = bpy.context.scene
p = scene.iblbake
out["new_file"] = [p.options_initialised, p.face_size, sorted(p.presets), p.output_dir]
prefs.face_size = 48  # a later change of the defaults changes no file that has its settings
p.presets = {{"three", "khronos"}}  # the World panel's toggles write the scene, never the preferences
out["after_prefs_change"] = [p.face_size, sorted(p.presets), sorted(prefs.presets)]
# An unsaved file with a // folder: Bake IBL is greyed out, with the reason.
p.output_dir = "//ibl/{{world}}"
out["unsaved_poll"] = bpy.ops.iblbake.bake.poll()
out["unsaved_why"] = scene_settings.unsaved_relative_folder(bpy.context, scene)
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(W, "a.blend"))
out["saved_poll"] = bpy.ops.iblbake.bake.poll()
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 0.5, 0.25, 1)
out["bake"] = sorted(bpy.ops.iblbake.bake())
bpy.ops.wm.save_mainfile()
# Reopened: the settings are the file's, the panel reads the folder's manifest.
prefs.face_size = 64
bpy.ops.wm.open_mainfile(filepath=os.path.join(W, "a.blend"))
scene = bpy.context.scene
p = scene.iblbake
out["reopened"] = [p.face_size, sorted(p.presets)]
plan = panel._plan(bpy.context, scene)
old = panel._folder_state(plan.folder)[0]
out["last_bake"] = folder.last_bake_line(old, folder.freshness(old, plan.world_fingerprint, plan.settings_hash))
out["files"] = [n for n, _ in panel.describe.grouped_files(panel._folder_state(plan.folder)[1])]
scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 3.0
panel._forget_plans()
plan = panel._plan(bpy.context, scene)
out["world_changed"] = folder.freshness(old, plan.world_fingerprint, plan.settings_hash)
scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
p.face_size = 16
panel._forget_plans()
plan = panel._plan(bpy.context, scene)
out["settings_changed"] = folder.freshness(old, plan.world_fingerprint, plan.settings_hash)
# What the UI's bake would ask about: fewer levels, no engines.
p.presets = set()
settings = scene_settings.gather_settings(bpy.context, scene)
old, gone = operators.replacing(settings, scene_settings.scene_needs_for(scene, settings),
                                operators.world_reader.classify(scene.world))
out["would_remove"] = gone
# The preview sheet an Image Editor showed is not saved with the file.
from iblbake import outputs
outputs.load_preview(os.path.join(plan.folder, "preview.png"))
bpy.ops.wm.save_mainfile()
out["images_after_save"] = [i.name for i in bpy.data.images]
print("RESULT=" + json.dumps(out))
'''


@needs_zips
def test_settings_live_in_the_file_and_the_panel_reads_the_folders_bake(tmp_path):
    """Issue 26: a new file's settings start from the preferences' defaults,
    then are the file's (a later change of the defaults, or a toggle in the
    World panel, changes nothing else); an unsaved file with a // folder
    cannot bake; after reopening, the panel says when and what the folder's
    bake is and whether the world or the settings changed since; the UI's
    bake would say what it removes; the preview sheet is not saved."""
    env = isolated_env(tmp_path)
    work = tmp_path / "work"
    work.mkdir()
    p = blender_script(tmp_path, SETTINGS_SCRIPT.format(work=str(work), zip=ADDON_ZIP), env)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    r = json.loads([ln for ln in p.stdout.splitlines() if ln.startswith("RESULT=")][0][7:])
    assert r["new_file"] == [True, 32, ["three"], str(work / "out" / "{world}")]
    assert r["after_prefs_change"] == [32, ["khronos", "three"], ["three"]]
    assert r["unsaved_poll"] is False and "save the file first" in r["unsaved_why"] and "//ibl/{world}" in r["unsaved_why"]
    assert r["saved_poll"] is True and r["bake"] == ["FINISHED"]
    assert r["reopened"] == [32, ["khronos", "three"]]
    assert r["last_bake"].startswith("Last bake: ") and r["last_bake"].endswith(
        ", the plain colour of world 'World': irradiance, 6 specular levels, BRDF LUT, three.js, Khronos; up to date")
    assert "khronos/ (3 files)" in r["files"] and "three/ (1 file)" in r["files"]
    assert r["world_changed"] == "the world changed since" and r["settings_changed"] == "the settings changed since"
    assert [g.split(" (")[0] for g in r["would_remove"]] == ["specular level 5", "the three.js and Khronos folders"]
    assert "iblbake preview" not in r["images_after_save"]


# An older add-on's scene settings, where Blender keeps an add-on's
# (bpy.props) data: among the ID's custom properties before 5.0, apart from
# them (system properties) from 5.0 on, where 5.x puts an older file's when
# it reads one (checked by hand: files written by Blender 3.4 keep Scene
# Options in 5.2.2).
OLD_FILE = r'''
import bpy
scene = bpy.context.scene
store = scene.bl_system_properties_get(do_create=True) if hasattr(scene, "bl_system_properties_get") else scene
store["iblbake"] = {{"use_scene_options": {own}, "face_size": 48}}
bpy.ops.wm.save_as_mainfile(filepath={path!r})
'''


@needs_zips
def test_an_older_file_keeps_what_it_baked_with(tmp_path):
    """A file saved before issue 26: its scene either used the preferences
    (no Scene Options: it now starts from the preferences' values) or had
    its own options (kept)."""
    env = isolated_env(tmp_path)
    for own in (0, 1):
        path = str(tmp_path / ("old%d.blend" % own))
        q = blender_script(tmp_path, OLD_FILE.format(own=own, path=path), env, name="old.py")
        assert q.returncode == 0, q.stderr
    p = blender_script(tmp_path, "import bpy, addon_utils\n"
                       "bpy.ops.preferences.addon_install(filepath=%r)\n"
                       "assert addon_utils.enable('iblbake', default_set=True) is not None\n"
                       "bpy.context.preferences.addons['iblbake'].preferences.face_size = 24\n"
                       "for own in (0, 1):\n"
                       "    bpy.ops.wm.open_mainfile(filepath=%r %% own)\n"
                       "    p = bpy.context.scene.iblbake\n"
                       "    print('OLD%%d=%%s %%d' %% (own, p.options_initialised, p.face_size))\n"
                       % (ADDON_ZIP, str(tmp_path / "old%d.blend")), env)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    assert "OLD0=True 24" in p.stdout and "OLD1=True 48" in p.stdout, p.stdout


def test_headless_bakes_replace_the_folder_and_print_what_went(tmp_path):
    """bake_world.py replaces the folder, as scripts expect, and says what
    the earlier bake had that this one has not."""
    out = str(tmp_path / "out")
    opts = ["--face-size", "32", "--irradiance-size", "8", "--lut-size", "32"]
    p = bake_world("--hdri", FOREST, "--out", out, *opts, "--preset", "three")
    assert p.returncode == 0 and "replaced" not in p.stdout, p.stdout + p.stderr
    p = bake_world("--hdri", FOREST, "--out", out, "--face-size", "16", "--irradiance-size", "8", "--lut-size", "32")
    assert p.returncode == 0, p.stdout + p.stderr
    line = [ln for ln in p.stdout.splitlines() if ln.startswith("iblbake: replaced the earlier bake in")]
    assert len(line) == 1 and "specular level 5 (" in line[0] and "the three.js folder (" in line[0], p.stdout
    assert not os.path.exists(os.path.join(out, "three"))
    city = "/usr/share/blender/datafiles/studiolights/world/city.exr"
    p = bake_world("--hdri", city, "--out", out, "--face-size", "16", "--irradiance-size", "8", "--lut-size", "32")
    assert "iblbake: replaced the earlier bake in %s: the bake of forest.exr (" % out in p.stdout, p.stdout


def run_on_a_terminal(args, timeout=600):
    """blender -b --factory-startup ARGS with a pseudo-terminal as stdout and
    stderr: (exit code, what it printed)."""
    from blender_helpers import blender_env
    sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
    from pty_run import run_on_a_terminal as run
    return run([BLENDER, "-b", "--factory-startup", *args], blender_env(), timeout)


def test_batch_jobs_and_the_bar(tmp_path):
    """bake_world.py --batch --jobs 2: Blender reads the next world while
    the last one bakes; every file is the one --jobs 1 writes, the index keeps
    the worlds' order, and on a terminal a bar shows worlds done, the
    current world's stage, rate and ETA, a failure kept as a line."""
    studio = "/usr/share/blender/datafiles/studiolights/world/"
    names = ["forest", "city", "sunset", "night"]
    if not all(os.path.isfile(studio + n + ".exr") for n in names):
        pytest.skip("Blender's studio lights are not installed")
    worlds = [studio + n + ".exr" for n in names] + [str(tmp_path / "missing.exr")]
    opts = ["--face-size", "32", "--lut-size", "16", "--irradiance-size", "8"]
    p = bake_world("--batch", *worlds, "--out", str(tmp_path / "one"), *opts)
    assert p.returncode == 1 and "[5/5] failed missing: no image file at" in p.stdout, p.stdout + p.stderr
    code, text = run_on_a_terminal(["--python", BAKE_WORLD, "--", "--batch", *worlds, "--out", str(tmp_path / "two"),
                                    "--jobs", "2", *opts])
    assert code == 1, text
    assert "\r[" in text and "\033[K" in text and "/5 " in text and "ETA " in text and "worlds/min" in text, text
    assert any(": %s" % s in text for s in ("starting", "hashing", "specular", "writing")), text
    assert "failed missing: no image file at" in text
    for run in ("one", "two"):
        with open(tmp_path / run / "index.json") as f:
            assert [(w["name"], w["status"]) for w in json.load(f)["worlds"]] == [
                (n, "baked") for n in names] + [("missing", "failed")]
    for n in names:
        a, b = tmp_path / "one" / n, tmp_path / "two" / n
        files = sorted(f for f in os.listdir(a) if f != "manifest.json")
        assert files == sorted(f for f in os.listdir(b) if f != "manifest.json")
        for f in files:
            if os.path.isfile(a / f):
                assert (a / f).read_bytes() == (b / f).read_bytes(), (n, f)
        assert manifest(a)["blender"]["content_hash"] == manifest(b)["blender"]["content_hash"]


SUNSET = "/usr/share/blender/datafiles/studiolights/world/sunset.exr"
# Rendered Nishita skies are kept here between runs (half a minute each on 2 cores).
SUN_CACHE = os.environ.get("IBLBAKE_TEST_CACHE", os.path.join(os.path.expanduser("~"), ".cache", "iblbake-tests"))


def test_sun_split_in_blender_and_add_sun_lamp(case):
    """Sun: Split on sunset.exr as the world: the panel's sentence, and Add
    Sun Lamp makes (then updates, not duplicates) a Sun lamp whose -Z is the
    light's direction of travel, Strength x colour = E, Angle = the diameter."""
    if not os.path.isfile(SUNSET):
        pytest.skip("Blender's studio lights are not installed")
    res, work = case("sun_lamp", hdri=SUNSET)
    assert res["result"] == ["FINISHED"], res
    sun = res["sun"]
    assert sun["found"], sun["why"]
    assert manifest(work / "out")["sun"] == sun
    assert os.path.isfile(work / "out" / "sun.json") and os.path.isfile(work / "out" / "sun.gltf")
    assert re.fullmatch(r"Sun at \d+\u00b0 elevation, [\d.]+\u00b0 across, \d+ % of the direct light", res["sentence"]), \
        res["sentence"]
    assert res["poll"] and res["ops"] == [["FINISHED"], ["FINISHED"]] and res["lamps"] == 1
    lamp = res["lamp"]
    assert lamp["type"] == "SUN" and lamp["bake"] == str(work / "out")
    np.testing.assert_allclose(np.asarray(lamp["color"]) * lamp["energy"], sun["illuminance"], rtol=1e-5)
    assert lamp["angle_deg"] == pytest.approx(sun["angular_diameter_deg"], rel=1e-5)
    np.testing.assert_allclose(lamp["shines_along"], -np.asarray(sun["direction"]), atol=1e-5)
    assert res["off"]["result"] == ["FINISHED"] and res["off_sentence"] == ""


def test_sun_split_of_a_nishita_sky(case):
    """Blender's Nishita sky (the sun 15 degrees up): the sun is found, the
    removed light's cosine integral at its direction is E per channel
    (0.1 %), no sun-free texel within a diameter is above twice the
    brightest 1 to 3 diameters away, nothing is negative; without its sun
    disc, nothing is split."""
    res, _ = case("sun_nishita", cache=SUN_CACHE)
    disc, nodisc = res["disc"], res["nodisc"]
    sun, checks = disc["sun"], disc["checks"]
    print("nishita: %s; E %s, share %.4f, diameter %.4f, direction %s" % (
        sun["why"], sun.get("illuminance"), sun.get("irradiance_share", 0), sun.get("angular_diameter_deg", 0),
        sun.get("direction")))
    assert sun["found"], sun["why"]
    assert sun["elevation_deg"] == pytest.approx(15.0, abs=0.5)
    np.testing.assert_allclose(checks["removed_cosine"], sun["illuminance"], rtol=1e-3)
    assert checks["negative"] == 0 and checks["inner_max"] <= 2 * checks["ring_max"], checks
    assert not nodisc["sun"]["found"] and nodisc["checks"]["texels_changed"] == 0, nodisc["sun"]["why"]


def test_bake_world_sun_split(tmp_path):
    """bake_world.py --sun split: the manifest's sun and the files, as the CLI's."""
    if not os.path.isfile(SUNSET):
        pytest.skip("Blender's studio lights are not installed")
    opts = ["--face-size", "16", "--irradiance-size", "8", "--lut-size", "16", "--sun", "split"]
    p = bake_world("--hdri", SUNSET, "--out", str(tmp_path / "addon"), *opts)
    assert p.returncode == 0, p.stdout + p.stderr
    subprocess.run([CLI, "bake", SUNSET, "-o", str(tmp_path / "cli"), "-q", *opts], check=True)
    a, c = manifest(tmp_path / "addon"), manifest(tmp_path / "cli")
    assert a["sun"]["found"] and a["options"]["sun"] == "split"
    np.testing.assert_allclose(a["sun"]["illuminance"], c["sun"]["illuminance"], rtol=1e-6)
    np.testing.assert_allclose(a["sun"]["direction"], c["sun"]["direction"], atol=1e-9)
