"""What the panel shows that is not a setting: the running bake's stage and
progress, and each scene's last result. Kept in this module, never in the
.blend (an old failure must not greet a user who reopens a file)."""
from dataclasses import dataclass, field
from typing import List, Optional, Tuple


@dataclass
class Run:
    """The bake in progress (one at a time)."""
    scene: str
    stage: str = "Starting"
    fraction: float = 0.0          # the whole bake, 0..1
    cancel_requested: bool = False


@dataclass
class Last:
    """A scene's last bake, for the panel."""
    status: str = ""
    kind: str = ""                 # "INFO", "CANCEL" or "ERROR"
    error: str = ""
    out_dir: str = ""
    content_hash: str = ""
    files: List[Tuple[str, int]] = field(default_factory=list)
    total_bytes: int = 0
    preview: str = ""              # preview.png's path, when the bake wrote one
    thumbnail: object = None       # its small sRGB RGBA copy for the panel (describe.thumbnail), or None
    stages: List[Tuple[str, float]] = field(default_factory=list)  # what the user waited for, in seconds


RUN: Optional[Run] = None
LAST = {}  # scene name -> Last


def last(scene_name: str) -> Last:
    return LAST.get(scene_name) or Last()


def set_last(scene_name: str, value: Last):
    LAST[scene_name] = value


def clear():
    """A new file: nothing of the old one's results stays."""
    LAST.clear()
