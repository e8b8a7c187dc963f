"""Add-on preferences: the defaults a new file's (or a new scene's) settings
start from, the LUT cache. A file keeps its own settings: changing these
changes no file that has them already (see properties.py)."""
import bpy
from bpy.props import StringProperty

from . import panel
from .properties import ADDON_ID, BakeOptionProps


class IBLBAKE_AddonPreferences(BakeOptionProps, bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    default_output_dir: StringProperty(
        name="Output Folder", subtype="DIR_PATH", default="//ibl/{world}",
        description="Where a new file's bakes go; {blend}, {scene} and {world} are replaced, "
                    "// is the .blend file's folder")
    lut_cache_dir: StringProperty(
        name="LUT Cache", subtype="DIR_PATH", default="",
        description="Where BRDF LUTs are kept and reused across scenes (empty: ~/.cache/iblbake, "
                    "shared with the iblbake command line)")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(self, "lut_cache_dir")
        box = layout.box()
        box.label(text="Defaults for New Files", icon="FILE_NEW")
        box.label(text="A file keeps its own settings (World Properties > Image-Based Lighting): these fill in "
                       "the settings of a file or scene that has none yet.")
        box.prop(self, "default_output_dir")
        sub = box.column()
        sub.use_property_split = False  # the toggles carry their own labels
        panel.draw_engines(sub, self)
        panel.draw_options(box, self)


classes = (IBLBAKE_AddonPreferences,)
