"""The benchmark's sources: Blender's studiolight HDRIs plus generated ones, in bench/.cache/sources."""
import shutil
import subprocess
from pathlib import Path

from common import CACHE, ROOT, log, run_tool

STUDIOLIGHTS = Path("/usr/share/blender/datafiles/studiolights/world")
QUICK = ["forest", "sunset", "sun_1k", "sun_2k"]


def _oiiotool(*args):
    subprocess.run(["oiiotool", *map(str, args)], check=True, capture_output=True)


def resized(name, w, h):
    """Studiolight `name` resized to w x h (cached)."""
    out = CACHE / "sources" / f"{name}_{w}x{h}.exr"
    if not out.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        _oiiotool(STUDIOLIGHTS / f"{name}.exr", "--resize:filter=triangle", f"{w}x{h}", "-d", "float", "-o", out)
    return out


def generated():
    """name -> path of the generated sources, made when missing."""
    d = CACHE / "sources"
    d.mkdir(parents=True, exist_ok=True)
    out = {"sun_1k": d / "sun_1024x512.exr", "sun_2k": d / "sun_2048x1024.exr",
           "redsun_1k": d / "redsun_1024x512.exr", "checker_2k": d / "checker_2048x1024.exr"}
    for name, w in (("sun_1k", 1024), ("sun_2k", 2048)):
        if not out[name].exists():
            log(f"making the pure sun source {w} x {w // 2}")
            run_tool("sun", w, w // 2, out[name])
    if not out["redsun_1k"].exists():
        log("making the red sun in a blue sky")
        run_tool("redsun", 1024, 512, out["redsun_1k"])
    if not out["checker_2k"].exists():
        log("making the checkerboard source")
        _oiiotool("--pattern", "checker:width=64:height=64:color1=0.01,0.01,0.01:color2=1,1,1", "2048x1024", 3,
                  "-d", "float", "-o", out["checker_2k"])
    out["sunset_2k"] = resized("sunset", 2048, 1024)
    out["sunset_4k"] = resized("sunset", 4096, 2048)
    nishita = d / "nishita_2048x1024.exr"
    if not nishita.exists() and shutil.which("blender"):
        log("rendering the Nishita sky with Blender (Cycles, 32 samples)")
        subprocess.run(["blender", "-b", "--factory-startup", "--python", str(ROOT / "bench" / "nishita_sky.py"), "--",
                        str(nishita), "2048", "32"], check=True, capture_output=True)
    if nishita.exists():
        out["nishita_2k"] = nishita
    else:
        log("no blender: the Nishita sky source is left out")
    # Issue 25's strong, low sun: the same sky with the sun 4 degrees up (a
    # disc of about 1.5e6 in the channel sum, red against the blue sky).
    strong = d / "nishita_strong_2048x1024.exr"
    if not strong.exists() and shutil.which("blender"):
        log("rendering the Nishita sky with a strong, low sun (Cycles, 32 samples)")
        subprocess.run(["blender", "-b", "--factory-startup", "--python", str(ROOT / "bench" / "nishita_sky.py"), "--",
                        str(strong), "2048", "32", "--sun-elevation", "4"], check=True, capture_output=True)
    if strong.exists():
        out["nishita_strong_2k"] = strong
    return out


def all_sources(quick=False):
    """Ordered name -> path: every studiolight, then the generated sources."""
    srcs = {p.stem: p for p in sorted(STUDIOLIGHTS.glob("*.exr"))}
    srcs.update(generated())
    if quick:
        srcs = {k: v for k, v in srcs.items() if k in QUICK}
    return srcs


DESCRIPTIONS = {
    "sun_1k": "pure sun: 0.5 deg disc of 5e4 on a dim sky, 1024 x 512",
    "sun_2k": "pure sun: 0.5 deg disc of 5e4 on a dim sky, 2048 x 1024",
    "nishita_2k": "Nishita sky (Blender's Sky Texture, default sun), Cycles, 2048 x 1024",
    "nishita_strong_2k": "Nishita sky, sun 4 deg up (disc about 1e6 red, 7e4 blue), Cycles, 2048 x 1024",
    "redsun_1k": "red sun: 0.5 deg disc of (5e4, 5e3, 0) in a blue sky of (0.1, 0.3, 1), 1024 x 512",
    "checker_2k": "checkerboard 0.01 / 1, 64 px squares, 2048 x 1024",
    "sunset_2k": "sunset.exr resized to 2048 x 1024",
    "sunset_4k": "sunset.exr resized to 4096 x 2048",
}


def describe(name):
    return DESCRIPTIONS.get(name, f"{name}.exr 1024 x 512")
