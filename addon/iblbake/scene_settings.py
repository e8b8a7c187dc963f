"""What a bake of a scene is asked to do, read from bpy: the add-on
preferences' defaults (or the scene's own options) and the scene's choices
as one core.settings.BakeSettings, the output folder resolved, and what the
scene's materials need."""
import os

import bpy

from . import scene_needs
from .core import names
from .core.needs import needs_from_lobes
from .core.pipeline import BakeError
from .core.settings import BakeSettings
from .core.options import SCENE_OUTPUTS
from .properties import ENGINE_ITEMS, ROWS

ADDON_ID = __package__  # "iblbake", or "bl_ext.<repo>.iblbake" as a 4.2+ extension



def addon_preferences(context=None):
    """The preferences, or None when the add-on is not enabled as such
    (imported by a script instead): callers fall back to the defaults."""
    context = context or bpy.context
    addon = context.preferences.addons.get(ADDON_ID)
    return addon.preferences if addon else None


def options_of(context, scene):
    """Where the bake's options come from: the scene's own, or the preferences'."""
    prefs = addon_preferences(context)
    return scene.iblbake if (scene.iblbake.use_scene_options or prefs is None) else prefs


def resolve_output_dir(scene, template: str) -> str:
    blend = bpy.data.filepath
    try:
        text = names.fill_template(template, os.path.splitext(os.path.basename(blend))[0] if blend else "untitled",
                                   scene.name, scene.world.name if scene.world else "no_world")
    except names.TemplateError as e:
        raise BakeError(str(e))
    if text.startswith("//") and not blend:
        raise BakeError("the output folder %r is relative to the .blend file, which is not saved yet: "
                        "save the file, or choose an absolute folder" % template)
    return os.path.abspath(os.path.expanduser(bpy.path.abspath(text)))


def output_template(context, scene) -> str:
    prefs = addon_preferences(context)
    return scene.iblbake.output_dir or (prefs.default_output_dir if prefs else "") or "//ibl/{world}"


def engine_names(props) -> list:
    """The engine presets ticked in `props` (an ENUM_FLAG set), in the table's order."""
    chosen = set(getattr(props, "presets", set()) or ())
    return [item[0] for item in ENGINE_ITEMS if item[0] in chosen]


def option_value(row, props):
    """A property's value as BakeSettings holds it (an ENUM_FLAG set as a list in the table's order)."""
    value = getattr(props, row["name"])
    if row["kind"] == "list":
        return [c["value"] for c in row["choices"] if c["value"] in value]
    return value


def gather_settings(context, scene) -> BakeSettings:
    """The preferences' defaults (or the scene's own options) and the scene's
    choices, as one BakeSettings."""
    prefs = addon_preferences(context)
    props = scene.iblbake
    src = options_of(context, scene)
    s = BakeSettings()
    for row in ROWS:  # the scene's outputs from the scene, the options from `src`
        setattr(s, row["name"], option_value(row, props if row["name"] in SCENE_OUTPUTS else src))
    s.auto_skip, s.force = props.auto_skip, props.force
    if prefs is not None:
        s.lut_cache_dir = bpy.path.abspath(prefs.lut_cache_dir) if prefs.lut_cache_dir else ""
    s.out_dir = resolve_output_dir(scene, output_template(context, scene))
    return s


def scene_needs_for(scene, settings: BakeSettings):
    lobes, surfaces = scene_needs.scene_lobes(scene)
    return needs_from_lobes(lobes, settings.resolved_mip_count(), surfaces)


def manifest_extra(scene) -> dict:
    """What the manifest's "blender" section says about where the bake came from."""
    return {"scene": scene.name, "blend_file": bpy.data.filepath or None, "blender_version": bpy.app.version_string}
