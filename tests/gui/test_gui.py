"""The add-on in a real Blender window under Xvfb (gui_session.py drives it):
installed from the built zip, baked from the panel's operator in its modal
(invoke) form for an 8K image world and a Sky Texture world, stopped with Esc
and with Cancel at each stage, refused without a world.

Asserts what a person would see: the event loop keeps turning while the
world is read or rendered (a 10 ms timer fires during those stages), the
progress property climbs, every stop leaves the earlier bake as it was.
Prints the longest stalls it measured (wall clock is never asserted: this
machine is shared) and keeps the screenshots in build/tests/gui/."""
import json
import os
import re
import shutil
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
BUILD = os.environ.get("IBLBAKE_BUILD_DIR", os.path.join(ROOT, "build"))
BLENDER = os.environ.get("BLENDER", shutil.which("blender") or "blender")
FOREST = "/usr/share/blender/datafiles/studiolights/world/forest.exr"
SIZE = (1280, 1024)
TOOLS = ("Xvfb", "import", "xdotool", "oiiotool")

missing = [t for t in TOOLS if shutil.which(t) is None]
pytestmark = pytest.mark.skipif(bool(missing), reason="needs %s (scripts/install_deps.sh, GUI group)" % missing)


def big_exr():
    """forest.exr resized to 8192 x 4096 (half float), made once."""
    path = os.path.join(BUILD, "tests", "gui-data", "forest_8k.exr")
    if not os.path.isfile(path):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        subprocess.run(["oiiotool", FOREST, "--resize", "8192x4096", "-d", "half", "-o", path + ".tmp.exr"],
                       check=True)
        os.replace(path + ".tmp.exr", path)
    return path


@pytest.fixture
def xvfb():
    """A private X server; yields its DISPLAY."""
    proc = subprocess.Popen(["Xvfb", "-displayfd", "1", "-screen", "0", "%dx%dx24" % SIZE, "-nolisten", "tcp"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        number = proc.stdout.readline().strip()
        assert number.isdigit(), "Xvfb did not start"
        yield ":" + number
    finally:
        proc.terminate()
        proc.wait(10)


def blender_version():
    out = subprocess.run([BLENDER, "--version"], capture_output=True, text=True, timeout=120).stdout
    m = re.search(r"Blender (\d+)\.(\d+)", out)
    assert m, out[:300]
    return int(m.group(1)), int(m.group(2))


def dist_zip():
    """scripts/package.sh's extension zip (self-contained wheels), when dist/ has one."""
    dist = os.path.join(ROOT, "dist")
    zips = sorted(p for p in os.listdir(dist) if p.startswith("iblbake-") and p.endswith(".zip")) \
        if os.path.isdir(dist) else []
    return os.path.join(dist, zips[-1]) if zips else None


def addon_zip():
    """The zip a user of this Blender installs: on 4.2+ the self-contained
    extension of dist/ when there is one (scripts/check_fresh.sh copies it
    in), else the build's extension; before 4.2 the build's add-on zip."""
    if blender_version() >= (4, 2) and dist_zip():
        return dist_zip()
    zips = sorted(p for p in os.listdir(BUILD) if p.startswith("iblbake-") and p.endswith(".zip"))
    want_extension = blender_version() >= (4, 2)
    zips = [p for p in zips if ("extension" in p) == want_extension]
    assert zips, "build the addon_zip target first"
    return os.path.join(BUILD, zips[-1])


def report(res):
    """The stalls, per bake and stage, for the test log."""
    lines = ["longest gap between two runs of a 10 ms timer (s): wall / without waiting for a CPU / "
             "main-thread CPU; and the longest call of our main-thread code"]
    base = res.get("baseline", {})
    for key, label in (("gaps", "wall"), ("own", "own"), ("cpu", "cpu")):
        if base.get(key):
            lines.append("  redraws alone, no bake: %s %.3f" % (label, max(base[key].values())))
    for name, b in list(res["bakes"].items()) + list(res["cancels"].items()):
        stages = sorted(b["gaps"], key=lambda s: -b["gaps"][s])
        worst = stages[0] if stages else "-"
        lines.append("  %-22s worst stage %-32s wall %.3f  own %.3f  cpu %.3f  | our code: %s" % (
            name, worst, b["gaps"].get(worst, 0), b["own"].get(worst, 0), b["cpu"].get(worst, 0),
            ", ".join("%s %.3f" % (k.split(".")[-1], v) for k, v in sorted(b["code"].items()))))
    return "\n".join(lines)


def test_panel_bakes_live_and_stops_at_every_stage(tmp_path, xvfb):
    work = tmp_path / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("IBLBAKE_CORE_DIR", "PYTHONPATH")}
    env.update(DISPLAY=xvfb, BLENDER_USER_SCRIPTS=str(tmp_path / "scripts"),
               BLENDER_USER_EXTENSIONS=str(tmp_path / "extensions"), BLENDER_USER_CONFIG=str(tmp_path / "config"),
               IBLBAKE_CACHE_DIR=str(tmp_path / "cache"))
    cmd = [BLENDER, "--factory-startup", "-p", "0", "0", str(SIZE[0]), str(SIZE[1]), "--python",
           os.path.join(HERE, "gui_session.py"), "--", addon_zip(), str(work), big_exr()]
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=1500)
    result = work / "result.json"
    assert result.is_file(), "Blender exited %s without a result:\n%s\n%s" % (
        p.returncode, p.stdout[-4000:], p.stderr[-2000:])
    res = json.loads(result.read_text())
    keep = os.path.join(BUILD, "tests", "gui")
    os.makedirs(keep, exist_ok=True)
    for old in os.listdir(keep):  # an earlier run's screenshots never pass for this run's
        if old.endswith(".png"):
            os.remove(os.path.join(keep, old))
    for shot in res["screenshots"]:
        if os.path.isfile(shot):
            shutil.copy(shot, keep)
    with open(os.path.join(keep, "result.json"), "w") as f:
        json.dump(res, f, indent=1)
    print(report(res))
    print("screenshots: %s" % keep)
    sys.stdout.flush()
    assert res["errors"] == [], res["errors"]
    # The module came from the installed zip, never the build tree: dist's
    # wheel in the extensions' site-packages, else the zip's own folder.
    print("module: %s (installed from %s)" % (res["module"], cmd[-3]))
    assert res["module"].startswith(str(tmp_path)), res["module"]
    if cmd[-3] == dist_zip():
        assert "/extensions/.local/lib/python" in res["module"] and "site-packages" in res["module"], res["module"]

    # Both bakes ran as modal jobs and finished.
    for name, prepare in (("image", "Reading the world image"), ("sky", "Rendering the world with Cycles")):
        b = res["bakes"][name]
        assert b["invoke"] == ["RUNNING_MODAL"], b
        assert b["status"].startswith("Baked in"), b
        # The event loop turned while the world was read or rendered.
        assert b["ticks"].get(prepare, 0) >= 3, (name, b["ticks"])
        # The progress bar climbed.
        prog = b["progress"]
        assert all(a <= c for a, c in zip(prog, prog[1:])), prog
        assert len(set(prog)) >= 3 and max(prog) >= 90.0, prog
    assert res["bakes"]["sky"]["ticks"].get("Specular levels", 0) + res["bakes"]["sky"]["ticks"].get(
        "Writing files", 0) >= 1

    # Esc or Cancel at every stage: stopped, and the earlier bake untouched.
    assert len(res["cancels"]) >= 7
    for name, c in res["cancels"].items():
        assert c["stage_seen"], (name, c)
        assert c["status"].startswith("Cancelled"), (name, c)
        assert c["intact"], (name, c)

    # Open Output Folder without a file manager says where the files are; Open Preview shows the sheet.
    folder = res["bakes"]["image"]["out"]
    assert "No file manager" in res["open_folder"]["status"] and folder in res["open_folder"]["status"], res
    assert res["open_folder"]["clipboard"] == folder
    assert "iblbake preview" in res["open_preview"]["image_editors"], res["open_preview"]

    # This scene's materials: the default cube's Principled BSDF at roughness 0.5 reads level 4 of 9.
    assert res["scene_only_lines"] == [
        "Only 1 of 9 specular levels (level 4): this scene's materials all use roughness 0.5"], res["scene_only_lines"]

    # No world: refused in words, nothing written.
    assert "no world" in res["no_world"]["status"] and not res["no_world"]["written"], res["no_world"]
    names = {os.path.basename(shot) for shot in res["screenshots"]}
    assert {"image_during.png", "sky_during.png"} <= names, sorted(names)
    for shot in res["screenshots"]:
        assert os.path.getsize(shot) > 10000, shot
