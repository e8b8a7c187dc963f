"""Per-scene settings (the World panel) and the options they share with the
add-on preferences (one mixin). Every option's property is made from its row
of the options table (core/options.py: the native table and the add-on's own
rows), so its name, label, default, range and help live in one place."""
import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import state
from .core import options


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
    ("EXPORT", "Every Roughness (for Export)", "Bake irradiance, every specular level and the LUT, whatever this "
     "scene's materials use: what an engine or another scene needs", 0),
    ("SCENE", "This Scene's Materials", "Bake only what the visible objects' materials read (no irradiance "
     "without diffuse materials, only the specular levels of their roughness)", 1),
]


class BakeOptionProps:
    """The options a bake takes (every row of core/options.py but the
    scene's outputs); shared by the preferences and the scene. The
    annotations are made from the table below."""


BakeOptionProps.__annotations__ = {
    row["name"]: make_property(row, update=(lambda self, context: _engines_changed(self, context))
                               if row["name"] == "presets" else None)
    for row in ROWS if row["name"] not in options.SCENE_OUTPUTS}


class IBLBAKE_SceneSettings(BakeOptionProps, bpy.types.PropertyGroup):
    # What to bake (irradiance, specular, lut): the scene's own, from the table.
    use_scene_options: BoolProperty(
        name="Scene Options", default=False,
        description="Use this scene's options below instead of the add-on preferences' defaults")
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
    """Ticking an engine means export: bake every roughness (the scene's own
    setting when the scene's options are in use, else the active scene's)."""
    if not props.presets:
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
