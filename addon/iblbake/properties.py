"""Per-scene settings (the World panel) and the options they share with the
add-on preferences (one mixin, so a default lives in one place: core.settings)."""
import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from .core import settings as S

LUT_MODEL_ITEMS = [
    ("karis", "Karis (UE4)", "GGX, Smith-Schlick k = alpha/2: the seeds' and UE4's LUT"),
    ("height-correlated", "Height-correlated", "GGX with height-correlated Smith visibility"),
    ("multiscatter", "Multiple scattering", "Height-correlated, written for Turquin's energy compensation"),
]
PNG_ITEMS = [("srgb", "sRGB 8-bit", "Clamped, exposure applied"), ("rgbm", "RGBM", "Shared multiplier in alpha")]


class BakeOptionProps:
    """The options a bake takes; shared by the preferences and the scene."""
    face_size: IntProperty(name="Specular Size", default=S.FACE_SIZE, min=1, max=4096,
                           description="Face size of specular mip 0")
    irradiance_size: IntProperty(name="Irradiance Size", default=S.IRRADIANCE_SIZE, min=1, max=4096,
                                 description="Face size of the irradiance cube")
    mip_count: IntProperty(name="Mip Levels", default=S.MIP_COUNT, min=0, max=20,
                           description="Specular mip levels (0: the full chain down to 1x1)")
    lut_size: IntProperty(name="LUT Size", default=S.LUT_SIZE, min=1, max=4096, description="BRDF LUT size")
    lut_model: EnumProperty(name="LUT Model", items=LUT_MODEL_ITEMS, default="karis")
    write_exr: BoolProperty(name="EXR", default=True, description="Write EXR files (half float crosses)")
    write_png: BoolProperty(name="PNG", default=False, description="Write PNG files too")
    png_encoding: EnumProperty(name="PNG Encoding", items=PNG_ITEMS, default="srgb")
    exposure: FloatProperty(name="PNG Exposure", default=0.0, min=-64, max=64, description="Stops, PNG only")
    render_width: IntProperty(name="Render Width", default=S.RENDER_WIDTH, min=16, max=16384,
                              description="Worlds that are not an image or a colour are rendered by Cycles "
                                          "to a lat-long of this width (height is half)")
    render_samples: IntProperty(name="Render Samples", default=S.RENDER_SAMPLES, min=1, max=4096,
                                description="Cycles samples per pixel for that render (denoising is off)")


class IBLBAKE_SceneSettings(BakeOptionProps, bpy.types.PropertyGroup):
    use_scene_options: BoolProperty(
        name="Scene Options", default=False,
        description="Use this scene's options below instead of the add-on preferences' defaults")
    output_dir: StringProperty(
        name="Output Folder", subtype="DIR_PATH", default="",
        description="Where the bake goes (empty: the preferences' default folder). "
                    "{blend}, {scene} and {world} are replaced; // is the .blend file's folder")
    bake_irradiance: BoolProperty(name="Irradiance", default=True, description="Bake the diffuse irradiance cube")
    bake_specular: BoolProperty(name="Specular", default=True, description="Bake the prefiltered specular chain")
    bake_lut: BoolProperty(name="BRDF LUT", default=True, description="Bake (or reuse) the split-sum LUT")
    auto_skip: BoolProperty(
        name="Skip Unused", default=True,
        description="Skip what the visible objects' materials do not use: irradiance without diffuse materials, "
                    "specular without glossy ones, and specular levels outside their roughness range")
    force: BoolProperty(name="Bake Even If Unchanged", default=False,
                        description="Bake even when the world and every setting hash the same as the last bake")
    # Last result, for the panel.
    last_status: StringProperty(name="Last Bake", default="")
    last_error: StringProperty(name="Last Error", default="")
    last_output: StringProperty(name="Last Output", default="", subtype="DIR_PATH")
    last_hash: StringProperty(name="Last Content Hash", default="")


classes = (IBLBAKE_SceneSettings,)


def register_props():
    bpy.types.Scene.iblbake = PointerProperty(type=IBLBAKE_SceneSettings)


def unregister_props():
    del bpy.types.Scene.iblbake
