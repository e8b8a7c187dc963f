"""The last bake's files on the desktop: Open Output Folder (the file manager),
Open Preview (the preview sheet in an Image Editor) and Add Sun Lamp (the
sun a bake with sun="split" found, as a Sun lamp)."""
import math
import os
import shutil
import subprocess
import sys

import bpy

from . import state
from .core import describe
from .core.pipeline import BakeError
from .scene_settings import gather_settings

PREVIEW_IMAGE = "iblbake preview"


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


def show_image(context, img):
    """img in this screen's Image Editor; with none here, in a new window."""
    for area in context.screen.areas:
        if area.type == "IMAGE_EDITOR":
            area.spaces.active.image = img
            return
    bpy.ops.wm.window_new()
    window = context.window_manager.windows[-1]
    area = max(window.screen.areas, key=lambda a: a.width * a.height)
    area.type = "IMAGE_EDITOR"
    area.spaces.active.image = img


class IBLBAKE_OT_open_preview(bpy.types.Operator):
    """Show the last bake's preview sheet (irradiance, every specular level, the LUT and spheres lit by the bake) in an Image Editor"""
    bl_idname = "iblbake.open_preview"
    bl_label = "Open Preview"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and bool(state.last(context.scene.name).preview)

    def execute(self, context):
        img = load_preview(state.last(context.scene.name).preview)
        if img is None:
            self.report({"ERROR"}, "iblbake: the preview file is gone")
            return {"CANCELLED"}
        show_image(context, img)
        return {"FINISHED"}


def _open_folder_fallback(path, proc):
    """Checks the file manager's process a moment later; if it failed, says where the files are."""
    def check():
        code = proc.poll()
        if code is None:
            return None  # still running: the file manager is up
        if code != 0:
            _no_file_manager(path)
        return None
    return check


def _no_file_manager(path):
    scene = bpy.context.scene
    if scene is not None:
        last = state.last(scene.name)
        last.status = "No file manager could be opened: the files are in %s (path copied)" % path
        state.set_last(scene.name, last)
    bpy.context.window_manager.clipboard = path
    state.redraw()


class IBLBAKE_OT_open_output(bpy.types.Operator):
    """Open the output folder in the file manager (when none can be started, the panel shows the path and it is copied to the clipboard)"""
    bl_idname = "iblbake.open_output"
    bl_label = "Open Output Folder"

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        try:
            path = state.last(context.scene.name).out_dir or gather_settings(context, context.scene).out_dir
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
            _no_file_manager(path)
            self.report({"WARNING"}, "iblbake: no file manager (xdg-open) here; the files are in %s "
                                     "(path copied to the clipboard)" % path)
            return {"FINISHED"}
        proc = subprocess.Popen([opener, path], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                stdin=subprocess.DEVNULL)
        bpy.app.timers.register(_open_folder_fallback(path, proc), first_interval=3.0)
        self.report({"INFO"}, "iblbake: opening %s" % path)
        return {"FINISHED"}


SUN_LAMP = "IBL Sun"


def last_sun(context, scene):
    """The sun of the scene's last bake (the manifest's `sun`), else that of
    the bake in its output folder; None when neither looked for one."""
    sun = state.last(scene.name).sun
    if sun is None:
        try:
            out = gather_settings(context, scene).out_dir
        except (BakeError, ValueError):
            return None
        sun = (describe.manifest_of(out) or {}).get("sun")
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
        obj = add_sun_lamp(scene, sun, state.last(scene.name).out_dir)
        self.report({"INFO"}, "iblbake: %s: %s" % (obj.name, describe.sun_sentence(sun)))
        return {"FINISHED"}


classes = (IBLBAKE_OT_open_output, IBLBAKE_OT_open_preview, IBLBAKE_OT_add_sun_lamp)
