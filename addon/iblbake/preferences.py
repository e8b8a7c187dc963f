"""Add-on preferences: the default output folder and the option defaults."""
import bpy
from bpy.props import StringProperty

from .properties import ENGINE_ITEMS, BakeOptionProps
from .scene_settings import ADDON_ID


class IBLBAKE_AddonPreferences(BakeOptionProps, bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    default_output_dir: StringProperty(
        name="Default Output Folder", subtype="DIR_PATH", default="//ibl/{world}",
        description="Used when a scene names no folder; {blend}, {scene} and {world} are replaced, "
                    "// is the .blend file's folder")
    lut_cache_dir: StringProperty(
        name="LUT Cache", subtype="DIR_PATH", default="",
        description="Where BRDF LUTs are kept and reused across scenes (empty: ~/.cache/iblbake, "
                    "shared with the iblbake command line)")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "default_output_dir")
        layout.prop(self, "lut_cache_dir")
        draw_options(layout, self)


def draw_engines(layout, props):
    """The engine presets as toggles (several may be ticked)."""
    if not ENGINE_ITEMS:
        return
    col = layout.column(align=True)
    col.label(text="Also Export For")
    for start in range(0, len(ENGINE_ITEMS), 4):
        row = col.row(align=True)
        for name, label, _desc, _bit in ENGINE_ITEMS[start:start + 4]:
            row.prop_enum(props, "engines", name, text=label)


def draw_options(layout, props, engines=True):
    """The shared options, as the preferences and the World panel show them."""
    if engines:
        draw_engines(layout, props)
    col = layout.column(align=True)
    col.prop(props, "face_size")
    col.prop(props, "mip_count")
    col.prop(props, "irradiance_size")
    col = layout.column(align=True)
    col.prop(props, "lut_size")
    col.prop(props, "lut_model")
    row = layout.row(heading="Formats")
    row.prop(props, "write_exr")
    row.prop(props, "write_png")
    row.prop(props, "write_preview")
    if props.write_png:
        layout.prop(props, "png_encoding")
        layout.prop(props, "exposure")
    col = layout.column(align=True)
    col.prop(props, "render_width")
    col.prop(props, "render_samples")


classes = (IBLBAKE_AddonPreferences,)
