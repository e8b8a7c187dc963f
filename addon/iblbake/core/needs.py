"""What a scene's materials need from the environment lighting.

The Blender side turns every shader node it meets into Lobes with the rules
below; needs_from_lobes() then decides which outputs and which specular mip
levels are worth baking.

The level rule: an engine reads the prefiltered cube at lod = r (M - 1) for
perceptual roughness r (SPEC: r_m = m / (M - 1)) and blends the two levels
around it, so materials whose roughness spans [lo, hi] read levels
floor(lo (M - 1)) .. ceil(hi (M - 1)); only those are baked. A socket driven
by a link (a texture, a ramp, anything) counts as the full range [0, 1].
"""
import math
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

Range = Tuple[float, float]
FULL: Range = (0.0, 1.0)


def clamp_range(r: Range) -> Range:
    lo, hi = (min(max(float(v), 0.0), 1.0) for v in r)
    return (min(lo, hi), max(lo, hi))


@dataclass(frozen=True)
class Lobe:
    """One way a material reads the environment: diffuse (irradiance) or
    glossy (prefiltered specular + LUT) at perceptual roughness in `roughness`."""
    kind: str          # "diffuse" or "glossy"
    roughness: Range = FULL
    source: str = ""   # material / node, for the panel and the manifest


def principled_lobes(source: str, roughness: Range, metallic: Range, specular: Range,
                     transmission: Range = (0.0, 0.0), coat: Range = (0.0, 0.0),
                     coat_roughness: Range = FULL) -> List[Lobe]:
    """Principled BSDF: diffuse unless fully metallic or fully transmissive;
    glossy when any of specular, metallic or transmission is non-zero (Cycles
    drops the specular closure when both specular and metallic are 0); the
    coat adds a glossy lobe of its own roughness."""
    lobes = []
    if metallic[0] < 1.0 and transmission[0] < 1.0:
        lobes.append(Lobe("diffuse", FULL, source))
    if specular[1] > 0.0 or metallic[1] > 0.0 or transmission[1] > 0.0:
        lobes.append(Lobe("glossy", clamp_range(roughness), source))
    if coat[1] > 0.0:
        lobes.append(Lobe("glossy", clamp_range(coat_roughness), source + " (coat)"))
    return lobes


# Shader nodes by what they read (Blender's bl_idname); roughness comes from
# their "Roughness" socket. Nodes in none of these sets and not Principled are
# unknown: they count as reading everything.
DIFFUSE_NODES = frozenset({
    "ShaderNodeBsdfDiffuse", "ShaderNodeSubsurfaceScattering", "ShaderNodeBsdfTranslucent",
    "ShaderNodeBsdfVelvet", "ShaderNodeBsdfSheen", "ShaderNodeBsdfToon"})
GLOSSY_NODES = frozenset({
    "ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic", "ShaderNodeBsdfGlass",
    "ShaderNodeBsdfRefraction"})
DIFFUSE_AND_GLOSSY_NODES = frozenset({"ShaderNodeEeveeSpecular"})
# Closures that do not read the environment as a surface.
INERT_NODES = frozenset({
    "ShaderNodeEmission", "ShaderNodeBsdfTransparent", "ShaderNodeHoldout", "ShaderNodeBackground",
    "ShaderNodeVolumeAbsorption", "ShaderNodeVolumeScatter", "ShaderNodeVolumePrincipled"})


def node_lobes(bl_idname: str, source: str, roughness: Range = FULL) -> List[Lobe]:
    """Lobes of a non-Principled shader node (see the sets above)."""
    if bl_idname in INERT_NODES:
        return []
    if bl_idname in DIFFUSE_NODES:
        return [Lobe("diffuse", FULL, source)]
    if bl_idname in GLOSSY_NODES:
        return [Lobe("glossy", clamp_range(roughness), source)]
    if bl_idname in DIFFUSE_AND_GLOSSY_NODES:
        return [Lobe("diffuse", FULL, source), Lobe("glossy", clamp_range(roughness), source)]
    return [Lobe("diffuse", FULL, source + " (unknown node)"), Lobe("glossy", FULL, source + " (unknown node)")]


def levels_for_roughness(rough: Range, mip_count: int) -> Tuple[int, int]:
    """Mip levels an engine reads for roughness in `rough` (module docstring)."""
    if mip_count <= 1:
        return (0, 0)
    lo, hi = clamp_range(rough)
    n = mip_count - 1
    first = int(math.floor(lo * n + 1e-9))
    last = int(math.ceil(hi * n - 1e-9))
    return (max(0, min(first, n)), max(0, min(max(last, first), n)))


@dataclass
class Needs:
    irradiance: bool = True
    specular: bool = True
    lut: bool = True
    roughness: Optional[Range] = None     # glossy roughness in use
    levels: Optional[Tuple[int, int]] = None  # specular levels to bake (None: all)
    reasons: dict = field(default_factory=dict)  # output -> why it is skipped
    surfaces: int = 0                     # lobes inspected
    analysed: bool = True                 # False: nothing to inspect, everything baked

    def to_json(self) -> dict:
        return {"irradiance": self.irradiance, "specular": self.specular, "lut": self.lut,
                "roughness": list(self.roughness) if self.roughness else None,
                "levels": list(self.levels) if self.levels else None,
                "reasons": dict(self.reasons), "lobes": self.surfaces, "analysed": self.analysed}


def needs_from_lobes(lobes: List[Lobe], mip_count: int, objects: int) -> Needs:
    """What to bake for a scene of `objects` visible surfaces whose materials
    have `lobes`. A scene with no visible surface tells nothing: bake all."""
    if objects == 0:
        return Needs(analysed=False)
    diffuse = [lb for lb in lobes if lb.kind == "diffuse"]
    glossy = [lb for lb in lobes if lb.kind == "glossy"]
    n = Needs(irradiance=bool(diffuse), specular=bool(glossy), lut=bool(glossy), surfaces=len(lobes))
    if not diffuse:
        n.reasons["irradiance"] = "no visible material has a diffuse component"
    if not glossy:
        n.reasons["specular"] = "no visible material has a glossy component"
        n.reasons["brdf_lut"] = "no visible material has a glossy component (the split-sum LUT is unused)"
    else:
        lo = min(lb.roughness[0] for lb in glossy)
        hi = max(lb.roughness[1] for lb in glossy)
        n.roughness = (lo, hi)
        n.levels = levels_for_roughness(n.roughness, mip_count)
        if n.levels != (0, max(0, mip_count - 1)):
            n.reasons["specular_levels"] = ("materials use roughness %.3g..%.3g, read from levels %d..%d"
                                            % (lo, hi, n.levels[0], n.levels[1]))
    return n
