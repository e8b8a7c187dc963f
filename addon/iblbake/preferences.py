"""Add-on preferences: the default output folder and the option defaults
(their rows drawn as the World panel draws the scene's own)."""
import bpy
from bpy.props import StringProperty

from . import panel
from .properties import BakeOptionProps
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
        panel.draw_options(layout, self)


classes = (IBLBAKE_AddonPreferences,)
