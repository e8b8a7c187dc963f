"""The Bake IBL operator and its helpers.

From scripts (execute) the bake runs synchronously, start to end. From the
UI (invoke) it is a modal job, so Blender never freezes: every slow step
runs off the main thread - the world image is read from its file by the
native reader on a worker thread, a procedural world is rendered by Cycles
in a child Blender (world_reader.ChildRender), the bake itself runs on a
worker thread (the native code releases the GIL) - and the main thread only
polls them on a timer, updating the panel's progress bar. Esc or the Cancel
button stops any stage; the earlier bake stays as it was."""
import os
import shutil
import subprocess
import sys
import time

import bpy
from bpy.app.handlers import persistent

from . import preferences, scene_needs, state, world_reader
from .core import describe, names, native, pipeline
from .core.job import BakeJob
from .core.needs import needs_from_lobes
from .core.settings import BakeSettings
from .core.world import COLOR, IMAGE, RENDER, FileNotAsBlenderShowsIt, WorldSource, read_file_pixels

OPTION_NAMES = ("face_size", "irradiance_size", "mip_count", "lut_size", "lut_model", "png_encoding", "exposure",
                "render_width", "render_samples")

# Native stage names -> what the panel says.
STAGE_WORDS = {"reading source": "Scanning the image", "specular": "Specular levels", "irradiance": "Irradiance",
               "brdf_lut": "BRDF LUT", "done": "Writing files", "writing": "Writing files", "starting": "Starting",
               "hashing": "Checking for changes"}


def resolve_output_dir(scene, template: str) -> str:
    blend = bpy.data.filepath
    try:
        text = names.fill_template(template, os.path.splitext(os.path.basename(blend))[0] if blend else "untitled",
                                   scene.name, scene.world.name if scene.world else "no_world")
    except names.TemplateError as e:
        raise pipeline.BakeError(str(e))
    if text.startswith("//") and not blend:
        raise pipeline.BakeError("the output folder %r is relative to the .blend file, which is not saved yet: "
                                 "save the file, or choose an absolute folder" % template)
    return os.path.abspath(os.path.expanduser(bpy.path.abspath(text)))


def output_template(context, scene) -> str:
    prefs = preferences.get(context)
    return scene.iblbake.output_dir or (prefs.default_output_dir if prefs else "") or "//ibl/{world}"


def engine_names(props) -> list:
    """The engine presets ticked in `props` (an ENUM_FLAG set), in the table's order."""
    chosen = set(getattr(props, "engines", set()) or ())
    return [name for name in preferences.engine_ids() if name in chosen]


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
    s.presets = engine_names(src)
    s.preview = bool(getattr(src, "write_preview", True))
    s.irradiance, s.specular, s.lut = props.bake_irradiance, props.bake_specular, props.bake_lut
    s.auto_skip, s.force = props.auto_skip, props.force
    if prefs is not None:
        s.lut_cache_dir = bpy.path.abspath(prefs.lut_cache_dir) if prefs.lut_cache_dir else ""
    s.out_dir = resolve_output_dir(scene, output_template(context, scene))
    return s


def scene_needs_for(scene, settings: BakeSettings):
    lobes, surfaces = scene_needs.scene_lobes(scene)
    return needs_from_lobes(lobes, settings.resolved_mip_count(), surfaces)


def _extra(scene):
    return {"scene": scene.name, "blend_file": bpy.data.filepath or None, "blender_version": bpy.app.version_string}


def prepare(context, scene):
    """Everything up to the native bake, on the main thread (scripts):
    settings, needs, world source and pixels. Raises BakeError / WorldError."""
    settings = gather_settings(context, scene)
    needs = scene_needs_for(scene, settings)
    source, pixels = world_reader.read_world(scene, settings.render_width, settings.render_samples)
    return settings, needs, source, pixels, _extra(scene)


def record(scene_name, report=None, error=None, cancelled=False, stages=None, out_dir=""):
    """The scene's last result, for the panel (state.py; not saved in the .blend)."""
    old = state.last(scene_name)
    if cancelled:
        state.set_last(scene_name, state.Last(
            status="Cancelled: the earlier bake is unchanged", kind="CANCEL", out_dir=old.out_dir or out_dir,
            files=old.files, total_bytes=old.total_bytes, preview=old.preview, content_hash=old.content_hash,
            thumbnail=old.thumbnail))
        _redraw()
        return
    if error is not None:
        state.set_last(scene_name, state.Last(
            status="Failed: %s" % error, kind="ERROR", error=str(error), out_dir=old.out_dir or out_dir,
            files=old.files, total_bytes=old.total_bytes, preview=old.preview, content_hash=old.content_hash,
            thumbnail=old.thumbnail))
        _redraw()
        return
    files, total = describe.bake_files(report.out_dir)
    preview = os.path.join(report.out_dir, "preview.png")
    state.set_last(scene_name, state.Last(
        status=report.summary(), kind="INFO", out_dir=report.out_dir, content_hash=report.content_hash,
        files=files, total_bytes=total, preview=preview if os.path.isfile(preview) else "",
        thumbnail=getattr(report, "thumbnail", None), stages=list(stages or [])))
    _redraw()


def _print_stages(stage, fraction, _last=[None]):
    """Headless progress: one line per stage."""
    if stage != _last[0]:
        _last[0] = stage
        print("iblbake: %s (%d%%)" % (stage, int(100 * fraction)), flush=True)
    return True


def _redraw(context=None):
    wm = bpy.context.window_manager if context is None else context.window_manager
    if wm is None:  # background mode
        return
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type in ("PROPERTIES", "STATUSBAR", "IMAGE_EDITOR"):
                area.tag_redraw()


class IBLBAKE_OT_bake(bpy.types.Operator):
    """Bake the world's image-based lighting (irradiance, prefiltered specular, BRDF LUT) into the output folder"""
    bl_idname = "iblbake.bake"
    bl_label = "Bake IBL"
    bl_options = {"REGISTER"}

    # Scripts (bake_world.py --preset) may replace the scene's engine presets
    # for one bake: comma-separated names, "NAME:FORMAT" variants allowed.
    presets: bpy.props.StringProperty(name="Presets", default="", options={"HIDDEN", "SKIP_SAVE"})
    override_presets: bpy.props.BoolProperty(name="Override Presets", default=False, options={"HIDDEN", "SKIP_SAVE"})

    _running = None  # the running modal bake's operator (one at a time), for poll() and file loads
    _job = None      # this operator's worker thread (core.job.BakeJob), once started

    @classmethod
    def poll(cls, context):
        return context.scene is not None and IBLBAKE_OT_bake._running is None

    def _fail(self, scene_name, error, out_dir=""):
        record(scene_name, error=error, out_dir=out_dir)
        self.report({"ERROR"}, "iblbake: %s" % error)
        return {"CANCELLED"}

    # -- scripts: synchronous ------------------------------------------------
    def execute(self, context):
        scene = context.scene
        progress = _print_stages if bpy.app.background else None
        start = time.perf_counter()
        try:
            settings, needs, source, pixels, extra = prepare(context, scene)
            if self.override_presets:
                settings.presets = [n.strip() for n in self.presets.split(",") if n.strip()]
            report = pipeline.bake(source, pixels, settings, needs, progress, extra)
        except (pipeline.BakeError, world_reader.WorldError) as e:
            return self._fail(scene.name, e)
        except native.load().Cancelled:
            record(scene.name, cancelled=True)
            self.report({"INFO"}, "iblbake: cancelled; the earlier bake is unchanged")
            return {"CANCELLED"}
        except Exception as e:  # anything else still reaches the user as a message
            return self._fail(scene.name, "%s: %s" % (type(e).__name__, e))
        report.seconds = time.perf_counter() - start
        record(scene.name, report)
        self.report({"INFO"}, report.summary())
        return {"FINISHED"}

    # -- the UI: a modal job -------------------------------------------------
    def invoke(self, context, event):
        scene = context.scene
        self._scene_name = scene.name
        self._clicked = time.perf_counter()
        self._stages = []            # (name, seconds) the user waited for
        self._stage_start = self._clicked
        self._child = None
        self._pre = 0.0              # share of the bar before the native bake
        try:
            self._settings = gather_settings(context, scene)
            self._source = world_reader.classify(scene.world)
            self._needs = scene_needs_for(scene, self._settings)
            self._settings.validate()
        except (pipeline.BakeError, world_reader.WorldError, ValueError) as e:
            return self._fail(scene.name, e)
        except Exception as e:
            return self._fail(scene.name, "%s: %s" % (type(e).__name__, e))
        self._extra = _extra(scene)
        self._world = scene.world
        self._frame = scene.frame_current
        self._step = "start"
        IBLBAKE_OT_bake._running = self
        state.RUN = state.Run(scene.name, "Starting")
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.05, window=context.window)
        wm.modal_handler_add(self)
        self._status(context, "Starting", 0.0)
        return {"RUNNING_MODAL"}

    def _status(self, context, stage, fraction):
        """The stage and the whole bake's fraction, for the panel and the status
        bar; redrawn only when what they show changes (each redraw costs)."""
        run = state.RUN
        if run is not None:
            run.stage, run.fraction = stage, max(run.fraction, min(1.0, fraction))
            fraction = run.fraction
        text = "iblbake: %s %d%% (Esc to cancel)" % (stage, int(100 * fraction))
        if text == getattr(self, "_shown", None):
            return
        self._shown = text
        try:
            context.workspace.status_text_set(text)
        except (AttributeError, ReferenceError):
            pass
        _redraw(context)

    def _end_stage(self, name):
        now = time.perf_counter()
        self._stages.append((name, now - self._stage_start))
        self._stage_start = now

    def _start_bake(self, pixels_fn, pre_name=None):
        """The rest on a worker thread: pixels_fn() (reading a file, say) then the native bake."""
        settings, needs, source, extra = self._settings, self._needs, self._source, dict(self._extra)
        stages = self._stages

        def work(progress):
            pixels = None
            if pixels_fn is not None:
                t = time.perf_counter()
                progress("reading", 0.0)
                pixels = pixels_fn()
                if pre_name:
                    stages.append((pre_name, time.perf_counter() - t))
            extra["waited"] = {name: round(sec, 4) for name, sec in stages}
            report = pipeline.bake(source, pixels, settings, needs, progress, extra)
            preview = os.path.join(report.out_dir, "preview.png")
            if os.path.isfile(preview):  # the panel's thumbnail, made here rather than on the main thread
                try:
                    report.thumbnail = describe.thumbnail(native.load().read_image(preview))
                except (OSError, RuntimeError, ValueError):
                    pass
            return report

        self._job = BakeJob(work).start()
        self._step = "bake"

    def modal(self, context, event):
        try:
            if IBLBAKE_OT_bake._running is not self:  # released by a file load (see _release_on_load)
                return self._finish(context, cancelled=True)
            run = state.RUN
            if self._step == "cancelling":
                return self._poll_cancel(context) if event.type == "TIMER" else {"PASS_THROUGH"}
            if (event.type == "ESC" and event.value == "PRESS") or (run is not None and run.cancel_requested):
                return self._cancel(context)
            if event.type != "TIMER":
                return {"PASS_THROUGH"}
            return self._advance(context)
        except Exception as e:  # never leave the timer, the child or the job behind
            self._abort()
            self._cleanup(context)
            return self._fail(self._scene_name, "%s: %s" % (type(e).__name__, e), self._settings.out_dir)

    def _advance(self, context):
        src = self._source
        if self._step == "start":  # the panel has drawn "Starting" by now
            if src.path == COLOR:
                self._start_bake(None)
            elif src.path == IMAGE:
                plan = world_reader.file_read_plan(src)
                if plan is None:
                    self._step = "buffer"
                    self._status(context, "Reading the image from Blender", 0.02)
                else:
                    path, alpha = plan
                    core = native.load()
                    self._pre = 0.1
                    self._start_bake(lambda: read_file_pixels(src, core.read_image, core.remap_latlong, alpha),
                                     "read_image_file")
            else:
                self._start_render(context)
            return {"RUNNING_MODAL"}
        if self._step == "buffer":  # Blender's own buffer: main thread, one foreach_get
            try:
                pixels = world_reader.read_image_pixels(src)
            except world_reader.NeedsRender as e:
                self._source = WorldSource(RENDER, str(e), world=src.world)
                self._start_render(context)
                return {"RUNNING_MODAL"}
            self._end_stage("read_image_buffer")
            self._pre = 0.1
            self._start_bake(lambda: pixels)
            return {"RUNNING_MODAL"}
        if self._step == "render":
            child = self._child
            if not child.done():
                self._status(context, "Rendering the world with Cycles", 0.02 + (self._pre - 0.02) * child.fraction)
                return {"RUNNING_MODAL"}
            path, notes = child.result()
            self._source.render["notes"] = self._render_notes + notes
            self._end_stage("render_world")
            self._start_bake(lambda: native.load().read_image(path), "read_render")
            return {"RUNNING_MODAL"}
        job = self._job
        stage, fraction = job.status()
        if stage == "reading":
            words = "Reading the world image" if src.path == IMAGE else "Reading the render"
            self._status(context, words, self._pre * 0.5)
        else:
            self._status(context, STAGE_WORDS.get(stage, stage.capitalize()), self._pre + (1 - self._pre) * fraction)
        if not job.done():
            return {"RUNNING_MODAL"}
        if isinstance(job.error, FileNotAsBlenderShowsIt):  # read Blender's buffer instead
            self._stages[:] = [s for s in self._stages if s[0] != "read_image_file"]
            self._step = "buffer"
            self._status(context, "Reading the image from Blender", 0.02)
            return {"RUNNING_MODAL"}
        return self._finish(context)

    def _start_render(self, context):
        src = self._source
        src.render, self._render_notes = world_reader.render_settings(
            bpy.data.scenes[self._scene_name], self._settings.render_width, self._settings.render_samples)
        self._child = world_reader.ChildRender(self._world, src.render["width"], src.render["samples"],
                                               self._frame).start()
        self._pre = 0.6
        self._step = "render"
        self._status(context, "Rendering the world with Cycles", 0.02)

    def _abort(self):
        """Asks the child render and the worker to stop; returns at once."""
        if self._child is not None:
            self._child.cancel()
        job = getattr(self, "_job", None)
        if isinstance(job, BakeJob):
            job.cancel()

    def _cancel(self, context):
        """Stops the child render or the worker; the worker is then waited for
        on the timer (a file read in progress ends on its own, the native
        bake at its next progress report), never on the main thread."""
        self._abort()
        self._step = "cancelling"
        self._status(context, "Cancelling", state.RUN.fraction if state.RUN else 0.0)
        return self._poll_cancel(context)

    def _poll_cancel(self, context):
        if self._child is not None and not self._child.done():
            return {"RUNNING_MODAL"}
        job = getattr(self, "_job", None)
        if not isinstance(job, BakeJob):
            return self._finish(context, cancelled=True)
        if not job.done():
            return {"RUNNING_MODAL"}
        if job.result is not None:  # it had finished (and written) before the key press: say so
            return self._finish(context)
        return self._finish(context, cancelled=True)

    def _cleanup(self, context):
        wm = context.window_manager
        if getattr(self, "_timer", None) is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        try:
            context.workspace.status_text_set(None)
        except (ReferenceError, AttributeError):  # the workspace went away with a loaded file
            pass
        if self._child is not None:
            self._child.cleanup()
        if IBLBAKE_OT_bake._running is self:
            IBLBAKE_OT_bake._running = None
        state.RUN = None
        _redraw(context)

    def _finish(self, context, cancelled=False):
        self._cleanup(context)
        name = self._scene_name
        job = getattr(self, "_job", None)
        if cancelled or (isinstance(job, BakeJob) and job.cancelled):
            record(name, cancelled=True)
            self.report({"INFO"}, "iblbake: cancelled; the earlier bake is unchanged")
            return {"CANCELLED"}
        if job.error is not None:
            e = job.error
            if not isinstance(e, (pipeline.BakeError, world_reader.WorldError)):
                e = "%s: %s" % (type(e).__name__, e)
            return self._fail(name, e, self._settings.out_dir)
        report = job.result
        self._end_stage("bake")
        report.seconds = time.perf_counter() - self._clicked  # what the user waited, from the click
        record(name, report, stages=self._stages)
        self.report({"INFO"}, report.summary())
        return {"FINISHED"}


class IBLBAKE_OT_cancel(bpy.types.Operator):
    """Stop the running bake; the earlier bake in the folder stays as it was (Esc does the same)"""
    bl_idname = "iblbake.cancel"
    bl_label = "Cancel"

    @classmethod
    def poll(cls, context):
        return state.RUN is not None

    def execute(self, context):
        state.RUN.cancel_requested = True
        op = IBLBAKE_OT_bake._running
        if op is not None:  # stop the work now; the modal operator reports at its next event
            op._abort()
        return {"FINISHED"}


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
        for area in context.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = img
                return {"FINISHED"}
        # No Image Editor here: a new window showing it.
        bpy.ops.wm.window_new()
        window = context.window_manager.windows[-1]
        area = max(window.screen.areas, key=lambda a: a.width * a.height)
        area.type = "IMAGE_EDITOR"
        area.spaces.active.image = img
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
    _redraw()


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
        except pipeline.BakeError as e:
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


@persistent
def _release_on_load(*_args):
    """A file load drops modal handlers: stop the running bake (nothing is
    written) so the Bake button works again in the new file, and forget the
    old file's results."""
    op = IBLBAKE_OT_bake._running
    if op is not None:
        op._abort()
        IBLBAKE_OT_bake._running = None
    state.RUN = None
    state.clear()


classes = (IBLBAKE_OT_bake, IBLBAKE_OT_cancel, IBLBAKE_OT_open_output, IBLBAKE_OT_open_preview)
HANDLERS = ((bpy.app.handlers.load_pre, _release_on_load),)
