"""The bake, given pixels (or a colour) and a BakeSettings: decides what to
skip, hashes the content, calls the native baker and writes one folder
atomically. No bpy."""
import hashlib
import json
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from . import native
from .needs import Needs
from . import options as option_table
from .settings import BakeSettings
from .world import COLOR, RENDER, WorldSource

ProgressFn = Callable[[str, float], bool]  # (stage, fraction) -> False cancels


class BakeError(Exception):
    """A bake that could not be done; the message says why and what to change."""


@dataclass
class BakeReport:
    status: str                    # "baked" or "unchanged"
    out_dir: str
    content_hash: str
    manifest: dict = field(default_factory=dict)
    seconds: float = 0.0
    thumbnail: Optional[object] = None  # the preview sheet, small, for the panel (set by the UI's job)

    def summary(self, folder: bool = False) -> str:
        """What the bake did, in the panel's words ("Baked in 3.21 s: irradiance,
        9 specular levels, BRDF LUT, three.js"); with folder, where to."""
        where = " into %s" % self.out_dir if folder else ""
        if self.status == "unchanged":
            return ("Nothing to bake%s: the world and the settings are unchanged since the last bake "
                    "(tick Bake Even If Unchanged to bake anyway)" % where)
        from .folder import outputs_of_manifest
        return "Baked in %.2f s%s: %s" % (self.seconds, where, outputs_of_manifest(self.manifest).words())


def native_options(settings: BakeSettings, needs: Optional[Needs]) -> dict:
    """Keyword options of iblbake_core.bake() for these settings; the scene's
    needs switch outputs and specular levels off when auto_skip is on."""
    opts = {name: getattr(settings, name) for name in option_table.native_names()}
    opts["threads"] = settings.threads
    reasons = {}
    # Engine presets need every level of their own chain: nothing is skipped for them.
    if settings.auto_skip and needs is not None and needs.analysed and not settings.presets:
        for key, out in (("irradiance", "irradiance"), ("specular", "specular"), ("lut", "brdf_lut")):
            if opts[key] and not getattr(needs, key):
                opts[key] = False
                reasons[out] = needs.reasons.get(out, "not used by the scene")
        if opts["specular"] and needs.levels is not None:
            opts["first_level"], opts["last_level"] = needs.levels
            if "specular_levels" in needs.reasons:
                reasons["specular_levels"] = needs.reasons["specular_levels"]
    if reasons:
        opts["skip_reasons"] = reasons
    return opts


HASH_SHARE = 0.03  # the progress bar's share of the native bake's range while the pixels are hashed


def pixels_sha256(pixels: np.ndarray, progress: Optional[ProgressFn] = None) -> str:
    """sha256 of the RGB float32 pixels: the hash iblbake_core.bake() would
    write for them, computed once here and handed to it (source_sha256).
    Hashed in bands of rows, `progress("hashing", f)` after each (False
    cancels: iblbake_core.Cancelled)."""
    a = np.ascontiguousarray(np.asarray(pixels, np.float32)[..., :3])
    h = hashlib.sha256()
    rows = a.shape[0] if a.ndim == 3 else 1
    band = max(1, rows // 16)
    flat = memoryview(a.reshape(rows, -1))
    for y in range(0, rows, band):
        h.update(flat[y:y + band].cast("B"))  # releases the GIL
        if progress is not None and progress("hashing", HASH_SHARE * min(rows, y + band) / rows) is False:
            raise native.load().Cancelled()
    return h.hexdigest()


def _hash_meta(source: WorldSource, opts: dict, settings: BakeSettings) -> dict:
    """Every setting that changes a file, as content_hash and settings_hash read them."""
    fields = settings.hash_fields()
    if "png" not in settings.formats:  # PNG-only settings change no file
        for k in ("png_encoding", "exposure"):
            fields.pop(k)
    if source.path != RENDER:  # the render settings only matter to rendered worlds
        for k in ("render_width", "render_samples"):
            fields.pop(k)
    return {"settings": fields, "path": source.path,
            "options": {k: v for k, v in opts.items() if k not in ("threads", "png_encoding", "exposure")}}


def content_hash(source: WorldSource, pixel_digest: Optional[str], opts: dict, settings: BakeSettings,
                 core_version: str) -> str:
    """sha256 of the radiance the bake reads (pixel_digest, from pixels_sha256,
    or the plain colour) and of every setting that changes a file."""
    h = hashlib.sha256()
    meta = dict(_hash_meta(source, opts, settings), core=core_version)
    h.update(json.dumps(meta, sort_keys=True, default=str).encode())
    if pixel_digest is not None:
        h.update(pixel_digest.encode())
    else:
        h.update(np.asarray(source.color, np.float32).tobytes())
    return h.hexdigest()


def settings_hash(source: WorldSource, settings: BakeSettings, needs: Optional[Needs] = None) -> str:
    """sha256 of the settings alone (what the scene's materials leave out
    included): the panel compares it with the folder's manifest to say
    whether the settings changed since its bake, without reading a pixel."""
    meta = _hash_meta(source, native_options(settings, needs), settings)
    return hashlib.sha256(json.dumps(meta, sort_keys=True, default=str).encode()).hexdigest()


def existing_hash(out_dir: str) -> Optional[str]:
    """The content hash of the complete, intact bake in out_dir, if there is
    one: every file the manifest lists (`files`: size and sha256) must be
    there with its size and sha256, so a truncated or damaged output is baked
    again, never kept as "unchanged" (iblbake_core.intact_manifest, the CLI's
    batch's check). A manifest without `files` (an older bake) is not trusted."""
    m = native.load().intact_manifest(out_dir)
    return ((m or {}).get("blender") or {}).get("content_hash")


def source_warnings(source: WorldSource) -> list:
    """What about the world itself deserves a warning (the native bake adds
    its own: odd files, options, shapes)."""
    out = []
    if source.world is None:
        out.append("the scene has no world: baked what Cycles renders without one (black)")
    if source.path != COLOR and isinstance(source.strength, (int, float)) and source.strength < 0:
        out.append("the world's Background Strength is negative (%g): negative radiance is baked as 0"
                   % source.strength)
    if source.path == COLOR and any(c < 0 for c in source.color):
        out.append("the world colour times Strength is negative (%s): baked as 0"
                   % ", ".join("%g" % c for c in source.color))
    out += source.drivers
    return out


def bake(source: WorldSource, pixels: Optional[np.ndarray], settings: BakeSettings,
         needs: Optional[Needs] = None, progress: Optional[ProgressFn] = None, extra: Optional[dict] = None,
         print_warnings: bool = True) -> BakeReport:
    """Bake `pixels` ((H, W, 3) float32 lat-long radiance, rows top-down) or,
    for a plain-colour world, source.color, into settings.out_dir. Skips the
    bake when the folder already holds one of the same content hash (unless
    settings.force). Raises BakeError (bad settings or input) or
    iblbake_core.Cancelled; neither touches an earlier bake."""
    core = native.load()
    try:
        settings.validate()
    except ValueError as e:
        raise BakeError(str(e)) from e
    if source.path != COLOR and pixels is None:
        raise BakeError("no pixels to bake")
    out_dir = os.path.abspath(os.path.expanduser(settings.out_dir))
    opts = native_options(settings, needs)
    if not (opts["irradiance"] or opts["specular"] or opts["lut"] or opts["presets"]):
        why = "; ".join(sorted(set((opts.get("skip_reasons") or {}).values()))) or "every output is switched off"
        raise BakeError("nothing to bake (%s): choose Bake For: Every Roughness to bake anyway" % why)
    parent = os.path.dirname(out_dir)
    while parent and not os.path.isdir(parent):
        parent = os.path.dirname(parent)
    try:  # fail before the work, not after it
        os.rmdir(tempfile.mkdtemp(prefix=".iblbake-probe-", dir=parent or "."))
    except OSError as e:
        raise BakeError("cannot write into %s: %s" % (parent or ".", e.strerror or e)) from e
    if progress is not None and progress("hashing", 0.0) is False:
        raise core.Cancelled()
    hash_start = time.perf_counter()
    pixel_digest = pixels_sha256(pixels, progress) if pixels is not None else None
    hash_seconds = time.perf_counter() - hash_start
    digest = content_hash(source, pixel_digest, opts, settings, core.__version__)
    if not settings.force and existing_hash(out_dir) == digest:
        return BakeReport("unchanged", out_dir, digest)

    blender = dict(extra or {})
    blender.update(source.to_json())
    blender["needs"] = needs.to_json() if needs is not None else None
    blender["auto_skip"] = settings.auto_skip
    blender["content_hash"] = digest
    blender["settings_hash"] = settings_hash(source, settings, needs)
    if "waited" in blender:  # the stages before the native bake, as the UI's job ran them
        blender["waited"] = dict(blender["waited"], hash_pixels=round(hash_seconds, 4))
    opts["manifest_extra"] = {"blender": blender}
    warnings = source_warnings(source)
    if warnings:
        opts["warnings"] = warnings
    cache = settings.lut_cache_dir or core.default_lut_cache_dir()
    if cache:
        opts["lut_cache_dir"] = cache
    if progress is not None:
        opts["progress"] = progress
    if source.image_path and os.path.isfile(source.image_path):
        opts["source_path"] = source.image_path  # the manifest hashes the file, as the CLI does
    elif pixel_digest is not None:
        opts["source_sha256"] = pixel_digest  # hashed once, above
    start = time.perf_counter()
    try:
        if source.path == COLOR:
            result = core.bake_constant([float(c) for c in source.color], out_dir, **opts)
        else:
            result = core.bake(pixels, out_dir, **opts)
    except core.Cancelled:
        raise
    except (ValueError, RuntimeError, OSError) as e:  # bad input, a refused or unwritable folder
        raise BakeError(str(e)) from e
    for w in (result["manifest"].get("warnings") or []) if print_warnings else []:  # else the caller lists them
        print("iblbake: warning: %s" % w, file=sys.stderr, flush=True)
    return BakeReport("baked", out_dir, digest, result["manifest"], time.perf_counter() - start)
