"""The Bake IBL operator: copies the preferences' and the scene's properties
into a core BakeSettings, reads the world, and runs core.pipeline.bake -
synchronously from scripts (execute), on a background thread under a modal
operator from the UI (invoke), where Esc cancels."""
import os
import re

import bpy
from bpy.app.handlers import persistent

from . import preferences, scene_needs, world_reader
from .core import native, pipeline
from .core.job import BakeJob
from .core.needs import needs_from_lobes
from .core.settings import BakeSettings

OPTION_NAMES = ("face_size", "irradiance_size", "mip_count", "lut_size", "lut_model", "png_encoding", "exposure",
                "render_width", "render_samples")


def _safe(name: str) -> str:
    """A name as one path component: never empty, never "." or ".."."""
    s = re.sub(r"[^\w.-]+", "_", name).strip("_")
    return "untitled" if s.strip(".") == "" else s


def resolve_output_dir(scene, template: str) -> str:
    blend = bpy.data.filepath
    text = template.replace("{blend}", _safe(os.path.splitext(os.path.basename(blend))[0] if blend else "untitled"))
    text = text.replace("{scene}", _safe(scene.name))
    text = text.replace("{world}", _safe(scene.world.name if scene.world else "no_world"))
    if text.startswith("//") and not blend:
        raise pipeline.BakeError("the output folder %r is relative to the .blend file, which is not saved yet: "
                                 "save it or choose an absolute folder" % template)
    return os.path.abspath(os.path.expanduser(bpy.path.abspath(text)))


def gather_settings(context, scene) -> BakeSettings:
    """The preferences' defaults (or the scene's own options) and the scene's
    choices, as one BakeSettings."""
    prefs = preferences.get(context)
    props = scene.iblbake
    src = props if (props.use_scene_options or prefs is None) else prefs
    s = BakeSettings()
    for name in OPTION_NAMES:
        setattr(s, name, getattr(src, name))
    s.formats = [f for f, on in (("exr", src.write_exr), ("png", src.write_png)) if on]
    s.irradiance, s.specular, s.lut = props.bake_irradiance, props.bake_specular, props.bake_lut
    s.auto_skip, s.force = props.auto_skip, props.force
    if prefs is not None:
        s.lut_cache_dir = bpy.path.abspath(prefs.lut_cache_dir) if prefs.lut_cache_dir else ""
    template = props.output_dir or (prefs.default_output_dir if prefs else "")
    if not template:
        raise pipeline.BakeError("no output folder: set one in the World panel")
    s.out_dir = resolve_output_dir(scene, template)
    return s


def scene_needs_for(scene, settings: BakeSettings):
    lobes, surfaces = scene_needs.scene_lobes(scene)
    return needs_from_lobes(lobes, settings.resolved_mip_count(), surfaces)


def prepare(context, scene):
    """Everything up to the native bake (bpy work, main thread): settings,
    needs, world source and pixels. Raises BakeError / WorldError."""
    settings = gather_settings(context, scene)
    needs = scene_needs_for(scene, settings)
    source, pixels = world_reader.read_world(scene, settings.render_width, settings.render_samples)
    extra = {"scene": scene.name, "blend_file": bpy.data.filepath or None,
             "blender_version": bpy.app.version_string}
    return settings, needs, source, pixels, extra


def record(scene, report=None, error=None):
    props = scene.iblbake
    if error is not None:
        props.last_error = str(error)
        props.last_status = "Failed: %s" % error
        return
    props.last_error = ""
    props.last_status = report.summary()
    props.last_output = report.out_dir
    props.last_hash = report.content_hash


def _print_stages(stage, fraction, _last=[None]):
    """Headless progress: one line per stage."""
    if stage != _last[0]:
        _last[0] = stage
        print("iblbake: %s (%d%%)" % (stage, int(100 * fraction)), flush=True)
    return True


class IBLBAKE_OT_bake(bpy.types.Operator):
    """Bake the world's image-based lighting (irradiance, prefiltered specular, BRDF LUT) into the output folder"""
    bl_idname = "iblbake.bake"
    bl_label = "Bake IBL"
    bl_options = {"REGISTER"}

    _job = None
    _timer = None

    @classmethod
    def poll(cls, context):
        return context.scene is not None and IBLBAKE_OT_bake._job is None

    def _fail(self, scene, error):
        record(scene, error=error)
        self.report({"ERROR"}, "iblbake: %s" % error)
        return {"CANCELLED"}

    def execute(self, context):
        scene = context.scene
        progress = _print_stages if bpy.app.background else None
        try:
            settings, needs, source, pixels, extra = prepare(context, scene)
            report = pipeline.bake(source, pixels, settings, needs, progress, extra)
        except (pipeline.BakeError, world_reader.WorldError) as e:
            return self._fail(scene, e)
        except native.load().Cancelled:
            return self._fail(scene, "cancelled; the earlier bake is unchanged")
        except Exception as e:  # anything else still reaches the user as a message
            return self._fail(scene, "%s: %s" % (type(e).__name__, e))
        record(scene, report)
        self.report({"INFO"}, report.summary())
        return {"FINISHED"}

    def invoke(self, context, event):
        scene = context.scene
        try:
            settings, needs, source, pixels, extra = prepare(context, scene)
        except (pipeline.BakeError, world_reader.WorldError) as e:
            return self._fail(scene, e)
        except Exception as e:
            return self._fail(scene, "%s: %s" % (type(e).__name__, e))
        self._scene_name = scene.name
        self._workspace = context.workspace
        IBLBAKE_OT_bake._job = BakeJob(
            lambda progress: pipeline.bake(source, pixels, settings, needs, progress, extra)).start()
        wm = context.window_manager
        wm.progress_begin(0, 100)
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        context.workspace.status_text_set("iblbake: starting (Esc to cancel)")
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = IBLBAKE_OT_bake._job
        try:
            if job is None:  # released by a file load (see _release_on_load)
                return self._finish(context, None)
            if event.type == "ESC" and event.value == "PRESS":
                job.cancel()
                self._workspace.status_text_set("iblbake: cancelling...")
                return {"RUNNING_MODAL"}
            if event.type != "TIMER":
                return {"PASS_THROUGH"}
            stage, fraction = job.status()
            context.window_manager.progress_update(int(100 * fraction))
            self._workspace.status_text_set("iblbake: %s %d%% (Esc to cancel)" % (stage, int(100 * fraction)))
            if not job.done():
                return {"RUNNING_MODAL"}
            return self._finish(context, job)
        except Exception as e:  # never leave the timer, the progress bar or the job behind
            if job is not None:
                job.cancel()
            self._cleanup(context)
            self.report({"ERROR"}, "iblbake: %s: %s" % (type(e).__name__, e))
            return {"CANCELLED"}

    def _cleanup(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        try:
            self._workspace.status_text_set(None)
        except (ReferenceError, AttributeError):  # the workspace went away with a loaded file
            pass
        IBLBAKE_OT_bake._job = None

    def _finish(self, context, job):
        self._cleanup(context)
        if job is None:
            return {"CANCELLED"}
        scene = bpy.data.scenes.get(self._scene_name) or context.scene
        if job.cancelled:
            return self._fail(scene, "cancelled; the earlier bake is unchanged")
        if job.error is not None:
            return self._fail(scene, job.error)
        record(scene, job.result)
        self.report({"INFO"}, job.result.summary())
        for area in context.screen.areas:
            area.tag_redraw()
        return {"FINISHED"}


class IBLBAKE_OT_open_output(bpy.types.Operator):
    """Open the last bake's folder in the file browser"""
    bl_idname = "iblbake.open_output"
    bl_label = "Open Output Folder"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and os.path.isdir(context.scene.iblbake.last_output)

    def execute(self, context):
        bpy.ops.wm.path_open(filepath=context.scene.iblbake.last_output)
        return {"FINISHED"}


@persistent
def _release_on_load(*_args):
    """A file load drops modal handlers: cancel the running bake (nothing is
    written) so the Bake button works again in the new file."""
    job = IBLBAKE_OT_bake._job
    if job is not None:
        job.cancel()
        IBLBAKE_OT_bake._job = None


classes = (IBLBAKE_OT_bake, IBLBAKE_OT_open_output)
HANDLERS = ((bpy.app.handlers.load_pre, _release_on_load),)
