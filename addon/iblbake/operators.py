"""The Bake IBL operator and its Cancel button.

From scripts (execute) the bake runs synchronously, start to end. From the
UI (invoke) it is a modal job, so Blender never freezes: core.job.BakeRun
runs every slow step off the main thread - the world image is read from its
file by the native reader on a worker thread, a procedural world is rendered
by Cycles in a child Blender (world_reader.ChildRender), the bake itself
runs on a worker thread (the native code releases the GIL) - and the modal
operator only polls it on a timer, updating the panel's progress bar. Esc
or the Cancel button stops any stage; the earlier bake stays as it was."""
import time

import bpy
from bpy.app.handlers import persistent

from . import state, world_reader
from .core import native, pipeline
from .core.job import BakeRun, Steps
from .scene_settings import gather_settings, manifest_extra, scene_needs_for

OUR_ERRORS = (pipeline.BakeError, world_reader.WorldError)


def _words(error, ours=OUR_ERRORS):
    """An error as the user reads it: ours in their own words, others with their type."""
    return error if isinstance(error, ours) else "%s: %s" % (type(error).__name__, error)


def prepare(context, scene):
    """Everything up to the native bake, on the main thread (scripts):
    settings, needs, world source and pixels. Raises BakeError / WorldError."""
    settings = gather_settings(context, scene)
    needs = scene_needs_for(scene, settings)
    source, pixels = world_reader.read_world(scene, settings.render_width, settings.render_samples)
    return settings, needs, source, pixels, manifest_extra(scene)


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

    # Scripts (bake_world.py --preset) may replace the scene's engine presets
    # for one bake: comma-separated names, "NAME:FORMAT" variants allowed.
    presets: bpy.props.StringProperty(name="Presets", default="", options={"HIDDEN", "SKIP_SAVE"})
    override_presets: bpy.props.BoolProperty(name="Override Presets", default=False, options={"HIDDEN", "SKIP_SAVE"})

    _running = None  # the running modal bake's operator (one at a time), for poll() and file loads
    _run = None      # this operator's core.job.BakeRun, once invoked
    _timer = None
    _shown = None    # the status bar's text, once shown

    @classmethod
    def poll(cls, context):
        return context.scene is not None and IBLBAKE_OT_bake._running is None

    def _fail(self, scene_name, error, out_dir=""):
        state.set_failed(scene_name, error, out_dir)
        self.report({"ERROR"}, "iblbake: %s" % error)
        return {"CANCELLED"}

    def _cancelled(self, scene_name):
        state.set_cancelled(scene_name)
        self.report({"INFO"}, "iblbake: cancelled; the earlier bake is unchanged")
        return {"CANCELLED"}

    def _baked(self, scene_name, report, stages=()):
        state.set_baked(scene_name, report, stages)
        self.report({"INFO"}, report.summary())
        return {"FINISHED"}

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
        except OUR_ERRORS as e:
            return self._fail(scene.name, e)
        except native.load().Cancelled:
            return self._cancelled(scene.name)
        except Exception as e:  # anything else still reaches the user as a message
            return self._fail(scene.name, _words(e))
        report.seconds = time.perf_counter() - start
        return self._baked(scene.name, report)

    # -- the UI: a modal job -------------------------------------------------
    def invoke(self, context, event):
        scene = context.scene
        self._scene_name = scene.name
        clicked = time.perf_counter()
        try:
            self._settings = gather_settings(context, scene)
            source = world_reader.classify(scene.world)
            needs = scene_needs_for(scene, self._settings)
            self._settings.validate()
        except Exception as e:
            return self._fail(scene.name, _words(e, OUR_ERRORS + (ValueError,)))
        self._world, self._frame = scene.world, scene.frame_current
        steps = Steps(world_reader.file_read_plan, world_reader.read_image_pixels, self._start_render)
        self._run = BakeRun(source, self._settings, needs, manifest_extra(scene), steps, clicked)
        IBLBAKE_OT_bake._running = self
        state.RUN = state.Run(scene.name, "Starting")
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.05, window=context.window)
        wm.modal_handler_add(self)
        self._status(context)
        return {"RUNNING_MODAL"}

    def _start_render(self, source):
        """The Cycles render of a procedural world, in a child Blender (BakeRun's Steps.start_render)."""
        settings = self._settings
        source.render, notes = world_reader.render_settings(
            bpy.data.scenes[self._scene_name], settings.render_width, settings.render_samples)
        source.render["notes"] = notes
        return world_reader.ChildRender(self._world, source.render["width"], source.render["samples"],
                                        self._frame).start()

    def modal(self, context, event):
        try:
            if IBLBAKE_OT_bake._running is not self:  # released by a file load (see _release_on_load)
                return self._finish(context, cancelled=True)
            if event.type == "ESC" and event.value == "PRESS" and not self._run.cancel_requested:
                self._stop(context)  # and polled at once: a run that has started nothing ends here
            elif event.type != "TIMER":
                return {"PASS_THROUGH"}
            return self._advance(context)
        except Exception as e:  # never leave the timer, the child or the job behind
            self._run.cancel()
            self._cleanup(context)
            return self._fail(self._scene_name, _words(e, ours=()), self._settings.out_dir)

    def _stop(self, context):
        """Esc or the Cancel button: the run stops its stages, never waiting
        for them here; the panel says "Cancelling" until they have stopped."""
        self._run.cancel()
        self._status(context)

    def _advance(self, context):
        self._run.poll()
        if self._run.finished:
            return self._finish(context)
        self._status(context)
        return {"RUNNING_MODAL"}

    def _status(self, context):
        """The run's stage and fraction, for the panel and the status bar;
        redrawn only when what they show changes (each redraw costs)."""
        stage, fraction = self._run.stage, self._run.fraction
        if state.RUN is not None:
            state.RUN.stage, state.RUN.fraction = stage, fraction
        text = "iblbake: %s %d%% (Esc to cancel)" % (stage, int(100 * fraction))
        if text == self._shown:
            return
        self._shown = text
        try:
            context.workspace.status_text_set(text)
        except (AttributeError, ReferenceError):
            pass
        state.redraw(context)

    def _cleanup(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        try:
            context.workspace.status_text_set(None)
        except (ReferenceError, AttributeError):  # the workspace went away with a loaded file
            pass
        self._run.cleanup()
        if IBLBAKE_OT_bake._running is self:
            IBLBAKE_OT_bake._running = None
        state.RUN = None
        state.redraw(context)

    def _finish(self, context, cancelled=False):
        self._cleanup(context)
        run = self._run
        if cancelled or run.cancelled:
            return self._cancelled(self._scene_name)
        if run.error is not None:
            return self._fail(self._scene_name, _words(run.error), self._settings.out_dir)
        return self._baked(self._scene_name, run.report, run.stages)


class IBLBAKE_OT_cancel(bpy.types.Operator):
    """Stop the running bake; the earlier bake in the folder stays as it was (Esc does the same)"""
    bl_idname = "iblbake.cancel"
    bl_label = "Cancel"

    @classmethod
    def poll(cls, context):
        return state.RUN is not None

    def execute(self, context):
        op = IBLBAKE_OT_bake._running
        if op is not None:  # stop the work now; the modal operator reports at its next timer event
            op._stop(context)
        return {"FINISHED"}


@persistent
def _release_on_load(*_args):
    """A file load drops modal handlers: stop the running bake (nothing is
    written) so the Bake button works again in the new file, and forget the
    old file's results."""
    op = IBLBAKE_OT_bake._running
    if op is not None:
        op._run.cancel()
        IBLBAKE_OT_bake._running = None
    state.RUN = None
    state.clear()


classes = (IBLBAKE_OT_bake, IBLBAKE_OT_cancel)
HANDLERS = ((bpy.app.handlers.load_pre, _release_on_load),)
