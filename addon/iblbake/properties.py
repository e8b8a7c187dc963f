"""Per-scene settings (the World panel) and the options they share with the
add-on preferences (one mixin, so a default lives in one place: core.settings)."""
import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import state
from .core import native
from .core import settings as S


def engine_items():
    """The engine presets as enum items, from the native table (iblbake_core.presets():
    a list of dicts with name, description, ...); none when the module has no presets."""
    try:
        table = native.load().presets()
    except (ImportError, AttributeError):
        return []
    items = []
    for i, p in enumerate(table):
        name = str(p["name"])
        first = str(p.get("description", "")).split(" ")[0].strip(",;:")
        label = first if first.lower().startswith(name.lower()) else name.capitalize()  # "three.js", "Khronos"
        items.append((name, label, str(p.get("description", "")), 1 << i))
    return items


ENGINE_ITEMS = engine_items()

LUT_MODEL_ITEMS = [
    ("karis", "Karis (UE4)", "GGX, Smith-Schlick k = alpha/2: the seeds' and UE4's LUT"),
    ("height-correlated", "Height-correlated", "GGX with height-correlated Smith visibility"),
    ("multiscatter", "Multiple scattering", "Height-correlated, written for Turquin's energy compensation"),
]
PNG_ITEMS = [("srgb", "sRGB 8-bit", "Clamped, exposure applied"), ("rgbm", "RGBM", "Shared multiplier in alpha")]


BAKE_FOR_ITEMS = [
    ("EXPORT", "Every Roughness (for Export)", "Bake irradiance, every specular level and the LUT, whatever this "
     "scene's materials use: what an engine or another scene needs", 0),
    ("SCENE", "This Scene's Materials", "Bake only what the visible objects' materials read (no irradiance "
     "without diffuse materials, only the specular levels of their roughness)", 1),
]


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
                              description="Worlds that are not an image or a plain color are rendered by Cycles "
                                          "to a lat-long of this width (height is half)")
    render_samples: IntProperty(name="Render Samples", default=S.RENDER_SAMPLES, min=1, max=4096,
                                description="Cycles samples per pixel for that render (denoising is off)")
    write_preview: BoolProperty(name="Preview Sheet", default=True,
                                description="Also write preview.png: the irradiance, every specular level, the LUT "
                                            "and spheres lit by the bake, to look at")
    if ENGINE_ITEMS:
        engines: EnumProperty(
            name="Engines", items=ENGINE_ITEMS, options={"ENUM_FLAG"}, default=set(),
            update=lambda self, context: _engines_changed(self, context),
            description="Also export for these engines (their containers, mirrors and roughness per level); "
                        "several may be ticked")


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
        name="Skip Unused", default=False,
        description="Bake only what the visible objects' materials read: no irradiance without diffuse materials, "
                    "no specular without glossy ones, and only the specular levels of their roughness")
    bake_for: EnumProperty(
        name="Bake For", items=BAKE_FOR_ITEMS, get=lambda self: int(self.auto_skip),
        set=lambda self, value: setattr(self, "auto_skip", bool(value)),
        description="Every roughness (for export), or only what this scene's materials read")
    force: BoolProperty(name="Bake Even If Unchanged", default=False,
                        description="Bake even when the world and every setting hash the same as the last bake")
    # The last result, for scripts (read-only; kept by state.py, never saved in the .blend).
    last_status: StringProperty(name="Last Bake", get=lambda self: state.last(self.id_data.name).status)
    last_error: StringProperty(name="Last Error", get=lambda self: state.last(self.id_data.name).error)
    last_output: StringProperty(name="Last Output", get=lambda self: state.last(self.id_data.name).out_dir)


def _engines_changed(props, context):
    """Ticking an engine means export: bake every roughness (the scene's own
    setting when the scene's options are in use, else the active scene's)."""
    if not props.engines:
        return
    scene = props.id_data if isinstance(props.id_data, bpy.types.Scene) else getattr(context, "scene", None)
    if scene is not None and scene.iblbake.auto_skip:
        scene.iblbake.auto_skip = False


def _progress(_wm):
    run = state.RUN
    return 100.0 * run.fraction if run is not None else 0.0


classes = (IBLBAKE_SceneSettings,)


def register_props():
    bpy.types.Scene.iblbake = PointerProperty(type=IBLBAKE_SceneSettings)
    # The running bake's progress for the panel's bar (read-only, not saved: a window manager property).
    bpy.types.WindowManager.iblbake_progress = FloatProperty(
        name="Progress", subtype="PERCENTAGE", min=0.0, max=100.0, precision=0, get=_progress,
        description="How far the running bake is (Esc or Cancel stops it)")


def unregister_props():
    del bpy.types.WindowManager.iblbake_progress
    del bpy.types.Scene.iblbake
