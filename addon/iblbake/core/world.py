"""A world turned into something the native baker takes, without bpy.

The Blender side (world_reader.py) reads the node tree into a WorldSource;
prepare_pixels() applies what the nodes say (colour space, Mapping node,
Strength) to the image's pixels as Blender hands them over."""
import math
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

# How a world reaches the baker (the manifest's blender.path).
IMAGE = "environment_texture"   # an Environment Texture read pixel by pixel
COLOR = "plain_colour"          # a constant colour, baked in closed form
RENDER = "cycles_render"        # anything else, rendered to a lat-long by Cycles

LINEAR_COLORSPACES = frozenset({"Linear", "Linear Rec.709", "Non-Color", "Raw", "Scene Linear", "Linear Rec.2020"})


@dataclass
class Mapping:
    """A Mapping node between the texture coordinates and the Environment Texture."""
    vector_type: str = "POINT"   # POINT, TEXTURE, VECTOR or NORMAL
    location: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: Tuple[float, float, float] = (0.0, 0.0, 0.0)  # XYZ Euler, radians
    scale: Tuple[float, float, float] = (1.0, 1.0, 1.0)

    def is_identity(self) -> bool:
        a, b = self.affine()
        return np.allclose(a, np.eye(3), atol=1e-12) and np.allclose(b, 0.0, atol=1e-12)

    def affine(self):
        """(A, b) with lookup direction = A d + b, as Blender's mapping node
        computes it (intern/cycles/kernel/svm/mapping_util.h)."""
        r = euler_xyz_matrix(self.rotation)
        s = np.array(self.scale, float)
        t = np.array(self.location, float)
        if self.vector_type == "POINT":       # R (S d) + T
            return r @ np.diag(s), t
        if self.vector_type == "TEXTURE":     # S^-1 (R^T (d - T))
            inv = np.diag(safe_inverse(s)) @ r.T
            return inv, -inv @ t
        if self.vector_type == "VECTOR":      # R (S d)
            return r @ np.diag(s), np.zeros(3)
        if self.vector_type == "NORMAL":      # normalize(R (d / S)); the lookup normalises anyway
            return r @ np.diag(safe_inverse(s)), np.zeros(3)
        raise ValueError("unknown mapping type %r" % self.vector_type)

    def to_json(self) -> dict:
        return {"type": self.vector_type, "location": list(self.location),
                "rotation_degrees": [math.degrees(v) for v in self.rotation], "scale": list(self.scale)}


def euler_xyz_matrix(rot: Sequence[float]) -> np.ndarray:
    """Blender's XYZ Euler rotation matrix: Rz @ Ry @ Rx."""
    cx, cy, cz = np.cos(rot)
    sx, sy, sz = np.sin(rot)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def safe_inverse(s: np.ndarray) -> np.ndarray:
    """1/s with 0 for 0, as Cycles' safe_divide."""
    out = np.zeros_like(s, dtype=float)
    nz = s != 0
    out[nz] = 1.0 / s[nz]
    return out


def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    """The sRGB transfer function's inverse (IEC 61966-2-1), in place on float32."""
    low = v <= 0.04045
    out = np.where(low, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    return out.astype(np.float32, copy=False)


@dataclass
class WorldSource:
    """What the node tree says, before any pixel is read."""
    path: str                         # IMAGE, COLOR or RENDER
    why: str = ""                     # for RENDER: what made the world not an image or a colour
    world: Optional[str] = None
    color: Tuple[float, float, float] = (0.0, 0.0, 0.0)  # COLOR: colour x strength
    strength: float = 1.0
    image_name: str = ""
    image_path: str = ""              # absolute file path, "" when packed or generated
    colorspace: str = ""
    is_float: bool = True
    mapping: Optional[Mapping] = None
    render: dict = field(default_factory=dict)  # RENDER: width, height, samples
    drivers: List[str] = field(default_factory=list)  # drivers of the world Blender did not run

    def to_json(self) -> dict:
        d = {"path": self.path, "world": self.world}
        if self.why:
            d["why"] = self.why
        if self.path == COLOR:
            d["color"] = list(self.color)
        if self.path == IMAGE:
            d["image"] = {"name": self.image_name, "filepath": self.image_path or None,
                          "colorspace": self.colorspace, "is_float": self.is_float,
                          "linearised_from_srgb": self.needs_srgb_decode()}
            d["mapping"] = self.mapping.to_json() if self.mapping else None
            d["strength"] = self.strength
        if self.path == RENDER:
            d["render"] = dict(self.render)
        return d

    def needs_srgb_decode(self) -> bool:
        """Blender hands byte images over as stored; float ones already linear."""
        return not self.is_float and self.colorspace == "sRGB"

    def check_colorspace(self):
        if not self.is_float and self.colorspace != "sRGB" and self.colorspace not in LINEAR_COLORSPACES:
            raise ValueError("the Color Space %r of an 8-bit image is not read directly" % self.colorspace)
        # Blender's buffer of a float image in a non-linear space is not what
        # Cycles shows (1000 in sRGB: 40.5 in the buffer, 1.39e7 in Cycles).
        if self.is_float and self.colorspace not in LINEAR_COLORSPACES:
            raise ValueError("the Color Space %r of a float image is not read directly" % self.colorspace)


def prepare_pixels(src: WorldSource, rgba_bottom_up: np.ndarray, width: int, height: int, remap=None) -> np.ndarray:
    """Blender's flat RGBA pixels (rows bottom-up) -> the radiance the world
    shows, (H, W, 3) float32, rows top-down: linearised when the image is
    8-bit sRGB, seen through the Mapping node (`remap(image, A9, b3)`, the
    native remap_latlong), times Strength."""
    px = np.asarray(rgba_bottom_up, dtype=np.float32).reshape(height, width, 4)[::-1, :, :3]
    img = np.ascontiguousarray(px)
    if src.needs_srgb_decode():
        img = srgb_to_linear(img)
    return apply_nodes(src, img, remap)


def apply_nodes(src: WorldSource, img: np.ndarray, remap=None) -> np.ndarray:
    """Linear (H, W, 3) float32 radiance, rows top-down, seen through the
    Mapping node and times Strength (in place where it can)."""
    if src.mapping is not None and not src.mapping.is_identity():
        if remap is None:
            raise ValueError("a Mapping node needs the native remap")
        a, b = src.mapping.affine()
        img = remap(img, [float(v) for v in a.reshape(-1)], [float(v) for v in b])
    if src.strength != 1.0:
        img *= np.float32(src.strength)
    return img


class NeedsRender(Exception):
    """The image's pixels are not what Cycles shows (e.g. straight alpha)."""


class FileNotAsBlenderShowsIt(Exception):
    """The file's pixels, read by iblbake itself, may differ from what Blender
    shows for the image (alpha, colour space): read Blender's buffer instead."""


def read_file_pixels(src: WorldSource, read_image, remap=None, alpha_matters: bool = True) -> np.ndarray:
    """The Environment Texture's radiance read straight from its file by the
    native reader (off Blender's main thread: it releases the GIL), as
    Blender would show it: (H, W, 3) float32, rows top-down. `read_image(path,
    info=True)` is iblbake_core.read_image. Raises FileNotAsBlenderShowsIt when
    the file's pixels are not what Blender shows (then Blender's own buffer
    is read instead)."""
    if alpha_matters and "A" in exr_channels(src.image_path):  # the native reader reads R, G, B only
        raise FileNotAsBlenderShowsIt("the file has an alpha channel")
    img, info = read_image(src.image_path, info=True)
    if info["channels"] >= 4 and alpha_matters:
        raise FileNotAsBlenderShowsIt("the file has an alpha channel")
    if src.is_float:
        if src.colorspace not in LINEAR_COLORSPACES:
            raise FileNotAsBlenderShowsIt("a float image in Color Space %r" % src.colorspace)
    elif not (src.colorspace == "sRGB" and info["linearised"]):
        raise FileNotAsBlenderShowsIt("an 8-bit image in Color Space %r" % src.colorspace)
    return apply_nodes(src, np.asarray(img, dtype=np.float32), remap)


def exr_channels(path: str) -> list:
    """The channel names an OpenEXR file's header lists ([] for other files
    or an unreadable header): its attributes are name, type, size, value;
    "channels" (chlist) holds name, 16 bytes, ..., an empty name."""
    try:
        with open(path, "rb") as f:
            head = f.read(65536)
    except OSError:
        return []
    if head[:4] != b"\x76\x2f\x31\x01":
        return []
    pos = 8
    while pos < len(head) and head[pos] != 0:
        name_end = head.index(b"\0", pos)
        type_end = head.index(b"\0", name_end + 1)
        size = int.from_bytes(head[type_end + 1:type_end + 5], "little")
        value = head[type_end + 5:type_end + 5 + size]
        if head[pos:name_end] == b"channels" and head[name_end + 1:type_end] == b"chlist":
            names, i = [], 0
            while i < len(value) and value[i] != 0:
                end = value.index(b"\0", i)
                names.append(value[i:end].decode("latin-1"))
                i = end + 1 + 16
            return names
        pos = type_end + 5 + size
    return []
