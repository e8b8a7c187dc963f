"""Everything a bake is asked to do, as one plain object (the operator copies
the scene's and the preferences' properties into it)."""
from dataclasses import asdict, dataclass, field
from typing import List

# Defaults shared by the preferences, the scene settings and the batch script.
FACE_SIZE = 256
IRRADIANCE_SIZE = 32
MIP_COUNT = 0          # 0: the full chain, log2(face) + 1 levels
LUT_SIZE = 512
LUT_MODELS = ("karis", "height-correlated", "multiscatter")
RENDER_WIDTH = 1024    # Cycles fallback: lat-long width (height is half)
RENDER_SAMPLES = 16
EPS = 0.5              # specular accuracy knob: the core's default (error ~ eps^3 to eps^4)


@dataclass
class BakeSettings:
    out_dir: str = ""
    face_size: int = FACE_SIZE
    irradiance_size: int = IRRADIANCE_SIZE
    mip_count: int = MIP_COUNT
    lut_size: int = LUT_SIZE
    lut_model: str = "karis"
    formats: List[str] = field(default_factory=lambda: ["exr"])
    png_encoding: str = "srgb"
    exposure: float = 0.0
    float32: bool = False
    eps: float = EPS
    # What the user asks for; the scene analysis may switch more off.
    irradiance: bool = True
    specular: bool = True
    lut: bool = True
    presets: List[str] = field(default_factory=list)  # engine presets (iblbake_core.presets()), each written into out_dir/<name>/
    preview: bool = True     # preview.png: the contact sheet
    auto_skip: bool = True   # skip what the scene's materials don't use (the UI defaults to off: every roughness)
    force: bool = False      # bake even when the world and settings are unchanged
    render_width: int = RENDER_WIDTH
    render_samples: int = RENDER_SAMPLES
    lut_cache_dir: str = ""  # "" : the native default (~/.cache/iblbake)
    threads: int = 0

    def resolved_mip_count(self) -> int:
        return self.mip_count if self.mip_count > 0 else max(1, self.face_size).bit_length()

    def validate(self):
        """Raises ValueError naming the first setting at fault."""
        if not self.out_dir:
            raise ValueError("no output folder: set one in the World panel or the add-on preferences")
        if not self.formats or any(f not in ("exr", "png") for f in self.formats):
            raise ValueError("formats must be a non-empty list of 'exr' and 'png'")
        if self.lut_model not in LUT_MODELS:
            raise ValueError("unknown LUT model %r (expected one of %s)" % (self.lut_model, ", ".join(LUT_MODELS)))
        if not (16 <= self.render_width <= 16384):
            raise ValueError("render width must be in 16..16384")
        if not (1 <= self.render_samples <= 4096):
            raise ValueError("render samples must be in 1..4096")
        if not isinstance(self.presets, (list, tuple)) or not all(isinstance(p, str) and p for p in self.presets):
            raise ValueError("presets must be a list of engine preset names")

    def hash_fields(self) -> dict:
        """The settings that change the files (not where they go, nor how fast)."""
        d = asdict(self)
        for k in ("out_dir", "force", "lut_cache_dir", "threads"):
            d.pop(k)
        return d
