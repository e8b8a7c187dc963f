"""What the panel shows that is not a setting: the running bake's stage and
progress, and each scene's last result (set_baked, set_failed and
set_cancelled record it and redraw the editors that show it). Kept in this
module, never in the .blend (an old failure must not greet a user who
reopens a file)."""
import os
from dataclasses import dataclass, field, replace
from typing import List, Optional, Tuple

import bpy

from .core import describe


@dataclass
class Run:
    """The bake in progress (one at a time)."""
    scene: str
    stage: str = "Starting"
    fraction: float = 0.0          # the whole bake, 0..1


@dataclass
class Last:
    """A scene's last bake, for the panel."""
    status: str = ""
    kind: str = ""                 # "INFO", "CANCEL" or "ERROR"
    error: str = ""
    out_dir: str = ""
    content_hash: str = ""
    outcome: str = ""              # the report's status: "baked" or "unchanged" (bake_world.py --batch)
    files: List[Tuple[str, int]] = field(default_factory=list)
    total_bytes: int = 0
    preview: str = ""              # preview.png's path, when the bake wrote one
    thumbnail: object = None       # its small sRGB RGBA copy for the panel (describe.thumbnail), or None
    stages: List[Tuple[str, float]] = field(default_factory=list)  # what the user waited for, in seconds
    sun: Optional[dict] = None     # the manifest's `sun` (a bake with sun="split"), else None


RUN: Optional[Run] = None
LAST = {}  # scene name -> Last


def last(scene_name: str) -> Last:
    return LAST.get(scene_name) or Last()


def set_last(scene_name: str, value: Last):
    LAST[scene_name] = value


def clear():
    """A new file: nothing of the old one's results stays."""
    LAST.clear()


def set_baked(scene_name: str, report, stages=()):
    """A bake's result (a core.pipeline.BakeReport): its files, for the panel."""
    files, total = describe.bake_files(report.out_dir)
    preview = os.path.join(report.out_dir, "preview.png")
    manifest = report.manifest or describe.manifest_of(report.out_dir) or {}
    set_last(scene_name, Last(
        status=report.summary(), kind="INFO", out_dir=report.out_dir, content_hash=report.content_hash,
        outcome=report.status,
        files=files, total_bytes=total, preview=preview if os.path.isfile(preview) else "",
        thumbnail=report.thumbnail, stages=list(stages), sun=manifest.get("sun")))
    redraw()


def set_failed(scene_name: str, error, out_dir: str = ""):
    """A bake that failed; the earlier bake's files are still there."""
    _keep_files(scene_name, "Failed: %s" % error, "ERROR", str(error), out_dir)


def set_cancelled(scene_name: str):
    """A bake that was stopped; the earlier bake's files are still there."""
    _keep_files(scene_name, "Cancelled: the earlier bake is unchanged", "CANCEL", "", "")


def _keep_files(scene_name, status, kind, error, out_dir):
    old = last(scene_name)
    set_last(scene_name, replace(old, status=status, kind=kind, error=error, out_dir=old.out_dir or out_dir, stages=[]))
    redraw()


def redraw(context=None):
    """Redraws the editors that show what this module holds (none in background mode)."""
    wm = bpy.context.window_manager if context is None else context.window_manager
    if wm is None:
        return
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type in ("PROPERTIES", "STATUSBAR", "IMAGE_EDITOR"):
                area.tag_redraw()
