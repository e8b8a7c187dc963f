"""World Properties > Image-Based Lighting: how the world is read, where the
files go, what will be baked (in words), the options (whose rows the add-on
preferences draw too), the button - or, while a bake runs, its progress bar
with a Cancel button - and the last bake's files and preview."""
import bpy
from bpy.app.handlers import persistent

from . import operators, outputs, state, world_reader
from .core import describe
from .core.world import COLOR, IMAGE
from .core import options
from .properties import ENGINE_ITEMS, ROWS
from .scene_settings import (addon_preferences, engine_names, gather_settings, options_of, output_template,
                             scene_needs_for)


def _world_line(scene):
    try:
        src = world_reader.classify(scene.world)
    except world_reader.WorldError as e:
        return "ERROR", str(e)[0].upper() + str(e)[1:]
    if src.path == IMAGE:
        extra = []
        if src.mapping is not None and not src.mapping.is_identity():
            rot = src.mapping.to_json()["rotation_degrees"]
            extra.append("rotation %.0f/%.0f/%.0f" % tuple(rot))
        if src.strength != 1.0:
            extra.append("strength %.3g" % src.strength)
        return "IMAGE_DATA", "Image %s%s" % (src.image_name, (" (" + ", ".join(extra) + ")") if extra else "")
    if src.path == COLOR:
        return "COLOR", "Plain color (%.3g, %.3g, %.3g): baked exactly" % tuple(src.color)
    return "RENDER_STILL", "Rendered by Cycles: %s" % src.why


# The scene analysis, kept between redraws until the scene changes (a redraw
# must not walk every object of a large scene).
_needs_cache = {}


@persistent
def _forget_needs(*_args):
    _needs_cache.clear()


def _plan_lines(context, scene):
    """(sentences about what is baked, resolved folder or None, folder error)."""
    props = scene.iblbake
    opts = options_of(context, scene)
    key = (scene.name, props.use_scene_options, opts.face_size, opts.mip_count, props.output_dir, props.auto_skip,
           tuple(engine_names(opts)), bpy.data.filepath, scene.world.name if scene.world else None)
    if key not in _needs_cache:
        _needs_cache[key] = _compute_plan_lines(context, scene)
    return _needs_cache[key]


def _compute_plan_lines(context, scene):
    from .core.settings import BakeSettings
    folder, folder_error = None, ""
    try:
        settings = gather_settings(context, scene)
        folder = settings.out_dir
    except Exception as e:  # e.g. a //folder in an unsaved file: the panel says so
        settings = BakeSettings()
        opts = options_of(context, scene)
        settings.face_size, settings.mip_count = opts.face_size, opts.mip_count
        settings.presets = engine_names(opts)
        folder_error = str(e)
    needs = scene_needs_for(scene, settings) if scene.iblbake.auto_skip else None
    from .core.needs import Needs
    lines = describe.needs_sentences(needs or Needs(), settings.resolved_mip_count(), scene.iblbake.auto_skip,
                                     tuple(settings.presets))
    return lines, folder, folder_error


def _max_chars(context):
    """How many characters of a label fit the panel's width (an estimate)."""
    scale = context.preferences.view.ui_scale
    width = context.region.width if context.region else 300
    return int((width - 60 * scale) / (6.3 * scale))


def _draw_progress(layout, context):
    run = state.RUN
    split = layout.split(factor=0.75, align=True)
    split.scale_y = 1.4
    if hasattr(split, "progress"):  # Blender 4.0+
        split.progress(factor=run.fraction, type="BAR", text="%s  %d%%" % (run.stage, int(100 * run.fraction)))
    else:  # 3.x: a read-only percentage property drawn as a slider
        split.prop(context.window_manager, "iblbake_progress", text=run.stage, slider=True)
    split.operator(operators.IBLBAKE_OT_cancel.bl_idname, text="Cancel", icon="CANCEL")


STATUS_ICONS = {"INFO": "CHECKMARK", "CANCEL": "CANCEL", "ERROR": "ERROR"}


def _draw_last(layout, context, last):
    if not last.status:
        return
    if state.RUN is None:  # while a bake runs, its bar says what is going on
        col = layout.column(align=True)
        for i, line in enumerate(_wrap(last.status, _max_chars(context))):
            col.label(text=line, icon=STATUS_ICONS.get(last.kind, "INFO") if i == 0 else "BLANK1")
    sun_line = describe.sun_sentence(last.sun)
    if sun_line:
        layout.label(text=sun_line, icon="LIGHT_SUN")
        if last.sun.get("found"):
            layout.operator(outputs.IBLBAKE_OT_add_sun_lamp.bl_idname, icon="LIGHT_SUN")
    if last.files:
        box = layout.box()
        col = box.column(align=True)
        col.label(text="%d files, %s" % (len(last.files), describe.human_size(last.total_bytes)), icon="FILE")
        for name, size in describe.grouped_files(last.files):
            row = col.row()
            row.label(text=name, icon="BLANK1")
            row.label(text=describe.human_size(size))
    if last.preview:
        box = layout.box()
        icon = _preview_icon(last)
        if icon:
            # A square of up to 256 pixels (the thumbnail's width), as the panel's width allows.
            scale = context.preferences.view.ui_scale
            width = context.region.width if context.region else 300
            box.template_icon(icon_value=icon, scale=max(4.0, min(width - 40 * scale, 256 * scale) / (20.0 * scale)))
        box.operator(outputs.IBLBAKE_OT_open_preview.bl_idname, icon="IMAGE_DATA")


# The preview sheet's thumbnail (made by the bake's worker thread) as a custom
# preview: setting its pixels is quick; nothing is read on the main thread.
_previews = None


def _preview_icon(last):
    global _previews
    thumb = last.thumbnail
    if thumb is None:
        return 0
    key = "%s:%d" % (last.preview, id(thumb))
    if _previews is None:
        import bpy.utils.previews
        _previews = bpy.utils.previews.new()
    if key not in _previews:
        _previews.clear()
        item = _previews.new(key)
        item.image_size = (thumb.shape[1], thumb.shape[0])
        item.image_pixels_float.foreach_set(thumb.reshape(-1))
    return _previews[key].icon_id


def free_previews():
    global _previews
    if _previews is not None:
        import bpy.utils.previews
        bpy.utils.previews.remove(_previews)
        _previews = None


def _wrap(text, width):
    """Words in lines of at most `width` characters (labels do not wrap by themselves)."""
    lines, line = [], ""
    for word in text.split(" "):
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = (line + " " + word) if line else word
    if line:
        lines.append(line)
    return [describe.shorten_middle(ln, width) for ln in lines] or [""]


def draw_engines(layout, props):
    """The engine presets as toggles (several may be ticked)."""
    if not ENGINE_ITEMS:
        return
    col = layout.column(align=True)
    col.label(text="Also Export For")
    for start in range(0, len(ENGINE_ITEMS), 4):
        row = col.row(align=True)
        for name, label, _desc, _bit in ENGINE_ITEMS[start:start + 4]:
            row.prop_enum(props, "presets", name, text=label)


def draw_options(layout, props, engines=True):
    """The shared options, as the World panel and the preferences show them:
    a row per option of the table (core/options.py), in its order; numbers
    next to each other share a column, a list is a row of toggles, and an
    option another one makes moot (PNG's encoding without PNG) is hidden."""
    if engines:
        draw_engines(layout, props)
    col = None
    for row in ROWS:
        name = row["name"]
        if name in options.SCENE_OUTPUTS or name == "presets":
            continue  # the scene's outputs and the engines have their own rows
        need = options.REQUIRES.get(name)
        if need and need[1] not in getattr(props, need[0]):
            continue
        if row["kind"] in ("int", "float"):
            col = col or layout.column(align=True)
            col.prop(props, name)
            continue
        col = None
        if row["kind"] == "list":
            layout.row(heading=row["label"]).prop(props, name, expand=True)
        else:
            layout.prop(props, name)


class IBLBAKE_PT_world(bpy.types.Panel):
    bl_label = "Image-Based Lighting"
    bl_idname = "IBLBAKE_PT_world"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        props = scene.iblbake
        width = _max_chars(context)
        icon, text = _world_line(scene)
        for i, line in enumerate(_wrap(text, width)):
            layout.label(text=line, icon=icon if i == 0 else "BLANK1")
        if scene.world is None:  # nothing to bake: the line above says what to do
            return

        lines, folder, folder_error = _plan_lines(context, scene)
        col = layout.column(align=True)
        col.label(text="Output Folder")
        try:  # Blender 4.1+: the folder used while the field is empty, greyed inside it
            col.prop(props, "output_dir", text="", placeholder=output_template(context, scene))
        except TypeError:
            col.prop(props, "output_dir", text="")
        if folder:
            col.label(text=describe.shorten_middle(folder, width), icon="FILE_FOLDER")
        else:
            for i, line in enumerate(_wrap(folder_error, width)):
                col.label(text=line, icon="ERROR" if i == 0 else "BLANK1")

        box = layout.box()
        box.label(text="Bake For")
        box.column(align=True).prop(props, "bake_for", expand=True)
        col = box.column(align=True)
        for line in lines:
            for i, part in enumerate(_wrap(line, width - 2)):
                col.label(text=part, icon="INFO" if i == 0 else "BLANK1")
        row = box.row(align=True)
        for name in options.SCENE_OUTPUTS:
            if name != "sun":
                row.prop(props, name, toggle=True)
        row = box.row(align=True)  # the sun as a light (issue 27): Off | Split
        row.label(text="Sun")
        row.prop(props, "sun", expand=True)
        draw_engines(box, options_of(context, scene))

        layout.prop(props, "use_scene_options")
        if props.use_scene_options or addon_preferences(context) is None:
            sub = layout.column()
            sub.use_property_split = True
            draw_options(sub, props, engines=False)
        layout.prop(props, "force")

        if state.RUN is not None:
            _draw_progress(layout, context)
        else:
            row = layout.row(align=True)
            row.scale_y = 1.4
            row.operator(operators.IBLBAKE_OT_bake.bl_idname, icon="WORLD")
            row.operator(outputs.IBLBAKE_OT_open_output.bl_idname, text="", icon="FILEBROWSER")
        _draw_last(layout, context, state.last(scene.name))


classes = (IBLBAKE_PT_world,)
HANDLERS = ((bpy.app.handlers.depsgraph_update_post, _forget_needs), (bpy.app.handlers.load_post, _forget_needs))
