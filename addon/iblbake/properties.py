"""Per-scene settings (the World panel), saved in the .blend, and the
options they share with the add-on preferences (one mixin), which hold the
defaults a scene's options start from. Every option's property is made from
its row of the options table (core/options.py: the native table and the
add-on's own rows), so its name, label, default, range and help live in one
place.

A file's settings are the file's: the World panel writes the scene, never
the preferences. A scene's options start as the preferences' defaults once
(options_initialised): when the file is opened or made (load_post), when a
scene is added, or when a script sets one of them first; an older file
whose scene used the preferences (it had no Scene Options ticked) gets the
preferences' values of that moment, so it bakes as it did."""
import bpy
from bpy.app.handlers import persistent
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import state
from .core import options

ADDON_ID = __package__  # "iblbake", or "bl_ext.<repo>.iblbake" as a 4.2+ extension


def _items(row):
    """A choice or list row's values as EnumProperty items (ENUM_FLAG bits for a list)."""
    flag = row["kind"] == "list"
    return [(c["value"], c["label"], c["help"] or c["label"], 1 << i) if flag else (c["value"], c["label"], c["help"] or c["label"])
            for i, c in enumerate(row.get("choices") or [])]


def make_property(row, update=None):
    """The bpy property of one row of the options table (core/options.py)."""
    kind, extra = row["kind"], {"update": update} if update else {}
    common = dict(name=row["label"], description=row["help"][:1].upper() + row["help"][1:], **extra)
    if kind == "int":
        return IntProperty(default=row["default"], min=int(row.get("min", -2 ** 31)), max=int(row.get("max", 2 ** 31 - 1)),
                           **common)
    if kind == "float":
        lo, hi = row.get("min"), row.get("max")
        return FloatProperty(default=row["default"], min=-1e30 if lo is None else lo, max=1e30 if hi is None else hi,
                             **common)
    if kind == "bool":
        return BoolProperty(default=row["default"], **common)
    if kind == "choice":
        return EnumProperty(items=_items(row), default=row["default"], **common)
    return EnumProperty(items=_items(row), options={"ENUM_FLAG"}, default=set(row["default"]), **common)


def option_row(name):
    for row in ROWS:
        if row["name"] == name:
            return row
    raise KeyError(name)


ROWS = options.rows()
# The engine presets ticked in the panel: (name, label, description, bit) from the native table.
ENGINE_ITEMS = _items(option_row("presets"))


BAKE_FOR_ITEMS = [
    ("EXPORT", "Every Roughness", "For export: bake irradiance, every specular level and the LUT, whatever this "
     "scene's materials use: what an engine or another scene needs", 0),
    ("SCENE", "This Scene's Materials", "Bake only what the visible objects' materials read (no irradiance "
     "without diffuse materials, only the specular levels of their roughness)", 1),
]


class BakeOptionProps:
    """The options a bake takes (every row of core/options.py but the
    scene's outputs); shared by the preferences and the scene. The
    annotations are made from the table below."""


def _option_changed(name):
    """The update of an option's property: a scene's first option set (by a
    script, before any handler initialised it) starts the others from the
    preferences; ticking an engine means export."""
    def update(self, context):
        if isinstance(self.id_data, bpy.types.Scene) and not self.options_initialised:
            initialise_options(self.id_data, context, keep=name)
        if name == "presets":
            _engines_changed(self, context)
    return update


OPTION_ROWS = [row for row in ROWS if row["name"] not in options.SCENE_OUTPUTS]
BakeOptionProps.__annotations__ = {row["name"]: make_property(row, update=_option_changed(row["name"]))
                                   for row in OPTION_ROWS}


class IBLBAKE_SceneSettings(BakeOptionProps, bpy.types.PropertyGroup):
    # What to bake (irradiance, specular, lut): the scene's own, from the table.
    options_initialised: BoolProperty(
        name="Options Initialised", default=False, options={"HIDDEN"},
        description="This scene's options have been started from the preferences' defaults (once)")
    output_dir: StringProperty(
        name="Output Folder", subtype="DIR_PATH", default="",
        description="Where the bake goes (empty: the preferences' default folder). "
                    "{blend}, {scene} and {world} are replaced; // is the .blend file's folder")
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


IBLBAKE_SceneSettings.__annotations__.update(
    {row["name"]: make_property(row) for row in ROWS if row["name"] in options.SCENE_OUTPUTS})


def _engines_changed(props, context):
    """Ticking an engine in a scene means export: bake every roughness (a
    default ticked in the preferences changes no scene)."""
    if props.presets and isinstance(props.id_data, bpy.types.Scene) and props.auto_skip:
        props.auto_skip = False


def initialise_options(scene, context=None, keep=None):
    """Starts a scene's options from the preferences' defaults, once (see the
    module's docstring); `keep` names an option a script has just set. A
    scene of an older file that had its own options (Scene Options ticked)
    keeps them."""
    props = scene.iblbake
    if props.options_initialised:
        return
    props.options_initialised = True
    if props.get("use_scene_options"):  # an older file's own options: already the scene's
        return
    addon = (context or bpy.context).preferences.addons.get(ADDON_ID)
    prefs = addon.preferences if addon else None
    if prefs is None:  # imported by a script, not enabled: the table's defaults
        return
    for row in OPTION_ROWS:
        if row["name"] != keep:
            setattr(props, row["name"], getattr(prefs, row["name"]))
    if not props.output_dir and keep != "output_dir":
        props.output_dir = prefs.default_output_dir


@persistent
def initialise_all(*_args):
    """Every scene of the file (load_post, and the add-on being enabled)."""
    for scene in bpy.data.scenes:
        if not scene.iblbake.options_initialised:
            initialise_options(scene)


@persistent
def initialise_new_scenes(scene, *_args):
    """depsgraph_update_post: a scene added in this session."""
    if scene is not None and not scene.iblbake.options_initialised:
        initialise_options(scene)


def _progress(_wm):
    run = state.RUN
    return 100.0 * run.fraction if run is not None else 0.0


classes = (IBLBAKE_SceneSettings,)
HANDLERS = ((bpy.app.handlers.load_post, initialise_all), (bpy.app.handlers.depsgraph_update_post, initialise_new_scenes))


def register_props():
    bpy.types.Scene.iblbake = PointerProperty(type=IBLBAKE_SceneSettings)
    # The file open when the add-on is enabled; while Blender starts, bpy.data
    # is not there yet (the startup file's load_post does it then).
    if isinstance(bpy.data, bpy.types.BlendData):
        initialise_all()
    # The running bake's progress for the panel's bar (read-only, not saved: a window manager property).
    bpy.types.WindowManager.iblbake_progress = FloatProperty(
        name="Progress", subtype="PERCENTAGE", min=0.0, max=100.0, precision=0, get=_progress,
        description="How far the running bake is (Esc or Cancel stops it)")


def unregister_props():
    del bpy.types.WindowManager.iblbake_progress
    del bpy.types.Scene.iblbake
