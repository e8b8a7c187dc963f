"""The UI's bake as a job the modal operator polls on a timer, so Blender
never freezes: BakeRun reads the world image's file (or Blender's buffer),
or has Cycles render the world, then bakes, every slow step off the main
thread: in a child process (core/worker.py's BakeProcess, what the add-on
uses) or on a worker thread (BakeJob). No bpy: what needs it comes in as
callables (Steps)."""
import threading
import time
from dataclasses import dataclass
from typing import Callable, Optional

from . import native, pipeline
from .world import COLOR, IMAGE, RENDER, FileNotAsBlenderShowsIt, NeedsRender, WorldSource
from .worker import Work, read_file_natively, read_image, run_work, with_thumbnail  # noqa: F401


class BakeJob:
    """A bake on a background thread: the native code releases the GIL, so
    Blender's UI keeps running; cancel() makes the next progress callback
    return False, and the bake then stops without writing."""

    def __init__(self, work: Callable[[Callable[[str, float], bool]], object]):
        """`work(progress)` runs on the thread; its result or exception is kept."""
        self._work = work
        self._lock = threading.Lock()
        self._cancel = threading.Event()
        self.stage, self.fraction = "starting", 0.0
        self.result: Optional[object] = None
        self.error: Optional[BaseException] = None
        self.cancelled = False
        self.stages = []  # the timed reads of the work (run_work's)
        self._thread = threading.Thread(target=self._run, name="iblbake", daemon=True)

    def start(self):
        self._thread.start()
        return self

    def _progress(self, stage: str, fraction: float) -> bool:
        with self._lock:
            self.stage, self.fraction = stage, fraction
        return not self._cancel.is_set()

    def _run(self):
        try:
            self.result = self._work(self._progress)
        except native.load().Cancelled:
            self.cancelled = True
        except BaseException as e:  # reported by the operator on the main thread
            self.error = e

    def cancel(self):
        self._cancel.set()

    def done(self) -> bool:
        return not self._thread.is_alive()

    def wait(self, timeout: Optional[float] = None) -> bool:
        self._thread.join(timeout)
        return self.done()

    def status(self):
        with self._lock:
            return self.stage, self.fraction


@dataclass
class Steps:
    """What the stages run. The first three need bpy (the operator passes
    world_reader's); the others default to the native module and the pipeline."""
    # (path, alpha matters) when the image's file can be read off the main
    # thread, None when Blender's buffer must be read instead.
    file_plan: Callable
    # Blender's pixels of the image, on the main thread; raises NeedsRender.
    read_buffer: Callable
    # Starts the Cycles render of a RENDER source (filling source.render) and
    # returns it: done(), fraction, result() -> (exr path, notes), cancel(), cleanup().
    start_render: Callable
    read_file: Callable = read_file_natively   # (source, alpha matters, progress) -> pixels, worker thread
    read_render: Callable = read_image         # (exr path, progress) -> pixels, worker thread
    bake: Callable = pipeline.bake             # pipeline.bake's arguments -> BakeReport, worker thread
    # (Work, source, settings, needs, extra) -> a started job (BakeJob's
    # interface, `stages` its timed reads); None: a BakeJob running the
    # three callables above.
    start_job: Optional[Callable] = None


# The native bake's stage names -> what the panel says.
STAGE_WORDS = {"reading source": "Scanning the image", "specular": "Specular levels", "irradiance": "Irradiance",
               "brdf_lut": "BRDF LUT", "done": "Writing files", "writing": "Writing files", "starting": "Starting",
               "hashing": "Checking for changes"}
# (short: the bar is narrow at the Properties editor's default width)
RENDERING = "Rendering with Cycles"
STARTING_RENDER = "Starting Cycles"
SAVING_RENDER = "Saving the render"
READING_BUFFER = "Reading from Blender"
READING_FILE = "Reading the image"
READING_RENDER = "Reading the render"

# The progress bar's share of the stages before the native bake.
FIRST = 0.02          # while Blender's buffer is read, or the render starts
READ_SHARE = 0.15     # an image read
RENDER_SHARE = 0.6    # a render, then reading it


class BakeRun:
    """One bake from the click to its outcome, advanced by poll() on the main
    thread's timer: each call does at most one quick main-thread step (reading
    Blender's buffer is one foreach_get) or looks at what the child render or
    the worker thread has done. A main-thread step's exception propagates
    from poll(), as any error in the operator's own code does; the worker's
    becomes `error`. stage and fraction say how far
    it got (the fraction never goes back); once `finished`, exactly one of
    `report`, `error` and `cancelled` says how it ended."""

    def __init__(self, source: WorldSource, settings, needs, extra: dict, steps: Steps,
                 clicked: Optional[float] = None):
        self.source = source
        self._settings, self._needs, self._extra, self._steps = settings, needs, extra, steps
        self._clicked = time.perf_counter() if clicked is None else clicked
        self._stage_start = self._clicked
        self.stages = []              # (name, seconds) the user waited for
        self._step = self._start
        self._render = None           # the Cycles render, once started
        self._job = None              # the worker thread, once started
        self._pre = 0.0               # the bar's share before the native bake
        self.stage, self.fraction = "Starting", 0.0
        self.cancel_requested = self.finished = self.cancelled = False
        self.report = self.error = None

    def poll(self):
        """One step (main thread); a no-op once finished."""
        if not self.finished:
            (self._wait_for_stop if self.cancel_requested else self._step)()

    def cancel(self):
        """Asks the render and the worker to stop and returns at once: poll()
        then waits for them (a file read in progress ends on its own, the
        native bake at its next progress report), never blocking."""
        self.cancel_requested = True
        self.stage = "Cancelling"
        if self._render is not None:
            self._render.cancel()
        if self._job is not None:
            self._job.cancel()

    def cleanup(self):
        """Ends the render and the bake's process, if any, and removes their files."""
        if self._render is not None:
            self._render.cleanup()
        if self._job is not None and hasattr(self._job, "cleanup"):
            self._job.cleanup()

    # -- the steps -----------------------------------------------------------
    def _start(self):
        if self.source.path == COLOR:
            self._start_work(Work("none"))
        elif self.source.path == IMAGE:
            self._start_image()
        else:
            self._start_render()

    def _start_image(self):
        plan = self._steps.file_plan(self.source)
        if plan is None:
            self._to_buffer()
            return
        self._pre = READ_SHARE
        self._start_work(Work("file", self.source.image_path, plan[1], timed="read_image_file"))

    def _to_buffer(self):
        self._step = self._read_buffer
        self._show(READING_BUFFER, FIRST)

    def _read_buffer(self):
        try:
            pixels = self._steps.read_buffer(self.source)
        except NeedsRender as e:
            self.source = WorldSource(RENDER, str(e), world=self.source.world)
            self._start_render()
            return
        self._end_stage("read_image_buffer")
        self._pre = READ_SHARE
        self._start_work(Work("array", array=pixels))

    def _start_render(self):
        self._render = self._steps.start_render(self.source)
        self._pre = RENDER_SHARE
        self._step = self._wait_render
        self._show(STARTING_RENDER, FIRST)

    def _wait_render(self):
        render = self._render
        if not render.done():  # Blender starting and Cycles syncing, then its tiles and samples
            sampling = getattr(render, "sampling", True)
            stage = SAVING_RENDER if getattr(render, "saving", False) else RENDERING if sampling else STARTING_RENDER
            self._show(stage, FIRST + (self._pre - FIRST) * (render.fraction if sampling else 0.0))
            return
        path, notes = render.result()
        self.source.render["notes"] = self.source.render.get("notes", []) + notes
        self._end_stage("render_world")
        self._start_work(Work("render", path, timed="read_render"))

    def _start_work(self, work: Work):
        """The rest off the main thread: the read `work` names, then the bake."""
        extra = dict(self._extra, waited={name: round(sec, 4) for name, sec in self.stages})
        if self._steps.start_job is not None:
            self._job = self._steps.start_job(work, self.source, self._settings, self._needs, extra)
        else:
            steps, source, settings, needs = self._steps, self.source, self._settings, self._needs

            def run(progress):
                report, stages = run_work(work, source, settings, needs, extra, progress, steps.read_file,
                                          steps.read_render, steps.bake)
                job.stages = stages
                return report
            job = self._job = BakeJob(run)  # bound before it starts: run() reads it
            job.start()
        self._step = self._wait_thread

    def _wait_thread(self):
        job = self._job
        stage, fraction = job.status()
        if stage == "reading":  # the file's rows read so far
            start = FIRST if self.source.path == IMAGE else self._pre
            self._show(READING_FILE if self.source.path == IMAGE else READING_RENDER,
                       start + (self._pre - start) * fraction)
        elif stage != "starting":
            self._show(STAGE_WORDS.get(stage, stage.capitalize()), self._pre + (1 - self._pre) * fraction)
        if not job.done():
            return
        if isinstance(job.error, FileNotAsBlenderShowsIt):  # read Blender's buffer instead
            self._to_buffer()
        else:
            self._conclude(job)

    def _wait_for_stop(self):
        if self._render is not None and not self._render.done():
            return
        job = self._job
        if job is None:
            self._end(cancelled=True)
        elif job.done():
            if job.result is not None:  # it had finished (and written) before the cancel: say so
                self._conclude(job)
            else:
                self._end(cancelled=True)

    # -- the outcome ---------------------------------------------------------
    def _conclude(self, job):
        if job.cancelled or job.error is not None:
            self._end(cancelled=job.cancelled, error=job.error)
            return
        self.stages.extend(getattr(job, "stages", None) or [])
        self._end_stage("bake")
        job.result.seconds = time.perf_counter() - self._clicked  # what the user waited, from the click
        self._end(report=job.result)

    def _end(self, report=None, error=None, cancelled=False):
        self.report, self.error, self.cancelled = report, error, cancelled
        self.finished = True

    def _show(self, stage, fraction):
        self.stage, self.fraction = stage, max(self.fraction, min(1.0, fraction))

    def _end_stage(self, name):
        now = time.perf_counter()
        self.stages.append((name, now - self._stage_start))
        self._stage_start = now
