"""What the panel shows that is not a setting and not on disk: the running
bake's stage and progress, and each scene's last result in this session
(set_baked, set_failed and set_cancelled record it and redraw the editors
that show it). Kept in this module, never in the .blend (an old failure must
not greet a user who reopens a file); what a folder holds, the panel reads
from the folder itself (core/folder.py)."""
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
    """A scene's last bake in this session, for the panel."""
    status: str = ""
    kind: str = ""                 # "INFO", "CANCEL" or "ERROR"
    error: str = ""
    out_dir: str = ""
    thumbnail: object = None       # preview.png's small sRGB RGBA copy for the panel (describe.thumbnail), or None
    content_hash: str = ""
    outcome: str = ""              # the report's status: "baked" or "unchanged" (bake_world.py --batch)
    stages: List[Tuple[str, float]] = field(default_factory=list)  # what the user waited for, in seconds
    note: str = ""                 # a line of its own below the status (no file manager: where the files are)
    sun: Optional[dict] = None     # the manifest's `sun` (a bake with sun="split"), else None


RUN: Optional[Run] = None
LAST = {}  # scene name -> Last
LARGE_PREVIEW = set()  # scenes whose panel shows the sheet large (Open Preview with no Image Editor open)


def last(scene_name: str) -> Last:
    return LAST.get(scene_name) or Last()


def set_last(scene_name: str, value: Last):
    LAST[scene_name] = value


def clear():
    """A new file: nothing of the old one's results stays."""
    LAST.clear()
    LARGE_PREVIEW.clear()


def set_baked(scene_name: str, report, stages=()):
    """A bake's result (a core.pipeline.BakeReport); its files are read from its folder."""
    old = last(scene_name)
    thumbnail = report.thumbnail if report.thumbnail is not None else (
        old.thumbnail if old.out_dir == report.out_dir else None)  # unchanged: the same sheet
    manifest = report.manifest or describe.manifest_of(report.out_dir) or {}
    set_last(scene_name, Last(status=report.summary(), kind="INFO", out_dir=report.out_dir, thumbnail=thumbnail,
                              content_hash=report.content_hash, outcome=report.status, stages=list(stages),
                              sun=manifest.get("sun")))
    redraw(images=True)


def set_failed(scene_name: str, error, out_dir: str = ""):
    """A bake that failed; the earlier bake's files are still there."""
    _keep_files(scene_name, "Failed: %s" % error, "ERROR", str(error), out_dir)


def set_cancelled(scene_name: str):
    """A bake that was stopped; the earlier bake's files are still there."""
    _keep_files(scene_name, "Cancelled: the earlier bake is unchanged", "CANCEL", "", "")


def set_note(scene_name: str, note: str):
    set_last(scene_name, replace(last(scene_name), note=note))
    redraw()


def _keep_files(scene_name, status, kind, error, out_dir):
    old = last(scene_name)
    set_last(scene_name, replace(old, status=status, kind=kind, error=error, out_dir=old.out_dir or out_dir, stages=[],
                                 note=""))
    redraw()


PREVIEW_IMAGE = "iblbake preview"


def redraw(context=None, images=False, only_world=False):
    """Redraws the editors that show what this module holds (none in background
    mode): the Properties editors (only_world: those showing World
    Properties) and the status bar; with images, the Image Editors that
    show the preview sheet too."""
    wm = bpy.context.window_manager if context is None else context.window_manager
    if wm is None:
        return
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type == "STATUSBAR" or (area.type == "PROPERTIES" and (
                    not only_world or getattr(area.spaces.active, "context", "") == "WORLD")):
                area.tag_redraw()
            elif images and area.type == "IMAGE_EDITOR":
                image = area.spaces.active.image
                if image is not None and image.name == PREVIEW_IMAGE:
                    image.reload()
                    area.tag_redraw()
