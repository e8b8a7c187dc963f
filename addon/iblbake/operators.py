"""The Bake IBL operator and its Cancel button.

From scripts (execute) the bake runs synchronously, start to end, and
replaces the folder's earlier bake as scripts expect, printing what it
replaced. From the UI (invoke) it first says what the bake would remove
from the folder (levels, the irradiance, an engine's folder, or a bake of
another world) and asks (Blender's dialog: OK bakes, moving away keeps
everything); then it is a modal job, so Blender never freezes:
core.job.BakeRun runs every slow step off the main thread - the world image
is read from its file and baked by a child process at the lowest CPU
priority (core/worker.py), a procedural world is rendered by Cycles in a
child Blender (world_reader.ChildRender) - and the modal operator only polls
it on a timer, redrawing the panel's progress bar when it moves visibly.
Esc or the Cancel button stops any stage; the earlier bake stays as it was."""
import time

import bpy
from bpy.app.handlers import persistent

from . import state, world_reader
from .core import folder, native, pipeline
from .core.job import BakeRun, Steps
from .core.worker import BakeProcess
from .properties import initialise_options
from .scene_settings import gather_settings, manifest_extra, scene_needs_for, unsaved_relative_folder

OUR_ERRORS = (pipeline.BakeError, world_reader.WorldError)
# The panel's bar is redrawn when its percentage changes, at most this often
# (its stage's name changing redraws at once): each redraw costs the UI a
# whole window's drawing, which a loaded machine without a GPU feels.
REDRAW_INTERVAL = 0.5


def _words(error, ours=OUR_ERRORS):
    """An error as the user reads it: ours in their own words, others with their type."""
    return error if isinstance(error, ours) else "%s: %s" % (type(error).__name__, error)


def prepare(context, scene):
    """Everything up to the native bake, on the main thread (scripts):
    settings, needs, world source and pixels. Raises BakeError / WorldError."""
    initialise_options(scene, context)
    settings = gather_settings(context, scene)
    needs = scene_needs_for(scene, settings)
    extra = manifest_extra(scene)
    source, pixels = world_reader.read_world(scene, settings.render_width, settings.render_samples)
    return settings, needs, source, pixels, extra


def headless_bake(context, scene, presets=None):
    """A script's bake in two halves. This one reads the world on the main
    thread (bpy) and returns the other, run(progress, say) -> BakeReport,
    which touches no bpy, so a batch may run it on another thread while
    Blender reads the next world (bake_world.py --batch --jobs). run
    replaces the folder's earlier bake, as scripts expect, and says what
    went: printed, or handed to say(text) (then the bake's warnings are not
    printed either: the caller lists them from the manifest).
    presets: a list of names in place of the scene's engine presets."""
    settings, needs, source, pixels, extra = prepare(context, scene)
    if presets is not None:
        settings.presets = presets

    def run(progress=None, say=None):
        old = folder.read_folder(settings.out_dir)
        report = pipeline.bake(source, pixels, settings, needs, progress, extra, print_warnings=say is None)
        if old is not None and report.status == "baked":
            try:
                gone = folder.losses(old, folder.outputs_of_manifest(report.manifest), source)
            except Exception as e:  # the bake is done: a failure to list what went is not the bake's
                gone = ["(what went could not be listed: %s)" % _words(e)]
            if gone:
                text = "replaced the earlier bake in %s: %s" % (report.out_dir, "; ".join(gone))
                if say is None:
                    print("iblbake: " + text, flush=True)
                else:
                    say(text)
        return report
    return run


def replacing(settings, needs, source):
    """(the folder's bake or None, what a bake of these settings would remove from it: sentences)."""
    old = folder.read_folder(settings.out_dir)
    if old is None:
        return None, []
    new = folder.planned_outputs(pipeline.native_options(settings, needs), settings.resolved_mip_count())
    return old, folder.losses(old, new, source)


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
    # Set by invoke when it asks first: what would go (one line each), and
    # that execute, called by the dialog's OK, starts the UI's modal bake.
    replaced: bpy.props.StringProperty(name="Replaced", default="", options={"HIDDEN", "SKIP_SAVE"})
    asked: bpy.props.BoolProperty(name="Asked", default=False, options={"HIDDEN", "SKIP_SAVE"})

    _running = None  # the running modal bake's operator (one at a time), for poll() and file loads
    _run = None      # this operator's core.job.BakeRun, once invoked
    _timer = None
    _shown = None    # the status bar's text, once shown

    @classmethod
    def poll(cls, context):
        scene = context.scene
        if scene is None or IBLBAKE_OT_bake._running is not None:
            return False
        why = unsaved_relative_folder(context, scene)
        if why:
            cls.poll_message_set(why[0].upper() + why[1:])  # the disabled button's tooltip
            return False
        return True

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
        self.report({"INFO"}, report.summary(folder=True))
        return {"FINISHED"}

    # -- scripts: synchronous ------------------------------------------------
    def execute(self, context):
        if self.asked:  # the dialog's OK (invoke asked first): the UI's bake
            return self._start(context)
        scene = context.scene
        progress = _print_stages if bpy.app.background else None
        start = time.perf_counter()
        presets = [n.strip() for n in self.presets.split(",") if n.strip()] if self.override_presets else None
        try:
            report = headless_bake(context, scene, presets)(progress)
        except OUR_ERRORS as e:
            return self._fail(scene.name, e)
        except native.load().Cancelled:
            return self._cancelled(scene.name)
        except Exception as e:  # anything else still reaches the user as a message
            return self._fail(scene.name, _words(e))
        report.seconds = time.perf_counter() - start
        return self._baked(scene.name, report)

    # -- the UI: asks first, then a modal job --------------------------------
    def invoke(self, context, event):
        scene = context.scene
        try:
            initialise_options(scene, context)
            settings = gather_settings(context, scene)
            source = world_reader.classify(scene.world)
            needs = scene_needs_for(scene, settings)
            settings.validate()
            old, gone = replacing(settings, needs, source)
        except Exception as e:
            return self._fail(scene.name, _words(e, OUR_ERRORS + (ValueError,)))
        if gone:
            self.replaced = "\n".join([old.out_dir] + gone)
            self.asked = True
            return invoke_dialog(context.window_manager, self)
        return self._start(context)

    def draw(self, context):
        """The dialog: what the bake would remove, before OK."""
        lines = self.replaced.split("\n")
        col = self.layout.column(align=True)
        col.label(text="This bake replaces the folder's bake:", icon="ERROR")
        col.label(text=lines[0], icon="FILE_FOLDER")
        col.separator()
        col.label(text="These would be removed:")
        for line in lines[1:]:
            col.label(text=line[0].upper() + line[1:], icon="TRASH")
        col.separator()
        col.label(text="OK bakes and replaces them; Esc keeps them.")

    def _start(self, context):
        scene = context.scene
        self._scene_name = scene.name
        clicked = time.perf_counter()
        try:
            initialise_options(scene, context)
            self._settings = gather_settings(context, scene)
            source = world_reader.classify(scene.world)
            needs = scene_needs_for(scene, self._settings)
            self._settings.validate()
        except Exception as e:
            return self._fail(scene.name, _words(e, OUR_ERRORS + (ValueError,)))
        self._world, self._frame = scene.world, scene.frame_current
        steps = Steps(world_reader.file_read_plan, world_reader.read_image_pixels, self._start_render,
                      start_job=lambda *job: BakeProcess(*job).start())
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
        redrawn only when the bar moves visibly: a new stage at once, a new
        percentage at most every REDRAW_INTERVAL seconds."""
        stage, fraction = self._run.stage, self._run.fraction
        now = time.perf_counter()
        text = "iblbake: %s %d%% (Esc to cancel)" % (stage, int(100 * fraction))
        if text == self._shown:
            return
        if state.RUN is not None and stage == state.RUN.stage and now - getattr(self, "_shown_at", 0.0) < REDRAW_INTERVAL:
            return
        if state.RUN is not None:
            state.RUN.stage, state.RUN.fraction = stage, fraction
        self._shown, self._shown_at = text, now
        try:
            context.workspace.status_text_set(text)
        except (AttributeError, ReferenceError):
            pass
        state.redraw(context, images=False, only_world=True)

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


def invoke_dialog(wm, op):
    """Blender's dialog for `op` (its draw()), OK titled "Bake and Replace" where Blender can (4.1+)."""
    try:
        return wm.invoke_props_dialog(op, width=420, title="Replace the Earlier Bake?", confirm_text="Bake and Replace")
    except TypeError:  # before 4.1: OK
        return wm.invoke_props_dialog(op, width=420)


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
        op._run.cleanup()
        IBLBAKE_OT_bake._running = None
    state.RUN = None
    state.clear()


classes = (IBLBAKE_OT_bake, IBLBAKE_OT_cancel)
HANDLERS = ((bpy.app.handlers.load_pre, _release_on_load),)
