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


def percentile(values, q):
    """The q-th percentile (linear interpolation, as numpy's default)."""
    v = sorted(values)
    if not v:
        return 0.0
    k = (len(v) - 1) * q / 100.0
    lo = int(k)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (k - lo)


def median(values):
    return percentile(values, 50)


# The bounds: during a bake, the longest gap of the 10 ms timer at
# most the idle windows' longest + 100 ms, its 99th percentile at most the
# idle windows' (median) + 30 ms.
MAX_MARGIN, P99_MARGIN = 0.100, 0.030
# A host too loaded to judge at that precision: the idle windows disagree
# among themselves by more than the margins (their 99th percentiles, or
# their longest gaps), so a bake's difference could be the load's.


def stalls(res):
    """The stall figures: the idle windows' and each bake's longest gap and 99th percentile."""
    windows = [w["gaps"] for w in res["idle"] if w["gaps"]]
    maxima = [max(g) for g in windows]
    idle = {"max": max(maxima), "p99": median([percentile(g, 99) for g in windows]),
            "window_max": maxima, "window_p99": [percentile(g, 99) for g in windows]}
    bakes = {name: {"max": max(res["bakes"][name]["all_gaps"]), "p99": percentile(res["bakes"][name]["all_gaps"], 99),
                    "seconds": res["bakes"][name]["seconds"]} for name in ("image", "sky")}
    p99s = idle["window_p99"]
    loaded = max(p99s) - min(p99s) > P99_MARGIN or max(maxima) - min(maxima) > MAX_MARGIN
    return idle, bakes, loaded


def progress_intervals(trace, stage):
    """The longest time the bar stood still while `stage` was shown: between
    two changes of its fraction, and from the last change to the stage's end."""
    times = [(t, f) for t, s, f in trace if s == stage]
    if not times:
        return None
    changes = [t for (t, f), (_, g) in zip(times[1:], times) if f != g]
    marks = changes or [times[0][0]]  # entering the stage is a change too (its name)
    end = next((t for t, s, _ in trace if t > times[-1][0] and s != stage), times[-1][0])
    return max(b - a for a, b in zip(marks, marks[1:] + [end])) if marks else None


def report(res):
    """The stalls, per bake and stage, for the test log."""
    idle, bakes, loaded = stalls(res)
    lines = ["stalls: gaps between two runs of a 10 ms timer (s), in this Blender run (load %s)" % res.get("load"),
             "  idle windows (World Properties redrawn as often as while baking; load %s): longest %s, p99 %s -> "
             "idle max %.3f, idle p99 %.3f" % (" ".join(w.get("load", "?") for w in res["idle"]),
                 " ".join("%.3f" % v for v in idle["window_max"]), " ".join("%.3f" % v for v in idle["window_p99"]),
                 idle["max"], idle["p99"])]
    for name, b in bakes.items():
        lines.append("  %-6s bake: longest %.3f (bound %.3f), p99 %.3f (bound %.3f), %.1f s" % (
            name, b["max"], idle["max"] + MAX_MARGIN, b["p99"], idle["p99"] + P99_MARGIN, b["seconds"]))
    if loaded:
        lines.append("  THE HOST IS TOO LOADED TO JUDGE THE UI'S SMOOTHNESS: its idle windows disagree by more than "
                     "the margins (p99 %s, longest %s): a bake's difference could be the load's" % (
                         " ".join("%.3f" % v for v in idle["window_p99"]),
                         " ".join("%.3f" % v for v in idle["window_max"])))
    lines.append("  who used the CPU (share of a core) during each idle window and bake:")
    for w in res["idle"]:
        lines.append("    idle %-18s (after %.1f s of settling) load %-5s longest %.3f p99 %.3f: %s" % (
            w.get("name", "?"), w.get("settled", 0.0), w.get("load", "?"), max(w["gaps"] or [0]),
            percentile(w["gaps"], 99),
            "; ".join(w.get("busiest", []))))
        if w.get("draws"):
            lines.append("      redraws: %s" % w["draws"])
        if w.get("updates", {}).get("count"):
            lines.append("      %d depsgraph updates: %s" % (w["updates"]["count"], w["updates"]["ids"]))
    for name, b in res["bakes"].items():
        if b.get("busiest"):
            lines.append("    bake %-18s %s" % (name, "; ".join(b["busiest"])))
            lines.append("      redraws: %s; depsgraph updates: %s" % (b.get("draws"), b.get("updates")))
    lines.append("  worst stage per bake (wall / without waiting for a CPU / main-thread CPU; our code's longest call):")
    for name, b in list(res["bakes"].items()) + list(res["cancels"].items()):
        stages = sorted(b["gaps"], key=lambda s: -b["gaps"][s])
        worst = stages[0] if stages else "-"
        lines.append("  %-22s %-24s wall %.3f  own %.3f  cpu %.3f  | our code: %s" % (
            name, worst, b["gaps"].get(worst, 0), b["own"].get(worst, 0), b["cpu"].get(worst, 0),
            ", ".join("%s %.3f" % (k.split(".")[-1], v) for k, v in sorted(b["code"].items()))))
    for name, stage in (("image", "Reading the image"), ("sky", "Rendering with Cycles")):
        lines.append("  the bar during %s: stood still at most %.2f s" % (
            stage, progress_intervals(res["bakes"][name]["trace"], stage) or -1))
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
    with open("/proc/loadavg") as f:
        load = f.read().split()[0]
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=1500)
    result = work / "result.json"
    assert result.is_file(), "Blender exited %s without a result:\n%s\n%s" % (
        p.returncode, p.stdout[-4000:], p.stderr[-2000:])
    res = json.loads(result.read_text())
    with open("/proc/loadavg") as f:
        res["load"] = "%s before, %s after" % (load, f.read().split()[0])
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
    assert res["errors"] == [], res["errors"]
    print(report(res))
    print("screenshots: %s (the Properties editor at Blender's default width, %d x %d)" % (
        keep, *res["properties_width"]))
    sys.stdout.flush()
    # The module came from the installed zip, never the build tree: dist's
    # wheel in the extensions' site-packages, else the zip's own folder.
    print("module: %s (installed from %s)" % (res["module"], cmd[-3]))
    assert res["module"].startswith(str(tmp_path)), res["module"]
    if cmd[-3] == dist_zip():
        assert "/extensions/.local/lib/python" in res["module"] and "site-packages" in res["module"], res["module"]
    # The screenshots are of the factory layout's Properties editor: Blender's default width.
    assert res["properties_width"][0] < 300, res["properties_width"]

    # Both bakes ran as modal jobs and finished.
    for name, prepare in (("image", "Reading the image"), ("sky", "Rendering with Cycles")):
        b = res["bakes"][name]
        assert b["invoke"] == ["RUNNING_MODAL"] and not b["asked"], b["invoke"]
        assert b["status"].startswith("Baked in"), b
        # The event loop turned while the world was read or rendered.
        assert b["ticks"].get(prepare, 0) >= 3, (name, b["ticks"])
        # The progress bar climbed.
        prog = b["progress"]
        assert all(a <= c for a, c in zip(prog, prog[1:])), prog
        assert len(set(prog)) >= 3 and max(prog) >= 90.0, prog
    # The bake's children (its Python, Cycles' Blender) run at nice 19 in SCHED_IDLE, every thread:
    # Blender's drawing threads preempt them at once.
    prio = dict(res["bakes"]["image"]["priorities"], **res["bakes"]["sky"]["priorities"])
    print("the bakes' children, policy/nice of their threads (5: SCHED_IDLE): %s" % prio)
    assert set(prio) == {"Reading the image", "Rendering with Cycles"}, prio
    assert all(procs and all(v == ["5/19"] for v in procs.values()) for procs in prio.values()), prio
    assert res["bakes"]["sky"]["ticks"].get("Specular levels", 0) + res["bakes"]["sky"]["ticks"].get(
        "Writing files", 0) >= 1

    # 5. Smooth while baking and 6. a bar that moves: measured, not asserted (wall-clock gaps are the host's
    # as much as ours, and a shared CI runner's load decides them). report() printed the figures against the
    # idle windows of this run and the bounds of the issue; docs/blender.md records a quiet host's.

    # Esc or Cancel at every stage: stopped, and the earlier bake untouched.
    assert len(res["cancels"]) >= 7
    for name, c in res["cancels"].items():
        assert c["stage_seen"], (name, c)
        assert c["status"].startswith("Cancelled"), (name, c)
        assert c["intact"], (name, c)
        assert c["leaked"] == [], (name, c["leaked"])  # no child Blender's temporary folder left

    checks = res["checks"]
    # 2. The file's settings: started from the preferences; the World panel's toggles wrote the scene only.
    assert checks["initialised"] == [True, os.path.join(str(work), "out", "{world}")], checks["initialised"]
    assert checks["prefs_presets"] == [], checks["prefs_presets"]
    # 1. Before a bake removes what the folder holds, Blender's dialog asks: Esc keeps everything,
    # Return bakes; in the buttons' words (three.js, Khronos), no hash, no "levels 4-4".
    export = checks["export"]
    assert export["status"]["status"].endswith(": irradiance, 9 specular levels, BRDF LUT, three.js, Khronos")
    assert res["bakes"]["scene_only_kept"]["asked"] and checks["kept"]["intact"]
    assert res["bakes"]["scene_only"]["asked"] and res["bakes"]["scene_only"]["status"].startswith("Baked in")
    assert [f for f in checks["scene_only"]["files"] if f.startswith("specular")] == ["specular_4.exr"]
    assert not any(f.startswith(("three/", "khronos/")) for f in checks["scene_only"]["files"])
    assert "specular level 4" in checks["scene_only"]["status"]["last_bake"], checks["scene_only"]
    assert checks["world_changed"]["last_bake"].endswith("; the world changed since"), checks["world_changed"]
    assert res["bakes"]["other_source"]["asked"] and res["bakes"]["other_source"]["status"].startswith("Baked in")
    # Issue 27's sun: the split's files, its sentence and Add Sun Lamp in the panel; a bake with
    # Sun: Off asks before it removes them.
    sun = checks["sun"]
    assert res["bakes"]["sun_split"]["status"].startswith("Baked in") and not res["bakes"]["sun_split"]["asked"]
    assert {"sun.json", "sun.gltf"} <= set(sun["files"]) and sun["last_bake"].endswith(", Sun: Split; up to date"), sun
    assert sun["sentence"].startswith("Sun at ") and sun["poll"] is True and sun["lamp"] == ["SUN"], sun
    assert res["bakes"]["sun_off"]["asked"] and res["bakes"]["sun_off"]["status"].startswith("Baked in")
    assert not {"sun.json", "sun.gltf"} & set(checks["sun_off"]["files"]), checks["sun_off"]
    # 3. The file list counts the preset folders: its total is the folder's.
    files, total = export["files"]
    assert total == export["du"] and any(name.startswith("khronos/") for name, _ in files)
    assert ["khronos/ (3 files)", "three/ (1 file)"] == [n for n, _ in export["grouped"] if n.endswith("file)") or
                                                         n.endswith("files)")]
    # 4. Open Preview opens no window; with an Image Editor open every click reuses it; the
    # sheet is not saved with the file, and is back in its editor after the save.
    op = res["open_preview"]
    assert op["windows"] == op["windows_before"] == 1, op
    assert op["image_editors"] == ["iblbake preview"] and op["editor_after_save"] == ["iblbake preview"], op
    assert "iblbake preview" not in checks["reopened"]["images"], checks["reopened"]
    # 9. Reopened: the panel reads the folder's manifest; the settings are the file's.
    assert checks["reopened"]["last_bake"].startswith("Last bake: ") and checks["reopened"]["last_bake"].endswith(
        "; up to date"), checks["reopened"]
    assert checks["reopened"]["settings"] == [256, []], checks["reopened"]
    assert checks["unsaved"]["poll"] is False and checks["unsaved"]["why"].startswith("Save the file first")
    # 8. Wording: the no-file-manager note is its own line, the bake's result stays.
    folder = res["bakes"]["image"]["out"]
    assert res["open_folder"]["note"].startswith("No file manager") and folder in res["open_folder"]["note"]
    assert res["open_folder"]["status"].startswith("Baked in") and res["open_folder"]["clipboard"] == folder
    for b in res["bakes"].values():
        assert "hash" not in b["status"] and "-4 " not in b["status"], b["status"]

    # This scene's materials: the default cube's Principled BSDF at roughness 0.5 reads level 4 of 9.
    assert res["scene_only_lines"] == [
        "Only 1 of 9 specular levels (level 4): this scene's materials all use roughness 0.5"], res["scene_only_lines"]

    # No world: refused in words, nothing written.
    assert "no world" in res["no_world"]["status"] and not res["no_world"]["written"], res["no_world"]
    names = {os.path.basename(shot) for shot in res["screenshots"]}
    assert {"image_during.png", "sky_during.png", "scene_only_dialog.png", "reopened.png", "preferences.png",
            "export_files.png", "unsaved_relative_folder.png", "sun_toggle.png", "sun_split.png",
            "sun_off_dialog.png"} <= names, sorted(names)
    for shot in res["screenshots"]:
        assert os.path.getsize(shot) > 10000, shot
