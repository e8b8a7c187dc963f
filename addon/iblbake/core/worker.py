"""The slow part of the UI's bake - reading the world's pixels, hashing them,
the native bake - as a Work, run by run_work() on a thread (BakeJob) or in a
child process (BakeProcess).

The child is this Blender's own Python interpreter, started at the lowest
CPU priority (nice 19): its threads yield to Blender's UI threads (the main
thread, the drawing) whenever those want a core, so Blender stays smooth
while the bake uses every core. Other programs are not affected by that: the
kernel shares the CPU between sessions (autogroups, or cgroups) first, so the
bake keeps its session's share. A priority cannot be raised again once
lowered, and the bake's threads (TBB's) are shared with Blender's own in
Blender's process: hence a process of its own. It also keeps an 8K image's
hundreds of megabytes out of Blender's memory.

The child reports on its standard output, one line each: "P stage fraction"
(progress), "S name seconds" (a stage's time), "R" (ready). A line "cancel"
on its standard input, or that input's end (Blender gone), cancels it; after
the input's end the child removes the job's folder itself. bpy-free."""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass
from typing import Callable, List, Optional, Tuple

import numpy as np

from . import describe, native

NICE = 19
CANCELLED_EXIT = 3   # the child stopped on a cancel before the native bake started


@dataclass
class Work:
    """Where the bake's pixels come from: "file" (the Environment Texture's
    file, read as Blender shows it), "render" (the EXR a Cycles render
    wrote, at `path`), "array" (pixels already read, `array`) or "none" (a
    plain colour). `timed` names the read in the manifest's blender.waited."""
    kind: str
    path: str = ""
    alpha_matters: bool = True
    array: Optional[np.ndarray] = None
    timed: str = ""


def read_file_natively(source, alpha_matters: bool, progress: Optional[Callable[[float], None]] = None):
    """The Environment Texture's file read by the native reader, as Blender shows it."""
    from .world import read_file_pixels
    core = native.load()

    def read(path, info=False):
        return core.read_image(path, info=info, progress=progress)
    return read_file_pixels(source, read, core.remap_latlong, alpha_matters)


def read_image(path: str, progress: Optional[Callable[[float], None]] = None):
    return native.load().read_image(path, progress=progress)


def with_thumbnail(report):
    """The report with the panel's thumbnail of preview.png (made here, off Blender's main thread)."""
    preview = os.path.join(report.out_dir, "preview.png")
    if os.path.isfile(preview):
        try:
            report.thumbnail = describe.thumbnail(read_image(preview))
        except (OSError, RuntimeError, ValueError):
            pass
    return report


def run_work(work: Work, source, settings, needs, extra: dict, progress, read_file=read_file_natively,
             read_render=read_image, bake=None) -> Tuple[object, List[Tuple[str, float]]]:
    """Reads the pixels `work` names, then bakes: (BakeReport with its
    thumbnail, [(the read's name, seconds)]). `progress(stage, fraction)`
    returning False cancels; the read reports stage "reading"."""
    if bake is None:
        from .pipeline import bake
    stages = []
    pixels = None
    if work.kind != "none":
        start = time.perf_counter()
        if work.kind != "array":
            progress("reading", 0.0)

        def read_progress(f):
            progress("reading", f)
        if work.kind == "file":
            pixels = read_file(source, work.alpha_matters, read_progress)
        elif work.kind == "render":
            pixels = read_render(work.path, read_progress)
        else:
            pixels = work.array
        if work.timed:
            stages.append((work.timed, time.perf_counter() - start))
    waited = dict((extra or {}).get("waited") or {})
    waited.update({name: round(sec, 4) for name, sec in stages})
    extra = dict(extra or {}, waited=waited)
    return with_thumbnail(bake(source, pixels, settings, needs, progress, extra)), stages


# -- across the process boundary: plain JSON ------------------------------------
def _to_json(obj):
    return None if obj is None else asdict(obj)


def _source_from(d):
    from .world import Mapping, WorldSource
    d = dict(d)
    if d.get("mapping") is not None:
        d["mapping"] = Mapping(**{k: tuple(v) if isinstance(v, list) else v for k, v in d["mapping"].items()})
    d["color"] = tuple(d["color"])
    return WorldSource(**d)


def _needs_from(d):
    from .needs import Needs
    if d is None:
        return None
    d = dict(d)
    for k in ("roughness", "levels"):
        if d.get(k) is not None:
            d[k] = tuple(d[k])
    return Needs(**d)


def _settings_from(d):
    from .settings import BakeSettings
    return BakeSettings(**d)


def _error_from(kind: str, message: str) -> BaseException:
    from .pipeline import BakeError
    from .world import FileNotAsBlenderShowsIt
    cls = {"BakeError": BakeError, "FileNotAsBlenderShowsIt": FileNotAsBlenderShowsIt}.get(kind)
    return cls(message) if cls else RuntimeError("%s: %s" % (kind, message))


def python_executable() -> str:
    """This Python as a program: Blender embeds it, so sys.executable may be
    anything found on PATH; the interpreter of its own prefix is the one
    whose modules (numpy) match. "" when there is none."""
    version = "python%d.%d" % sys.version_info[:2]
    for path in (os.path.join(sys.base_prefix, "bin", version), os.path.join(sys.base_prefix, "bin", "python3"),
                 sys.executable):
        if path and os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    return ""


def _package():
    """(the add-on package's folder, its parent): the child imports core/ from there."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return here, os.path.dirname(here)


BOOT = ("import sys; sys.path.insert(0, sys.argv[1]); import importlib; "
        "importlib.import_module(sys.argv[2] + '.core.worker').child_main(sys.argv[3])")


class BakeProcess:
    """A Work and its bake in a child process, with BakeJob's interface:
    start(), status(), cancel(), done(), wait(), and once done exactly one of
    result, error and cancelled; `stages` the child's timed reads. When the
    child cannot start (no interpreter, a module missing), the work runs on
    a thread instead (BakeJob), and `fallback` says why."""

    def __init__(self, work: Work, source, settings, needs, extra: dict, python: Optional[str] = None):
        self.work, self.source, self.settings, self.needs, self.extra = work, source, settings, needs, extra
        self.python = python_executable() if python is None else python
        self.stage, self.fraction = "starting", 0.0
        self.result = self.error = None
        self.cancelled = False
        self.stages: List[Tuple[str, float]] = []
        # Each stage's furthest fraction the child reported. status() is the
        # latest only, and a poller can miss a step between two polls.
        self.reached: dict = {}
        self.fallback = ""
        self._lock = threading.Lock()
        self._cancel = threading.Event()
        self._ready = False
        self._finished = threading.Event()
        self._thread_job = None
        self.proc = None
        self.tmp = tempfile.mkdtemp(prefix="iblbake-bake-")

    # -- the parent side ---------------------------------------------------------
    def start(self):
        self._reader = threading.Thread(target=self._run, name="iblbake bake process", daemon=True)
        self._reader.start()
        return self

    def _run(self):
        try:
            if not self.python:
                raise OSError("no Python interpreter found beside this one (%s)" % sys.base_prefix)
            job = {"work": dict(asdict(self.work), array=None), "source": _to_json(self.source),
                   "settings": _to_json(self.settings), "needs": _to_json(self.needs), "extra": self.extra}
            if self.work.kind == "array":  # written here, off the main thread
                job["work"]["path"] = os.path.join(self.tmp, "pixels.npy")
                np.save(job["work"]["path"], np.ascontiguousarray(self.work.array, np.float32))
            with open(os.path.join(self.tmp, "job.json"), "w") as f:
                json.dump(job, f)
            folder, parent = _package()
            env = dict(os.environ)
            env["PYTHONPATH"] = os.pathsep.join([p for p in sys.path if p and os.path.isdir(p)])
            env["PYTHONNOUSERSITE"] = "1"
            self.proc = subprocess.Popen(
                [self.python, "-s", "-c", BOOT, parent, os.path.basename(folder), self.tmp],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=None, env=env, text=True, errors="replace",
                close_fds=True)
            if self._cancel.is_set():
                self._send_cancel()
            for line in self.proc.stdout:
                self._line(line.rstrip("\n").split("\t"))
            self.proc.wait()
            self._collect()
        except Exception as e:  # the child could not run: bake on a thread here
            if not self._ready and not self._cancel.is_set():
                self._remove_files()  # the thread needs none of it
                self._fall_back(e)
                return
            self.error = e
        self._remove_files()
        self._finished.set()

    def _remove_files(self):
        """The job's folder (the job, the pixels, the result) once no child
        uses it: nothing there is needed after _collect(), and a caller that
        never calls cleanup() would otherwise leave an image's worth of
        pixels in the temporary folder. A child still running keeps it until
        cleanup() has ended the child (or, its Blender gone, removes it
        itself: child_main)."""
        if self.proc is None or self.proc.poll() is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)

    def _line(self, parts):
        if parts[0] == "R":
            self._ready = True
        elif parts[0] == "P" and len(parts) == 3:
            with self._lock:
                self.stage, self.fraction = parts[1], float(parts[2])
                self.reached[self.stage] = max(self.fraction, self.reached.get(self.stage, 0.0))
        elif parts[0] == "S" and len(parts) == 3:
            self.stages.append((parts[1], float(parts[2])))

    def _collect(self):
        code = self.proc.returncode
        path = os.path.join(self.tmp, "result.json")
        if code == CANCELLED_EXIT or (self._cancel.is_set() and not os.path.isfile(path)):
            self.cancelled = True
            return
        try:
            with open(path) as f:
                res = json.load(f)
        except (OSError, ValueError):
            if not self._ready:
                raise RuntimeError("the bake's process exited with code %s before it started" % code)
            raise RuntimeError("the bake's process ended without a result (exit code %s)" % code)
        if res.get("cancelled"):
            self.cancelled = True
        elif res.get("error"):
            self.error = _error_from(res["error"]["type"], res["error"]["message"])
        else:
            from .pipeline import BakeReport
            report = BakeReport(**res["report"])
            thumb = os.path.join(self.tmp, "thumbnail.npy")
            if os.path.isfile(thumb):
                report.thumbnail = np.load(thumb)
            self.result = report

    def _fall_back(self, why):
        from .job import BakeJob
        self.fallback = "the bake ran inside Blender: its own process could not start (%s)" % why
        print("iblbake: %s" % self.fallback, file=sys.stderr, flush=True)
        work, source, settings, needs, extra = self.work, self.source, self.settings, self.needs, self.extra

        def run(progress):
            report, stages = run_work(work, source, settings, needs, extra, progress)
            self.stages.extend(stages)
            return report
        job = self._thread_job = BakeJob(run).start()
        job.wait()
        self.result, self.error, self.cancelled = job.result, job.error, job.cancelled
        self._finished.set()

    def status(self):
        if self._thread_job is not None:
            return self._thread_job.status()
        with self._lock:
            return self.stage, self.fraction

    def cancel(self):
        self._cancel.set()
        if self._thread_job is not None:
            self._thread_job.cancel()
        self._send_cancel()

    def _send_cancel(self):
        proc = self.proc
        if proc is not None and proc.poll() is None:
            try:
                proc.stdin.write("cancel\n")
                proc.stdin.close()
            except (OSError, ValueError):
                pass

    def done(self) -> bool:
        return self._finished.is_set()

    def wait(self, timeout: Optional[float] = None) -> bool:
        return self._finished.wait(timeout)

    def cleanup(self):
        """Ends the child (killed when a cancel did not end it within a second) and removes its files."""
        proc = self.proc
        if proc is not None and proc.poll() is None:
            self._send_cancel()
            try:
                proc.wait(1)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)


# -- the child side ------------------------------------------------------------------
def lower_priority(all_threads=False):
    """This thread (and the threads it starts) at nice 19 and, where the
    kernel has it, in SCHED_IDLE: nice alone still lets a bake thread finish
    its time slice when one of Blender's wakes, and Blender's drawing (on a
    software OpenGL, threads that wake and wait on each other many times a
    frame) took half as long again while an 8K image baked; SCHED_IDLE
    yields the core at once. Either is only a priority: an idle machine's
    cores are all the bake's. Linux keeps both per thread: all_threads
    lowers every thread the process has already (numpy's BLAS starts its
    own when imported; a child Blender has many), not only this one."""
    tids = [0]
    if all_threads:
        try:
            tids = [int(t) for t in os.listdir("/proc/self/task")]
        except OSError:
            pass
    for tid in tids:
        try:
            os.setpriority(os.PRIO_PROCESS, tid, max(NICE, os.getpriority(os.PRIO_PROCESS, tid)))
        except OSError:
            pass
        if hasattr(os, "sched_setscheduler") and hasattr(os, "SCHED_IDLE"):
            try:
                os.sched_setscheduler(tid, os.SCHED_IDLE, os.sched_param(0))
            except OSError:
                pass


def child_main(tmp: str):
    """The child process: nice, then the Work of tmp/job.json; its outcome in tmp/result.json."""
    lower_priority(all_threads=True)  # TBB's and OpenEXR's threads, made later, inherit it
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C in Blender's terminal is Blender's
    with open(os.path.join(tmp, "job.json")) as f:
        job = json.load(f)
    work = Work(**job["work"])
    if work.kind == "array":
        work.array = np.load(work.path, mmap_mode="r")
    source, settings = _source_from(job["source"]), _settings_from(job["settings"])
    needs = _needs_from(job["needs"])
    cancel = threading.Event()
    baking = threading.Event()  # set once the bake (which writes) has begun
    out_lock = threading.Lock()

    def emit(*parts):
        with out_lock:
            sys.stdout.write("\t".join(str(p) for p in parts) + "\n")
            sys.stdout.flush()

    orphaned = threading.Event()  # Blender is gone: no one will read the result, nor remove tmp

    def watch():
        for line in sys.stdin:
            if line.strip() == "cancel":
                break
        else:
            orphaned.set()
        cancel.set()  # a cancel, or Blender is gone
        if not baking.is_set():  # still reading: nothing written yet, stop at once
            if orphaned.is_set():
                shutil.rmtree(tmp, ignore_errors=True)
            os._exit(CANCELLED_EXIT)
    threading.Thread(target=watch, daemon=True).start()
    native.load()
    emit("R")
    last = [None, -1.0, 0.0]

    def progress(stage, fraction):
        now = time.perf_counter()
        # A new stage, a visible step, a quarter second, or a stage's end
        # (never dropped: the UI's bar and the tests count on seeing 1.0).
        if stage != last[0] or fraction - last[1] >= 0.002 or now - last[2] >= 0.25 or \
                (fraction >= 1.0 and last[1] < 1.0):
            last[:] = [stage, fraction, now]
            emit("P", stage, "%.4f" % fraction)
        return not cancel.is_set()

    from .pipeline import bake as pipeline_bake

    def bake(*args):
        baking.set()
        return pipeline_bake(*args)
    result = {}
    try:
        report, stages = run_work(work, source, settings, needs, job["extra"], progress, bake=bake)
        for name, sec in stages:
            emit("S", name, "%.4f" % sec)
        if report.thumbnail is not None:
            np.save(os.path.join(tmp, "thumbnail.npy"), report.thumbnail)
        result["report"] = {k: getattr(report, k) for k in ("status", "out_dir", "content_hash", "manifest",
                                                            "seconds")}
    except native.load().Cancelled:
        result["cancelled"] = True
    except Exception as e:
        name = type(e).__name__
        result["error"] = {"type": name, "message": str(e)}
    with open(os.path.join(tmp, "result.json.tmp"), "w") as f:
        json.dump(result, f)
    os.replace(os.path.join(tmp, "result.json.tmp"), os.path.join(tmp, "result.json"))
    if orphaned.is_set():
        shutil.rmtree(tmp, ignore_errors=True)
