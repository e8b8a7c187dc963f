"""World Properties > Image-Based Lighting: how the world is read, where the
files go, what will be baked (in words), the button - or, while a bake
runs, its stage, progress bar and Cancel - and the folder's bake ("Last
bake: when, what; up to date / the world changed since", read from its
manifest, so it is there after the file is reopened); sub-panels hold the
options (whose rows the add-on preferences draw too) and the folder's
files with the preview sheet.

Every line fits Blender's default Properties width (about 190 pixels at
1280 x 1024): long sentences wrap, paths are shortened in the middle,
toggles go two to a row when the panel is narrow, a choice's label sits on
its own row above it."""
import os
import threading

import bpy
from bpy.app.handlers import persistent

from . import operators, outputs, state, world_reader
from .core import describe, folder, options, pipeline
from .core.world import COLOR, IMAGE
from .properties import ENGINE_ITEMS, ROWS
from .scene_settings import engine_names, gather_settings, option_value, options_of, output_template, scene_needs_for


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


# What the panel computes from the scene (the materials' needs, the world's
# fingerprint), kept between redraws until the scene changes: a redraw must
# not walk every object of a large scene.
_plan_cache = {}


@persistent
def _forget_plans(*_args):
    _plan_cache.clear()


class Plan:
    """What a bake now would do: the sentences, the folder (or why there is none), its freshness keys."""

    def __init__(self, lines, folder_path, folder_error, settings_hash, world_fingerprint):
        self.lines, self.folder, self.folder_error = lines, folder_path, folder_error
        self.settings_hash, self.world_fingerprint = settings_hash, world_fingerprint


def _plan(context, scene):
    props = scene.iblbake
    opts = options_of(context, scene)
    key = (scene.name, bpy.data.filepath, scene.world.name if scene.world else None, props.output_dir,
           props.auto_skip, output_template(context, scene),
           tuple(str(option_value(row, props if row["name"] in options.SCENE_OUTPUTS else opts)) for row in ROWS))
    if key not in _plan_cache:
        _plan_cache[key] = _compute_plan(context, scene)
    return _plan_cache[key]


def _compute_plan(context, scene):
    from .core.needs import Needs
    from .core.settings import BakeSettings
    folder_path, folder_error = None, ""
    try:
        settings = gather_settings(context, scene)
        folder_path = settings.out_dir
    except Exception as e:  # e.g. a //folder in an unsaved file: the panel says so
        settings = BakeSettings()
        opts = options_of(context, scene)
        settings.face_size, settings.mip_count = opts.face_size, opts.mip_count
        settings.presets = engine_names(opts)
        folder_error = str(e)[0].upper() + str(e)[1:]
    needs = scene_needs_for(scene, settings) if scene.iblbake.auto_skip else None
    lines = describe.needs_sentences(needs or Needs(), settings.resolved_mip_count(), scene.iblbake.auto_skip,
                                     tuple(settings.presets))
    try:
        source = world_reader.classify(scene.world)
        digest = pipeline.settings_hash(source, settings, needs)
    except Exception:
        digest = None
    return Plan(lines, folder_path, folder_error, digest, world_reader.fingerprint(scene.world))


# -- the folder's bake, read from disk (cached until its manifest changes) -------
_folder_cache = {}


def _folder_state(path):
    """(FolderBake or None, [(file, bytes)], total bytes) of a folder, re-read when its manifest changes."""
    try:
        st = os.stat(os.path.join(path, "manifest.json"))
        key = (path, st.st_mtime_ns, st.st_size)
    except OSError:
        return None, [], 0
    if key not in _folder_cache:
        if len(_folder_cache) > 16:
            _folder_cache.clear()
        files, total = describe.bake_files(path)
        _folder_cache[key] = (folder.read_folder(path), files, total)
    return _folder_cache[key]


# -- the preview sheet's thumbnail, made off the main thread -------------------------
_previews = None
_thumbs = {}  # (path, mtime) -> thumbnail array, or None while it is being made


def _thumbnail(scene_name, path):
    """The sheet's thumbnail: this session's bake's, else one read from the
    file on a thread (the panel redraws when it is ready); None meanwhile."""
    last = state.last(scene_name)
    if last.thumbnail is not None and last.out_dir == os.path.dirname(path):
        return last.thumbnail
    try:
        key = (path, os.stat(path).st_mtime_ns)
    except OSError:
        return None
    if key not in _thumbs:
        _thumbs[key] = None

        def make():
            from .core.worker import read_image
            try:
                _thumbs[key] = describe.thumbnail(read_image(path))
            except (OSError, RuntimeError, ValueError):
                return
            bpy.app.timers.register(lambda: state.redraw() and None, first_interval=0.0)
        threading.Thread(target=make, name="iblbake thumbnail", daemon=True).start()
    return _thumbs[key]


def _preview_icon(path, thumb):
    global _previews
    key = "%s:%d" % (path, id(thumb))
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


# -- widths --------------------------------------------------------------------------
def _scale(context):
    return getattr(context.preferences.system, "ui_scale", 0.0) or context.preferences.view.ui_scale


def _width(context):
    """The panel's width in unscaled pixels."""
    return (context.region.width if context.region else 300) / _scale(context)


def _max_chars(context, indent=0):
    """How many characters of a label fit the panel's width, an icon beside it
    (an estimate: Blender's font averages under 5.8 px a character)."""
    return max(8, int((_width(context) - 40 - 16 * indent) / 5.8))


def _narrow(context):
    return _width(context) < 300


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


def _paragraph(layout, text, width, icon="NONE"):
    col = layout.column(align=True)
    for i, line in enumerate(_wrap(text, width)):
        col.label(text=line, icon=icon if i == 0 else ("BLANK1" if icon != "NONE" else "NONE"))
    return col


# -- rows shared with the preferences ---------------------------------------------------
def draw_engines(layout, props, columns=4):
    """The engine presets as toggles (several may be ticked), `columns` to a row."""
    if not ENGINE_ITEMS:
        return
    col = layout.column(align=True)
    col.label(text="Also Export For")
    grid = col.grid_flow(row_major=True, columns=columns, even_columns=True, align=True)
    for name, label, _desc, _bit in ENGINE_ITEMS:
        grid.prop_enum(props, "presets", name, text=label)


def draw_options(layout, props, narrow=False):
    """The shared options, as the World panel and the preferences show them:
    a row per option of the table (core/options.py), in its order; numbers
    next to each other share a column, a list is a row of toggles, and an
    option another one makes moot (PNG's encoding without PNG) is hidden.
    Narrow (the default Properties width), a choice's or a list's label is a
    row of its own above it and numbers carry their label inside the field."""
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
            if narrow:
                sub = layout.column(align=True)
                sub.label(text=row["label"])
                sub.row(align=True).prop(props, name, expand=True)
            else:
                layout.row(heading=row["label"]).prop(props, name, expand=True)
        elif row["kind"] == "choice" and narrow:
            sub = layout.column(align=True)
            sub.label(text=row["label"])
            sub.prop(props, name, text="")
        else:
            layout.prop(props, name)


# -- the panel -------------------------------------------------------------------------------
def _draw_progress(layout, context):
    run = state.RUN
    col = layout.column(align=True)
    col.label(text=run.stage, icon="SORTTIME")  # its own label: the bar's text is greyed on 3.x
    bar = col.row(align=True)
    bar.scale_y = 1.2
    if hasattr(bar, "progress"):  # Blender 4.0+
        bar.progress(factor=run.fraction, type="BAR", text="%d%%" % int(100 * run.fraction))
    else:  # 3.x: a read-only percentage property drawn as a slider
        bar.prop(context.window_manager, "iblbake_progress", text="", slider=True)
    row = col.row(align=True)
    row.scale_y = 1.2
    row.operator(operators.IBLBAKE_OT_cancel.bl_idname, text="Cancel (Esc)", icon="CANCEL")


STATUS_ICONS = {"INFO": "CHECKMARK", "CANCEL": "CANCEL", "ERROR": "ERROR"}


def _draw_status(layout, context, scene, plan):
    """This session's last result, then the folder's bake (from its manifest)."""
    width = _max_chars(context)
    last = state.last(scene.name)
    if state.RUN is None and last.status:
        text = last.status
        if last.kind == "INFO" and text.startswith("Baked in "):  # what it holds: the Last bake line below
            text = text.split(":")[0]
        _paragraph(layout, text, width, STATUS_ICONS.get(last.kind, "INFO"))
    if last.note:
        _paragraph(layout, last.note, width, "INFO")
    if not plan.folder:
        return
    old = _folder_state(plan.folder)[0]
    if old is None:
        return
    fresh = folder.freshness(old, plan.world_fingerprint, plan.settings_hash)
    icon = {folder.UP_TO_DATE: "CHECKMARK", folder.WORLD_CHANGED: "ERROR", folder.SETTINGS_CHANGED: "ERROR"}.get(
        fresh, "FILE_FOLDER")
    _paragraph(layout, folder.last_bake_line(old, fresh), width, icon)
    sun = old.manifest.get("sun")
    sun_line = describe.sun_sentence(sun)
    if sun_line:  # what a bake with Sun: Split found (issue 27)
        _paragraph(layout, sun_line, width, "LIGHT_SUN")
        if sun.get("found"):
            layout.operator(outputs.IBLBAKE_OT_add_sun_lamp.bl_idname, icon="LIGHT_SUN")


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
        narrow = _narrow(context)
        if not props.options_initialised and scene.name not in _initialising:
            # A scene made in this session: started from the preferences right after this redraw.
            _initialising.add(scene.name)
            bpy.app.timers.register(_initialise_soon(scene.name), first_interval=0.0)
        icon, text = _world_line(scene)
        _paragraph(layout, text, width, icon)
        if scene.world is None:  # nothing to bake: the line above says what to do
            return

        plan = _plan(context, scene)
        # The button (or the running bake) first, what it did and what the folder holds right below.
        if state.RUN is not None:
            _draw_progress(layout, context)
        else:
            row = layout.row(align=True)
            row.scale_y = 1.4
            row.operator(operators.IBLBAKE_OT_bake.bl_idname, icon="WORLD")
            row.operator(outputs.IBLBAKE_OT_open_output.bl_idname, text="", icon="FILEBROWSER")
        _draw_status(layout, context, scene, plan)

        col = layout.column(align=True)
        col.label(text="Output Folder")
        try:  # Blender 4.1+: the folder used while the field is empty, greyed inside it
            col.prop(props, "output_dir", text="", placeholder=output_template(context, scene))
        except TypeError:
            col.prop(props, "output_dir", text="")
        if plan.folder:  # its end (the folder's own name) always shown: shortened in the middle
            col.label(text=describe.shorten_middle(plan.folder, width - 5), icon="FILE_FOLDER")
        else:
            _paragraph(col, plan.folder_error, width - 2, "ERROR")

        box = layout.box()
        box.label(text="Bake For")
        box.column(align=True).prop(props, "bake_for", expand=True)
        for line in plan.lines:
            _paragraph(box, line, width - 3, "INFO")
        grid = box.grid_flow(row_major=True, columns=2 if narrow else 3, even_columns=True, align=True)
        for name in options.SCENE_OUTPUTS:
            if name != "sun":
                grid.prop(props, name, toggle=True)
        row = box.row(align=True)  # the sun as a light (issue 27): Off | Split
        row.label(text="Sun")
        row.prop(props, "sun", expand=True)
        draw_engines(box, props, columns=2 if narrow else 4)
        layout.prop(props, "force")


_initialising = set()


def _initialise_soon(scene_name):
    def run():
        _initialising.discard(scene_name)
        scene = bpy.data.scenes.get(scene_name)
        if scene is not None and not scene.iblbake.options_initialised:
            from .properties import initialise_options
            initialise_options(scene)
            state.redraw()
    return run


class WorldSubPanel:
    """A sub-panel of Image-Based Lighting, shown when the scene has a world."""
    bl_parent_id = "IBLBAKE_PT_world"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and context.scene.world is not None


class IBLBAKE_PT_world_options(WorldSubPanel, bpy.types.Panel):
    bl_label = "Options"
    bl_idname = "IBLBAKE_PT_world_options"

    def draw(self, context):
        layout = self.layout
        narrow = _narrow(context)
        layout.use_property_split = not narrow
        layout.use_property_decorate = False
        draw_options(layout, context.scene.iblbake, narrow)


class IBLBAKE_PT_world_files(WorldSubPanel, bpy.types.Panel):
    bl_label = "Files"
    bl_idname = "IBLBAKE_PT_world_files"

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        plan = _plan(context, scene)
        old, files, total = _folder_state(plan.folder) if plan.folder else (None, [], 0)
        if not files:
            layout.label(text="Nothing baked in this folder yet", icon="INFO")
            return
        width = _max_chars(context, indent=1)
        col = layout.column(align=True)
        col.label(text="%s, %s" % (describe.files_words(len(files)), describe.human_size(total)), icon="FILE")
        for name, size in describe.grouped_files(files):
            # The name as long as it needs, the size right-aligned after it.
            row = col.row(align=True)
            row.label(text=name)  # no icon: the room is the name's (a folder's ends with /)
            right = row.row(align=True)
            right.alignment = "RIGHT"
            right.label(text=describe.human_size(size))
        path = os.path.join(plan.folder, "preview.png")
        if os.path.isfile(path):
            box = layout.box()
            thumb = _thumbnail(scene.name, path)
            if thumb is not None:
                # As wide as the panel allows: up to the thumbnail's 256 pixels, or all of it when shown large.
                avail = _width(context) - 40
                w = avail if scene.name in state.LARGE_PREVIEW else min(avail, 256)
                box.template_icon(icon_value=_preview_icon(path, thumb), scale=max(4.0, w / 20.0))
            else:
                box.label(text="Loading the preview sheet…", icon="TIME")
            box.operator(outputs.IBLBAKE_OT_open_preview.bl_idname, icon="IMAGE_DATA")


classes = (IBLBAKE_PT_world, IBLBAKE_PT_world_options, IBLBAKE_PT_world_files)
HANDLERS = ((bpy.app.handlers.depsgraph_update_post, _forget_plans), (bpy.app.handlers.load_post, _forget_plans))
