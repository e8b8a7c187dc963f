"""The bake's files on the desktop: Open Output Folder (the file manager),
Open Preview (the preview sheet in an Image Editor) and Add Sun Lamp (the
sun a bake with sun="split" found, as a Sun lamp).

Open Preview opens no window of its own: it shows the sheet in the Image
Editor that shows it already, else in an Image Editor of this window or
another one; with none open, the panel shows the sheet large itself. Its
image ("iblbake preview") is left out of the .blend: saving takes it out of
the editors for the moment of the save and puts it back after (an image the
user renamed, or gave a fake user, is theirs and saved)."""
import math
import os
import shutil
import subprocess
import sys

import bpy
from bpy.app.handlers import persistent

from . import state
from .core import describe
from .core.pipeline import BakeError
from .scene_settings import gather_settings
from .state import PREVIEW_IMAGE


def load_preview(path):
    """preview.png as the Blender image "iblbake preview" (reloaded when it exists already)."""
    if not path or not os.path.isfile(path):
        return None
    img = bpy.data.images.get(PREVIEW_IMAGE)
    if img is None:
        img = bpy.data.images.load(path, check_existing=False)
        img.name = PREVIEW_IMAGE
    elif os.path.abspath(bpy.path.abspath(img.filepath)) != os.path.abspath(path):
        img.filepath = path
        img.reload()
    else:
        img.reload()
    img.use_fake_user = False
    return img


def image_editors(context):
    """Every Image Editor, best first: one showing the sheet, then this window's (largest first), then others'."""
    here = context.window
    found = []
    for window in context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR":
                image = area.spaces.active.image
                found.append(((image is None or image.name != PREVIEW_IMAGE), window != here,
                              -area.width * area.height, len(found), area))
    return [f[-1] for f in sorted(found, key=lambda f: f[:4])]


class IBLBAKE_OT_open_preview(bpy.types.Operator):
    """Show the preview sheet (irradiance, every specular level, the LUT and spheres lit by the bake) in an Image Editor: the one showing it already, else one of this window. With no Image Editor open, the panel shows the sheet large"""
    bl_idname = "iblbake.open_preview"
    bl_label = "Open Preview"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and bool(preview_path(context, context.scene))

    def execute(self, context):
        scene = context.scene
        img = load_preview(preview_path(context, scene))
        if img is None:
            self.report({"ERROR"}, "iblbake: the preview file is gone")
            return {"CANCELLED"}
        editors = image_editors(context)
        if not editors:
            state.LARGE_PREVIEW.add(scene.name)
            state.redraw(context)
            self.report({"INFO"}, "iblbake: no Image Editor is open: the panel shows the sheet (open an Image "
                                  "Editor to see it larger there)")
            return {"FINISHED"}
        area = editors[0]
        area.spaces.active.image = img
        area.tag_redraw()
        state.LARGE_PREVIEW.discard(scene.name)
        return {"FINISHED"}


def bake_dir(context, scene) -> str:
    """The scene's folder: its last bake's in this session, else the one a
    bake would go to ("" when there is none: a // folder in an unsaved file)."""
    out_dir = state.last(scene.name).out_dir
    if not out_dir:
        try:
            out_dir = gather_settings(context, scene).out_dir
        except (BakeError, ValueError):
            return ""
    return out_dir


def preview_path(context, scene) -> str:
    """The sheet of the scene's folder ("" when it has none)."""
    out_dir = bake_dir(context, scene)
    path = os.path.join(out_dir, "preview.png") if out_dir else ""
    return path if path and os.path.isfile(path) else ""


# -- the sheet stays out of the .blend ------------------------------------------------
_SAVED = []  # (area, path) the sheet was taken out of for a save


@persistent
def _preview_out_of_save(*_args):
    """save_pre: the sheet leaves the editors and bpy.data, unless it is the user's (renamed: another name)."""
    img = bpy.data.images.get(PREVIEW_IMAGE)
    if img is None or img.use_fake_user:
        return
    path = bpy.path.abspath(img.filepath)
    wm = bpy.context.window_manager
    for window in (wm.windows if wm else ()):
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR" and area.spaces.active.image == img:
                area.spaces.active.image = None
                _SAVED.append((area, path))
    users = bpy.data.user_map(subset={img}).get(img, set())
    if not [u for u in users if not isinstance(u, bpy.types.Screen)]:  # nothing but editors showed it
        bpy.data.images.remove(img)


@persistent
def _preview_back_after_save(*_args):
    """save_post: the sheet back where it was."""
    saved = list(_SAVED)
    _SAVED.clear()
    for area, path in saved:
        img = load_preview(path)
        try:
            if img is not None:
                area.spaces.active.image = img
        except ReferenceError:  # the editor is gone
            pass


def _open_folder_fallback(path, proc, scene_name):
    """Checks the file manager's process a moment later; if it failed, says where the files are."""
    def check():
        code = proc.poll()
        if code is None:
            return None  # still running: the file manager is up
        if code != 0:
            _no_file_manager(path, scene_name)
        return None
    return check


def _no_file_manager(path, scene_name):
    """The panel says where the files are, on a line of its own (the bake's summary stays)."""
    state.set_note(scene_name, "No file manager could be opened: the path is copied: %s" % path)
    bpy.context.window_manager.clipboard = path


class IBLBAKE_OT_open_output(bpy.types.Operator):
    """Open the output folder in the file manager (when none can be started, the panel shows the path and it is copied to the clipboard)"""
    bl_idname = "iblbake.open_output"
    bl_label = "Open Output Folder"

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        scene = context.scene
        try:
            path = state.last(scene.name).out_dir or gather_settings(context, scene).out_dir
        except BakeError as e:
            self.report({"ERROR"}, "iblbake: %s" % e)
            return {"CANCELLED"}
        if not os.path.isdir(path):
            self.report({"WARNING"}, "iblbake: nothing baked yet; the bake will go to %s" % path)
            return {"CANCELLED"}
        if sys.platform[:3] == "win" or sys.platform == "darwin":
            return bpy.ops.wm.path_open(filepath=path)
        opener = shutil.which("xdg-open")
        if opener is None:
            _no_file_manager(path, scene.name)
            self.report({"WARNING"}, "iblbake: no file manager (xdg-open) here; the files are in %s "
                                     "(path copied to the clipboard)" % path)
            return {"FINISHED"}
        proc = subprocess.Popen([opener, path], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                stdin=subprocess.DEVNULL)
        bpy.app.timers.register(_open_folder_fallback(path, proc, scene.name), first_interval=3.0)
        self.report({"INFO"}, "iblbake: opening %s" % path)
        return {"FINISHED"}


SUN_LAMP = "IBL Sun"


def last_sun(context, scene):
    """The sun of the scene's last bake (the manifest's `sun`), else that of
    the bake in its output folder; None when neither looked for one."""
    sun = state.last(scene.name).sun
    if sun is None:
        out = bake_dir(context, scene)
        sun = (describe.manifest_of(out) or {}).get("sun") if out else None
    return sun if isinstance(sun, dict) else None


def add_sun_lamp(scene, sun, bake_dir=""):
    """Creates (or updates) the Sun lamp "IBL Sun" in `scene` from sun.json's
    content: its -Z along the light (rotation from the direction), Strength =
    E (W/m^2 is the lamp's irradiance: Strength x colour = E per channel),
    Angle = the angular diameter, the colour. The lamp keeps the folder of the
    sun-free bake it goes with (custom property "iblbake_bake"). Returns it."""
    lamp = sun["blender"]
    obj = bpy.data.objects.get(SUN_LAMP)
    if obj is None or obj.type != "LIGHT" or obj.data.type != "SUN":
        obj = bpy.data.objects.new(SUN_LAMP, bpy.data.lights.new(SUN_LAMP, type="SUN"))
    if scene.collection.all_objects.get(obj.name) is None:
        scene.collection.objects.link(obj)
    light = obj.data
    light.energy = float(lamp["strength"])
    light.color = [float(c) for c in lamp["color"]]
    light.angle = math.radians(float(lamp["angle_deg"]))
    obj.rotation_mode = "XYZ"
    obj.rotation_euler = [math.radians(float(a)) for a in lamp["rotation_euler_deg"]]
    obj["iblbake_bake"] = bake_dir or ""
    return obj


class IBLBAKE_OT_add_sun_lamp(bpy.types.Operator):
    """Add (or update) a Sun lamp with the sun the last bake took out of the world: its direction, Strength = its illuminance, Angle = its diameter, its colour"""
    bl_idname = "iblbake.add_sun_lamp"
    bl_label = "Add Sun Lamp"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if context.scene is None:
            return False
        sun = last_sun(context, context.scene)
        return bool(sun and sun.get("found"))

    def execute(self, context):
        scene = context.scene
        sun = last_sun(context, scene)
        if not (sun and sun.get("found")):
            self.report({"ERROR"}, "iblbake: no sun: bake with Sun: Split first (or the world has none)")
            return {"CANCELLED"}
        obj = add_sun_lamp(scene, sun, bake_dir(context, scene))
        self.report({"INFO"}, "iblbake: %s: %s" % (obj.name, describe.sun_sentence(sun)))
        return {"FINISHED"}


classes = (IBLBAKE_OT_open_output, IBLBAKE_OT_open_preview, IBLBAKE_OT_add_sun_lamp)
HANDLERS = ((bpy.app.handlers.save_pre, _preview_out_of_save), (bpy.app.handlers.save_post, _preview_back_after_save))
