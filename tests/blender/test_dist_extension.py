"""dist/'s extension zip (scripts/package.sh: the self-contained wheels) in
this Blender, as a user installs it: Blender's own `extension validate` and
`extension install-file`, then bakes through the installed extension alone
(no checkout on the path, no build tree): a plain-colour world, and an HDRI
world through blender_scripts/bake_world.py, whose files must equal, bit for
bit, the same bake by this checkout's add-on with the build's module.

Runs on Blender 4.2+ when dist/ holds the zip: scripts/check_fresh.sh copies
it into the trixie (Blender 4.3) and sid (Blender 5.2) checks; elsewhere it
is skipped, saying why."""
import os
import re
import shutil
import subprocess
import sys
import zipfile

import pytest

from blender_helpers import BAKE_WORLD, BLENDER, FOREST, ROOT, bake_world, blender_version, manifest
from test_addon import BAKE_PLAIN, blender_script, check_plain_bake, isolated_env

sys.path.insert(0, os.path.join(ROOT, "tests", "wheels"))
from compare_bakes import compare  # noqa: E402

DIST = os.path.join(ROOT, "dist")


def dist_zip():
    names = sorted(n for n in os.listdir(DIST) if n.startswith("iblbake-") and n.endswith(".zip")) \
        if os.path.isdir(DIST) else []
    return os.path.join(DIST, names[-1]) if names else None


pytestmark = [
    pytest.mark.skipif(blender_version() < (4, 2), reason="extensions are Blender 4.2+ (this is %d.%d)"
                       % blender_version()[:2]),
    pytest.mark.skipif(dist_zip() is None, reason="no extension zip in dist/ (scripts/package.sh makes it; "
                       "scripts/check_fresh.sh copies it into the trixie and sid checks)"),
]


def python_tag():
    out = subprocess.run([BLENDER, "-b", "--factory-startup", "--python-expr",
                          "import sys; print('PYTAG=cp%d%d' % sys.version_info[:2])"],
                         capture_output=True, text=True, timeout=300).stdout
    return re.search(r"PYTAG=(cp\d+)", out).group(1)


def test_the_zip_carries_a_wheel_for_this_blenders_python():
    """What Blender's validator does not check (it never opens the wheels):
    each wheel the manifest lists is in the zip, is tagged cpXY-cpXY-manylinux_*_x86_64,
    holds the module for its Python and a RECORD; one is for this Blender's Python."""
    import tomllib
    with zipfile.ZipFile(dist_zip()) as z:
        names = set(z.namelist())
        m = tomllib.loads(z.read("iblbake/blender_manifest.toml").decode())
        assert m["platforms"] == ["linux-x64"]
        tags = []
        for w in m["wheels"]:
            assert w.startswith("./wheels/") and "iblbake/" + w[2:] in names, w
            tag = re.fullmatch(r"\./wheels/iblbake_core-[\d.]+-(cp3\d+)-(cp3\d+)-manylinux_2_(\d+)_x86_64\.whl", w)
            assert tag and tag.group(1) == tag.group(2), w
            tags.append(tag.group(1))
            with zipfile.ZipFile(z.open("iblbake/" + w[2:])) as wheel:
                inner = wheel.namelist()
                assert "iblbake_core.cpython-%s-x86_64-linux-gnu.so" % tag.group(1)[2:] in inner, inner
                assert any(n.endswith(".dist-info/RECORD") for n in inner), inner
    assert sorted(tags) == ["cp311", "cp313", "cp314"], tags
    assert python_tag() in tags


def install(tmp_path):
    """validate, then install-file -r user_default -e into a fresh user folder."""
    env = isolated_env(tmp_path)
    env["BLENDER_USER_EXTENSIONS"] = str(tmp_path / "user" / "extensions")
    p = subprocess.run([BLENDER, "--factory-startup", "--command", "extension", "validate", dist_zip()],
                       capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    p = subprocess.run([BLENDER, "-b", "--offline-mode", "--command", "extension", "install-file", "-r",
                        "user_default", "-e", dist_zip()], capture_output=True, text=True, env=env, timeout=300)
    # install-file exits 0 even when it refuses a package: its words tell.
    assert p.returncode == 0 and re.search(r'Installed "iblbake"', p.stdout + p.stderr), p.stdout + p.stderr
    return env


def site_packages(tmp_path):
    return str(tmp_path / "user" / "extensions" / ".local" / "lib")


def test_installed_extension_bakes_with_its_wheel(tmp_path):
    env = install(tmp_path)
    pkg = "bl_ext.user_default.iblbake"
    p = blender_script(tmp_path, "import bpy\nassert %r in bpy.context.preferences.addons, "
                       "list(bpy.context.preferences.addons.keys())\n" % pkg
                       + BAKE_PLAIN.format(pkg=pkg, out=str(tmp_path / "out" / "{world}")), env, factory=False)
    check_plain_bake(tmp_path, p, site_packages(tmp_path))
    module = [line for line in p.stdout.splitlines() if line.startswith("MODULE=")][0][7:]
    assert "/site-packages/iblbake_core.cpython-" in module, module


def test_bake_world_through_the_installed_extension_equals_the_checkouts_bake(tmp_path):
    """bake_world.py copied out of the checkout (so it enables the installed
    extension, not addon/) bakes Blender's forest.exr with every engine
    preset; the same command with this checkout's add-on and the build's
    module gives the same files (EXR and PNG by pixels, the rest by bytes)."""
    env = install(tmp_path)
    script = tmp_path / "bake_world.py"
    shutil.copy(BAKE_WORLD, script)
    args = ["--hdri", FOREST, "--preset", "three,khronos,filament,babylon,bevy,unity,source", "--face-size", "64"]
    p = subprocess.run([BLENDER, "-b", "--python-exit-code", "1", "--python", str(script), "--", *args,
                        "--out", str(tmp_path / "ext")], capture_output=True, text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    p = bake_world(*args, "--out", str(tmp_path / "dev"))
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    ext, dev = manifest(tmp_path / "ext"), manifest(tmp_path / "dev")
    assert ext["blender"]["path"] == dev["blender"]["path"] == "environment_texture"
    diffs, how = compare(str(tmp_path / "dev"), str(tmp_path / "ext"))
    assert diffs == [], diffs
    assert how["bytes"] + how["pixels"] >= 20, how


def test_a_world_the_wheel_cannot_read_comes_from_blenders_buffer(tmp_path):
    """The wheels read OpenEXR, PNG, JPEG and Radiance .hdr, not TIFF (no
    OpenImageIO plugin in a wheel): the panel's bake, which reads an EXR or
    .hdr world from its file on a worker thread, takes a .tif world's
    pixels from Blender's own decoder instead (world_reader.file_read_plan
    says None); and headless, the .hdr bakes the same lighting as the EXR
    it was made from (RGBE keeps 8 bits of mantissa: within 1 %)."""
    if shutil.which("oiiotool") is None:
        pytest.skip("needs oiiotool (openimageio-tools, scripts/install_deps.sh)")
    hdr, tif = tmp_path / "forest.hdr", tmp_path / "forest.tif"
    subprocess.run(["oiiotool", FOREST, "-o", str(hdr)], check=True)
    subprocess.run(["oiiotool", FOREST, "-d", "float", "-o", str(tif)], check=True)
    env = install(tmp_path)
    pkg = "bl_ext.user_default.iblbake"
    plans = ("import bpy, importlib\n"
             "wr = importlib.import_module(%r + '.world_reader')\n"
             "for path in (%r, %r, %r):\n"
             "    world = bpy.context.scene.world\n"
             "    nt = world.node_tree\n"
             "    env = nt.nodes.new('ShaderNodeTexEnvironment')\n"
             "    env.image = bpy.data.images.load(path)\n"
             "    if path.endswith('.tif'):  # Blender calls a float TIFF sRGB, which Cycles would render\n"
             "        names = [i.identifier for i in env.image.colorspace_settings.bl_rna.properties['name'].enum_items]\n"
             "        env.image.colorspace_settings.name = 'Linear Rec.709' if 'Linear Rec.709' in names else 'Linear'\n"
             "    nt.links.new(env.outputs['Color'], nt.nodes['Background'].inputs['Color'])\n"
             "    plan = wr.file_read_plan(wr.classify(world, check_image=True))\n"
             "    print('PLAN %%s %%s' %% (path.rsplit('.', 1)[1], 'file' if plan else 'blender'))\n"
             % (pkg, str(hdr), str(tif), FOREST))
    p = blender_script(tmp_path, plans, env, factory=False)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    for plan in ("PLAN hdr file", "PLAN tif blender", "PLAN exr file"):
        assert plan in p.stdout, p.stdout[-2000:]
    script = tmp_path / "bake_world.py"
    shutil.copy(BAKE_WORLD, script)
    for src, out in ((hdr, "hdr"), (FOREST, "exr")):
        p = subprocess.run([BLENDER, "-b", "--python-exit-code", "1", "--python", str(script), "--", "--hdri",
                            str(src), "--face-size", "32", "--out", str(tmp_path / out)],
                           capture_output=True, text=True, env=env, timeout=600)
        assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    h, e = manifest(tmp_path / "hdr"), manifest(tmp_path / "exr")
    assert h["blender"]["path"] == e["blender"]["path"] == "environment_texture"
    assert h["mean_radiance"] == pytest.approx(e["mean_radiance"], rel=0.01)

