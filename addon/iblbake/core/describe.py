"""Plain words for the panel (no bpy): what a bake will skip and why, a long
path shortened in the middle, file lists and sizes."""
import json
import os
import stat
from typing import List, Optional, Tuple

from . import options
from .needs import Needs

MAX_MANIFEST_BYTES = 64 << 20  # as the core's io::kMaxManifestBytes


def _levels(n: int) -> str:
    return "%d specular level%s" % (n, "" if n == 1 else "s")


def _roughness_words(lo: float, hi: float) -> str:
    if abs(hi - lo) < 1e-6:
        return "all use roughness %.2g" % lo
    return "use roughness %.2g to %.2g" % (lo, hi)


def needs_sentences(needs: Needs, mip_count: int, scene_only: bool, presets: Tuple[str, ...] = ()) -> List[str]:
    """What the bake will hold, in words an artist reads at a glance, e.g.
    "Only 1 of 9 specular levels: this scene's materials all use roughness 0.5"."""
    if not scene_only:
        return ["Everything: irradiance, all %s, the BRDF LUT" % _levels(mip_count)]
    if presets:
        return ["Everything: the engines ticked (%s) need every level"
                % ", ".join(options.choice_label("presets", p) for p in presets)]
    if not needs.analysed:
        return ["Everything: no visible object to read materials from"]
    out = []
    if not needs.irradiance:
        out.append("No irradiance: no visible material is diffuse")
    if not needs.specular:
        out.append("No specular and no LUT: no visible material is glossy")
    elif needs.levels is not None:
        first, last = needs.levels
        count = last - first + 1
        lo, hi = needs.roughness
        if count < mip_count:
            out.append("Only %d of %d specular levels (%s): this scene's materials %s"
                       % (count, mip_count, ("level %d" % first) if count == 1 else ("levels %d-%d" % (first, last)),
                          _roughness_words(lo, hi)))
        else:
            out.append("All %s: this scene's materials %s" % (_levels(mip_count), _roughness_words(lo, hi)))
    if not out:
        out.append("Everything: this scene's materials use all of it")
    return out


def sun_sentence(sun) -> str:
    """What a bake with sun="split" found, as the panel says it: "Sun at 34°
    elevation, 0.6° across, 92 % of the direct light" (the light's share of
    the light on a surface facing it), or "No sun found"; "" for a bake
    that did not look (sun is None)."""
    if not isinstance(sun, dict):
        return ""
    if not sun.get("found"):
        return "No sun found"
    return "Sun at %.0f\u00b0 elevation, %s\u00b0 across, %.0f %% of the direct light" % (
        sun.get("elevation_deg", 0.0), _short(sun.get("angular_diameter_deg", 0.0)),
        100.0 * sun.get("irradiance_share", 0.0))


def _short(x: float) -> str:
    """A small angle with two significant digits: 0.53, 1.2, 12."""
    return "%.2g" % x if x < 10 else "%.0f" % x


def shorten_middle(text: str, max_chars: int) -> str:
    """`text` in at most max_chars characters, cut in the middle ("/home/a/…/ibl/World")
    so that its end (the folder's own name) stays visible."""
    max_chars = max(5, int(max_chars))
    if len(text) <= max_chars:
        return text
    keep = max_chars - 1
    tail = (keep * 2 + 2) // 3  # the end matters most
    head = keep - tail
    return text[:head] + "\u2026" + text[len(text) - tail:]


def human_size(n: int) -> str:
    size = float(n)
    for unit in ("B", "KB", "MB", "GB"):
        if size < 1024 or unit == "GB":  # three digits at most: "261 KB", "1.9 MB"
            return ("%d %s" % (size, unit)) if unit == "B" or size >= 100 else ("%.1f %s" % (size, unit))
        size /= 1024.0
    return "%d B" % n


def bake_files(out_dir: str) -> Tuple[List[Tuple[str, int]], int]:
    """([(path relative to out_dir, bytes)], total bytes) of a bake's folder,
    the files of its engine presets' folders included ("three/specular.ktx2"),
    the manifest first."""
    files = []
    try:
        names = sorted(os.listdir(out_dir))
    except OSError:
        return [], 0
    for name in names:
        path = os.path.join(out_dir, name)
        if os.path.isfile(path):
            files.append((name, os.path.getsize(path)))
        elif os.path.isdir(path) and not name.startswith("."):
            for root, _dirs, inner in os.walk(path):
                for f in sorted(inner):
                    full = os.path.join(root, f)
                    if os.path.isfile(full):
                        files.append((os.path.relpath(full, out_dir).replace(os.sep, "/"), os.path.getsize(full)))
    files.sort(key=lambda e: (e[0] != "manifest.json", e[0] != "preview.png", "/" in e[0], e[0]))
    return files, sum(s for _, s in files)


def manifest_of(out_dir: str) -> Optional[dict]:
    """A bake's manifest.json, read as the core reads it: only a regular
    file, not through a link, without blocking (a FIFO named so would hang
    Blender), at most 64 MB; None otherwise."""
    try:
        fd = os.open(os.path.join(out_dir, "manifest.json"),
                     os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        with os.fdopen(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                return None
            text = f.read(MAX_MANIFEST_BYTES + 1)
            if len(text) > MAX_MANIFEST_BYTES:
                return None
            return json.loads(text)
    except (OSError, ValueError):
        return None


def files_words(n: int) -> str:
    return "%d file%s" % (n, "" if n == 1 else "s")


def grouped_files(files: List[Tuple[str, int]]) -> List[Tuple[str, int]]:
    """A bake's files for a short list: the specular levels of one extension
    as one line ("specular_0-8.exr"), an engine preset's folder as one line
    ("three/ (2 files)"), the others one by one."""
    out, levels, folders = [], {}, {}
    for name, size in files:
        if "/" in name:
            folders.setdefault(name.split("/", 1)[0], []).append(size)
            continue
        stem, ext = os.path.splitext(name)
        if stem.startswith("specular_") and stem[9:].isdigit():
            levels.setdefault(ext, []).append((int(stem[9:]), size))
            continue
        out.append((name, size))
    for ext, items in sorted(levels.items()):
        items.sort()
        if len(items) == 1:
            out.append(("specular_%d%s" % (items[0][0], ext), items[0][1]))
        else:
            out.append(("specular_%s%s" % (level_ranges([m for m, _ in items], "-", ","), ext),
                        sum(s for _, s in items)))
    for folder, sizes in sorted(folders.items()):
        out.append(("%s/ (%s)" % (folder, files_words(len(sizes))), sum(sizes)))
    return out


def level_ranges(levels, dash: str = "-", sep: str = " and ") -> str:
    """[0, 1, 2, 3, 5, 6] -> "0-3 and 5-6"."""
    runs = []
    for m in sorted(set(levels)):
        if runs and m == runs[-1][1] + 1:
            runs[-1][1] = m
        else:
            runs.append([m, m])
    return sep.join(("%d" % a) if a == b else ("%d%s%d" % (a, dash, b)) for a, b in runs)


def levels_words(levels) -> str:
    """ "specular level 4", "9 specular levels" (0-8), "specular levels 1-2", "specular levels 0-3 and 5-8"."""
    levels = sorted(set(levels))
    if len(levels) == 1:
        return "specular level %d" % levels[0]
    if levels and levels[0] == 0 and levels[-1] == len(levels) - 1:
        return "%d specular levels" % len(levels)
    return "specular levels " + level_ranges(levels)


def and_list(words) -> str:
    """["a", "b", "c"] -> "a, b and c"."""
    words = list(words)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1] if words else ""


def thumbnail(linear_rgb, width: int = 256):
    """A small display-encoded (sRGB) RGBA copy of an image read linear
    (iblbake_core.read_image of preview.png), rows bottom-up as Blender's
    previews hold them: (h, width, 4) float32. Box filtered; numpy only, so a
    worker thread makes it."""
    import numpy as np
    img = np.asarray(linear_rgb, dtype=np.float32)
    h, w = img.shape[:2]
    width = max(1, min(width, w))
    height = max(1, int(round(h * width / w)))
    ys = (np.arange(height + 1) * h // height).astype(int)
    xs = (np.arange(width + 1) * w // width).astype(int)
    rows = np.add.reduceat(img, ys[:-1], axis=0) / np.diff(ys)[:, None, None]
    small = np.add.reduceat(rows, xs[:-1], axis=1) / np.diff(xs)[None, :, None]
    small = np.clip(small, 0.0, 1.0)
    enc = np.where(small <= 0.0031308, small * 12.92, 1.055 * np.power(small, 1 / 2.4) - 0.055)
    out = np.ones((height, width, 4), np.float32)
    out[..., :3] = enc
    return np.ascontiguousarray(out[::-1])
