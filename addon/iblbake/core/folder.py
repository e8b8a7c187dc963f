"""A bake's folder as the panel and the Bake operator see it, without bpy:
what its manifest says it holds (FolderBake), what a new bake would write
(Outputs), what that bake would remove from it, and the panel's "Last bake"
line. A bake replaces its whole folder (native/src/io/output_dir.cpp), so
whatever the new bake does not write again is gone afterwards: the panel
asks first, the headless paths say what went."""
import os
import time
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

from . import describe, options
from .world import COLOR, IMAGE, RENDER


@dataclass(frozen=True)
class Outputs:
    """What a bake holds, by kind (not by file name)."""
    irradiance: bool = False
    levels: Tuple[int, ...] = ()       # specular levels
    lut: bool = False
    presets: Tuple[str, ...] = ()      # engine presets (their folders)
    preview: bool = False
    formats: Tuple[str, ...] = ("exr",)
    sun: bool = False                  # the sun as a light (sun.json, sun.gltf: Sun: Split, issue 27)

    def words(self) -> str:
        """ "irradiance, 9 specular levels, BRDF LUT, three.js" (the panel's terms)."""
        out = []
        if self.irradiance:
            out.append("irradiance")
        if self.levels:
            out.append(describe.levels_words(self.levels))
        if self.lut:
            out.append("BRDF LUT")
        out += [options.choice_label("presets", p) for p in options.in_table_order("presets", self.presets)]
        if self.sun:
            out.append("Sun: Split")
        return ", ".join(out) or "nothing"


def outputs_of_manifest(m: dict) -> Outputs:
    files = m.get("files") if isinstance(m.get("files"), dict) else {}
    formats = sorted({os.path.splitext(f)[1][1:] for f in files if "/" not in f and f != "preview.png"}
                     & {"exr", "png"})
    spec = [e.get("level") for e in m.get("specular") or [] if isinstance(e, dict)]
    return Outputs(irradiance=bool(m.get("irradiance")), levels=tuple(sorted(v for v in spec if isinstance(v, int))),
                   lut=bool(m.get("brdf_lut")), presets=tuple(sorted(m.get("presets") or {})),
                   preview=bool(m.get("preview")), formats=tuple(formats) or ("exr",),
                   sun=isinstance(m.get("sun"), dict))


def planned_outputs(opts: dict, mip_count: int) -> Outputs:
    """What a bake of these native options (core.pipeline.native_options) writes."""
    levels = ()
    if opts.get("specular"):
        first, last = opts.get("first_level", 0), opts.get("last_level", -1)
        last = mip_count - 1 if last is None or last < 0 else last
        levels = tuple(range(first, min(last, mip_count - 1) + 1))
    return Outputs(irradiance=bool(opts.get("irradiance")), levels=levels, lut=bool(opts.get("lut")),
                   presets=tuple(sorted(p.split(":")[0] for p in opts.get("presets") or [])),
                   preview=bool(opts.get("preview")), formats=tuple(sorted(opts.get("formats") or ["exr"])),
                   sun=opts.get("sun") == "split")


# -- where a bake came from ------------------------------------------------------
def source_of(source) -> Tuple[tuple, str]:
    """(key, words) of a core.world.WorldSource: two bakes of one key are of
    the same world (Strength or a Mapping changed is the same source, updated)."""
    if source.path == IMAGE:
        where = source.image_path or source.image_name
        return ("image", where), os.path.basename(where) or source.image_name
    if source.path == COLOR:
        return ("colour", source.world), "the plain colour of world '%s'" % source.world
    return ("render", source.world), "world '%s' rendered by Cycles" % source.world


def source_of_manifest(m: dict) -> Tuple[tuple, str]:
    b = m.get("blender")
    if isinstance(b, dict):
        path, world = b.get("path"), b.get("world")
        if path == IMAGE:
            image = b.get("image") or {}
            where = image.get("filepath") or image.get("name") or ""
            return ("image", where), os.path.basename(where) or str(image.get("name"))
        if path == COLOR:
            return ("colour", world), "the plain colour of world '%s'" % world
        return ("render", world), "world '%s' rendered by Cycles" % world
    where = str((m.get("source") or {}).get("path") or "")
    return ("image", where), (os.path.basename(where) or "an image") + " (by the command line)"


@dataclass
class FolderBake:
    """The bake a folder holds, from its manifest."""
    out_dir: str
    manifest: dict
    modified: float                        # the manifest's mtime: when it was baked
    outputs: Outputs
    source_key: tuple
    source_words: str
    files: List[Tuple[str, int]] = field(default_factory=list)  # (relative path, bytes), from the manifest

    @property
    def blender(self) -> dict:
        b = self.manifest.get("blender")
        return b if isinstance(b, dict) else {}

    @property
    def total_bytes(self) -> int:
        return sum(size for _, size in self.files)


def read_folder(out_dir: str) -> Optional[FolderBake]:
    """The folder's bake, or None when it holds none (or a manifest that is not iblbake's)."""
    path = os.path.join(out_dir, "manifest.json")
    m = describe.manifest_of(out_dir)
    if not isinstance(m, dict) or m.get("generator") != "iblbake":
        return None
    try:
        modified = os.stat(path).st_mtime
    except OSError:
        return None
    files = m.get("files") if isinstance(m.get("files"), dict) else {}
    listed = sorted((str(name), int(e.get("bytes", 0)) if isinstance(e, dict) else 0) for name, e in files.items())
    key, words = source_of_manifest(m)
    return FolderBake(out_dir, m, modified, outputs_of_manifest(m), key, words, listed)


# -- what a bake would remove ------------------------------------------------------
def _kept(name: str, new: Outputs) -> bool:
    """Whether a bake of `new` writes `name` (a path in the folder) again."""
    if "/" in name:
        return name.split("/", 1)[0] in new.presets  # a preset's folder, as a whole
    if name == "preview.png":
        return new.preview
    if name in ("sun.json", "sun.gltf"):
        return new.sun
    stem, ext = os.path.splitext(name)
    ext = ext[1:]
    if stem == "irradiance":
        return new.irradiance and ext in new.formats
    if stem == "brdf_lut":
        return new.lut and ext in new.formats
    if stem.startswith("specular_") and stem[9:].isdigit():
        return int(stem[9:]) in new.levels and ext in new.formats
    return True  # the manifest and anything iblbake does not name: not counted


def _what(name: str) -> str:
    """The kind of output a file is, for grouping."""
    if "/" in name:
        return "preset:" + name.split("/", 1)[0]
    stem = os.path.splitext(name)[0]
    if stem.startswith("specular_") and stem[9:].isdigit():
        return "level"
    return stem


def losses(old: FolderBake, new: Outputs, source=None) -> List[str]:
    """What a bake of `new` (of `source`, a WorldSource, when given) removes
    from `old`'s folder, one sentence per kind, with sizes; [] when nothing
    the folder's bake holds would go."""
    gone = [(name, size) for name, size in old.files if not _kept(name, new)]
    out = []
    if source is not None:
        key, words = source_of(source)
        if key != old.source_key:
            out.append("the bake of %s (%s, %s)" % (old.source_words, when(old.modified),
                                                  describe.human_size(old.total_bytes)))
    groups = {}
    for name, size in gone:
        groups.setdefault(_what(name), []).append((name, size))

    def sized(text, items):
        return "%s (%s)" % (text, describe.human_size(sum(s for _, s in items)))
    levels = groups.pop("level", [])
    if levels:
        numbers = sorted({int(os.path.splitext(n)[0][9:]) for n, _ in levels})
        kept_numbers = [m for m in numbers if m in new.levels]  # only a format of them goes
        text = describe.levels_words(numbers)
        if kept_numbers:
            text += " as %s" % "/".join(sorted({os.path.splitext(n)[1][1:].upper() for n, _ in levels}))
        out.append(sized(text, levels))
    for key, text in (("irradiance", "the irradiance"), ("brdf_lut", "the BRDF LUT"), ("preview", "the preview sheet"),
                      ("sun", "the sun's files")):
        if key in groups:
            out.append(sized(text, groups.pop(key)))
    presets = sorted(k for k in groups if k.startswith("preset:"))
    if presets:
        labels = [options.choice_label("presets", p) for p in options.in_table_order("presets", [k[7:] for k in presets])]
        items = [item for k in presets for item in groups.pop(k)]
        out.append(sized("the %s folder%s" % (describe.and_list(labels), "s" if len(labels) > 1 else ""), items))
    return out


def when(timestamp: float, now: Optional[float] = None) -> str:
    """A bake's date as the panel says it: "14:03 today", "12 May 14:03", "12 May 2023"."""
    now = time.time() if now is None else now
    t, n = time.localtime(timestamp), time.localtime(now)
    if t.tm_year != n.tm_year:
        return time.strftime("%d %b %Y", t).lstrip("0")
    if t[:3] == n[:3]:
        return time.strftime("%H:%M today", t)
    return time.strftime("%d %b %H:%M", t).lstrip("0")


# -- the panel's "Last bake" line -----------------------------------------------
UP_TO_DATE = "up to date"
WORLD_CHANGED = "the world changed since"
SETTINGS_CHANGED = "the settings changed since"


def freshness(old: FolderBake, world_fingerprint: Optional[str], settings_hash: Optional[str]) -> str:
    """Whether the folder's bake is what a bake now would make: "" when it
    cannot tell (a bake by the command line or an older add-on)."""
    b = old.blender
    if not b.get("world_fingerprint") or world_fingerprint is None:
        return ""
    if b["world_fingerprint"] != world_fingerprint:
        return WORLD_CHANGED
    if settings_hash is not None and b.get("settings_hash") and b["settings_hash"] != settings_hash:
        return SETTINGS_CHANGED
    return UP_TO_DATE


def last_bake_line(old: FolderBake, fresh: str, now: Optional[float] = None) -> str:
    """ "Last bake: 14:03 today, forest.exr: irradiance, 9 specular levels, BRDF LUT; up to date"."""
    text = "Last bake: %s, %s: %s" % (when(old.modified, now), old.source_words, old.outputs.words())
    return text + ("; " + fresh if fresh else "")
