"""The add-on's two zips (target addon_zip): what each holds, and that their
names say which Blender and which Python they are for."""
import ast
import importlib.machinery
import os
import platform
import re
import sys
import zipfile

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ADDON = os.path.join(HERE, "..", "..", "addon")
ADDON_ZIP = os.environ.get("IBLBAKE_ADDON_ZIP", "")
EXTENSION_ZIP = os.environ.get("IBLBAKE_EXTENSION_ZIP", "")
PY = "%d.%d" % sys.version_info[:2]
MODULE = "iblbake/iblbake_core" + importlib.machinery.EXTENSION_SUFFIXES[0]

sys.path.insert(0, ADDON)
import iblbake  # noqa: E402  (bpy-free: nothing registers)

needs_zips = pytest.mark.skipif(not (ADDON_ZIP and EXTENSION_ZIP), reason="run through CTest (the zips' paths)")


def bl_info_version():
    with open(os.path.join(ADDON, "iblbake", "__init__.py")) as f:
        tree = ast.parse(f.read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and node.targets[0].id == "bl_info":
            return ".".join(map(str, ast.literal_eval(node.value)["version"]))
    raise AssertionError("no bl_info")


def manifest_of(zip_path):
    import tomllib
    with zipfile.ZipFile(zip_path) as z:
        return tomllib.loads(z.read("iblbake/blender_manifest.toml").decode())


@needs_zips
def test_zip_names_say_blender_python_and_platform():
    version = bl_info_version()
    plat = {"x86_64": "linux-x64", "aarch64": "linux-arm64"}.get(platform.machine(), platform.machine())
    assert os.path.basename(ADDON_ZIP) == "iblbake-legacy-addon-%s-python%s-%s.zip" % (version, PY, plat)
    assert os.path.basename(EXTENSION_ZIP) == "iblbake-blender4.2+-extension-%s-python%s-%s.zip" % (version, PY, plat)


@needs_zips
@pytest.mark.parametrize("which", ["addon", "extension"])
def test_zip_holds_one_folder_with_the_module_for_this_python(which):
    path = ADDON_ZIP if which == "addon" else EXTENSION_ZIP
    with zipfile.ZipFile(path) as z:
        names = [n for n in z.namelist() if not n.endswith("/")]
    # one folder: an installer never spreads loose files into the add-ons folder
    assert names and all(n.startswith("iblbake/") for n in names), names
    assert MODULE in names and "iblbake/libiblbake_oiio.so" in names and "iblbake/__init__.py" in names
    assert "iblbake/core/pipeline.py" in names
    assert not any("__pycache__" in n or n.endswith(".pyc") for n in names)
    assert len([n for n in names if "iblbake_core" in n]) == 1
    # the legacy add-on has no manifest (Blender 4.2+ would take it for an extension)
    assert ("iblbake/blender_manifest.toml" in names) == (which == "extension")


@needs_zips
@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib")
def test_extension_manifest_follows_blenders_schema():
    """The fields Blender 4.2+ requires, with the values its validator accepts
    (Blender's own `extension validate` runs in the Blender suite on 4.2+)."""
    m = manifest_of(EXTENSION_ZIP)
    for key in ("schema_version", "id", "version", "name", "tagline", "maintainer", "type",
                "blender_version_min", "license"):
        assert isinstance(m.get(key), (str, list)) and m[key], key
    assert m["schema_version"] == "1.0.0" and m["id"] == "iblbake" and m["type"] == "add-on"
    assert m["version"] == bl_info_version()
    assert re.fullmatch(r"[a-z][a-z0-9_]*", m["id"])
    terse = [m["tagline"], *m.get("permissions", {}).values()]  # Blender: at most 64, no final punctuation
    assert all(len(t) <= 64 and (t[-1].isalnum() or t[-1] in ")]}") for t in terse), terse
    assert tuple(map(int, m["blender_version_min"].split("."))) >= (4, 2, 0)
    assert all(lic.startswith("SPDX:") for lic in m["license"])
    assert os.path.basename(EXTENSION_ZIP).endswith("-%s.zip" % m["platforms"][0]) and len(m["platforms"]) == 1


def test_a_module_for_another_python_is_refused_with_a_clear_reason(tmp_path):
    assert iblbake.python_mismatch(str(tmp_path)) == ""  # a checkout: no module inside, nothing to say
    (tmp_path / "iblbake_core.cpython-313-x86_64-linux-gnu.so").write_bytes(b"")
    assert iblbake.python_mismatch(str(tmp_path), "cpython-313") == ""
    why = iblbake.python_mismatch(str(tmp_path), "cpython-311")
    assert "built for Python 3.13" in why and "runs Python 3.11" in why and "python3.11" in why
