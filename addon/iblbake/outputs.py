"""The last bake's files on the desktop: Open Output Folder (the file manager)
and Open Preview (the preview sheet in an Image Editor)."""
import os
import shutil
import subprocess
import sys

import bpy

from . import state
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


classes = (IBLBAKE_OT_open_output, IBLBAKE_OT_open_preview)
