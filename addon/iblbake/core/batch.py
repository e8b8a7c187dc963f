"""A batch of worlds for blender_scripts/bake_world.py --batch, no bpy: the
worlds, their folders and the shard come from the native batch machinery
(iblbake_core.batch_worlds, the CLI's own pipeline/batch), and so does
OUT/index.json + index.html (write_batch_index), so a library baked by the
CLI or by Blender has the same names, shards and gallery. What differs is
the bake of one world (Blender renders or reads it through its world), which
the caller hands in."""
import json
import os
import shutil
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from typing import Callable, List, Optional, Sequence, Tuple, Union

from . import native

BLEND_SUFFIX = ".blend"

# bake_one(world) -> (status, content_hash), status "baked" or "unchanged",
# or finish(progress) -> the same, the bake's bpy-free rest (see run);
# an exception is the world's failure.
Outcome = Tuple[str, str]
BakeOne = Callable[[dict], Union[Outcome, Callable[[Callable[[str, float], bool]], Outcome]]]


def worlds(inputs: Sequence[str], lists: Sequence[str] = (), shard: str = "") -> List[dict]:
    """[{source, name}] of the batch (.blend files and images; a folder: both
    kinds, sorted), in the CLI's order, names and shard."""
    core = native.load()
    return core.batch_worlds(list(inputs), list(lists), list(core.image_extensions()) + [BLEND_SUFFIX], shard)


def manifest_warnings(folder: str) -> List[str]:
    """The warnings of the bake in `folder` (its manifest's), as the CLI's batch lists them."""
    try:
        with open(os.path.join(folder, "manifest.json")) as f:
            warnings = json.load(f).get("warnings", [])
    except (OSError, ValueError, AttributeError):
        return []
    return [w for w in warnings if isinstance(w, str)] if isinstance(warnings, list) else []


def clock_text(seconds: float) -> str:
    """m:ss or h:mm:ss, as the CLI's bar shows times."""
    if not seconds >= 0 or seconds > 360000:
        return "--:--"
    s = int(seconds + 0.5)
    return "%d:%02d:%02d" % (s // 3600, s // 60 % 60, s % 60) if s >= 3600 else "%d:%02d" % (s // 60, s % 60)


class Display:
    """What a batch shows, as the CLI's batch does: on a terminal one bar on
    stderr, redrawn in place (worlds done, the current world's stage, rate,
    ETA, time so far), with failures and warnings kept on screen as lines;
    otherwise one plain line per world through `log`. Thread-safe: stages
    come from the threads that bake."""
    WIDTH = 24

    def __init__(self, total: int, tty: bool, log=print, stream=None, clock=time.monotonic):
        self.total, self.tty, self.log, self.clock = total, tty, log, clock
        self.stream = stream if stream is not None else sys.stderr
        self.start = clock()
        self.done = 0
        self.current = ""      # the world whose stage the bar shows
        self.stage_text, self.fraction = "", 0.0
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._ticker = None
        if tty:
            self._ticker = threading.Thread(target=self._tick, name="iblbake-batch-bar", daemon=True)
            self._ticker.start()

    def started(self, name: str):
        self.stage(name, "starting", 0.0)

    def stage(self, name: str, stage: str, fraction: float) -> bool:
        with self._lock:
            self.current, self.stage_text, self.fraction = name, stage, fraction
        return True

    def line(self, text: str):
        """A line that stays (a world's result, a warning)."""
        with self._lock:
            if self.tty:
                self.stream.write("\r\033[K%s\n" % text)
                self._draw_locked()
            else:
                self.log(text)

    def finished(self, entry: dict):
        with self._lock:
            self.done += 1
            done = self.done
        took = " in %.2f s" % entry["seconds"] if entry["status"] == "baked" else ""
        text = "[%d/%d] %s %s%s%s" % (done, self.total, entry["status"], entry["name"], took,
                                      ": " + entry["error"] if entry["error"] else "")
        if not self.tty or entry["status"] == "failed":
            self.line(text)
        for warning in entry["warnings"]:
            self.line("  warning: %s: %s" % (entry["name"], warning))
        if self.tty:
            with self._lock:
                self._draw_locked()

    def close(self):
        self._closed.set()
        if self._ticker is not None:
            self._ticker.join()
        if self.tty:
            with self._lock:
                self.stream.write("\r\033[K")
                self.stream.flush()

    def bar(self) -> str:
        """[#####...] 12/50 forest: specular 40% | 3.1 worlds/min | ETA 2:05 | 0:42"""
        elapsed = self.clock() - self.start
        filled = int(self.WIDTH * self.done / self.total) if self.total else self.WIDTH
        text = "[%s%s] %d/%d" % ("#" * filled, "." * (self.WIDTH - filled), self.done, self.total)
        if self.current and self.done < self.total:
            pct = " %d%%" % int(self.fraction * 100 + 0.5) if self.fraction > 0 and self.stage_text != "writing" else ""
            text += " %s: %s%s" % (self.current, self.stage_text, pct)
        eta = "ETA --:--"
        if self.done > 0 and elapsed > 0:
            text += " | %.1f worlds/min" % (60.0 * self.done / elapsed)
            eta = "ETA " + clock_text(elapsed / self.done * (self.total - self.done))
        return text + " | " + eta + " | " + clock_text(elapsed)

    def _draw_locked(self):
        if not self.tty or self._closed.is_set():
            return
        text = self.bar()
        cols = shutil.get_terminal_size((100, 24)).columns
        self.stream.write("\r%s\033[K" % text[:max(cols - 1, 10)])
        self.stream.flush()

    def _tick(self):
        while not self._closed.wait(0.25):
            with self._lock:
                self._draw_locked()


def run(items: List[dict], out: str, bake_one: BakeOne, shard: str = "", log=print, jobs: int = 1,
        tty: bool = False, stream=None) -> List[dict]:
    """Bakes each world, keeps going after a failure and writes the index
    (with each world's warnings, from its manifest). Returns the index's
    entries, in the worlds' order.

    bake_one(world) runs on this (Blender's main) thread. It returns
    (status, content_hash), or a function finish(progress, say) ->
    (status, content_hash) holding the rest of the bake, which needs no
    bpy: with jobs > 1 up to `jobs` of them run on worker threads while this
    thread prepares the next world (the native bake releases the GIL), so at
    most `jobs` worlds are held at once. progress(stage, fraction) feeds the
    bar; say(text) shows a line that stays (the bake's own warnings are
    listed from its manifest here, so finish should not print them). On a
    terminal (tty) a bar, otherwise a line a world ("[3/12] baked forest in
    1.20 s", then its warnings); stream: the bar's (stderr). Any exception
    escaping the loop (a KeyboardInterrupt) stops the bakes running through
    their progress, waits for them, writes the index of the worlds done and
    goes on up. (Headless Blender turns a first Ctrl-C into its own break
    event, which Python never sees: the batch goes on; a second Ctrl-C
    kills Blender, and the same command then resumes, skipping the worlds
    already baked.)"""
    core = native.load()
    jobs = max(1, min(int(jobs), len(items) or 1))
    display = Display(len(items), tty, log, stream)
    entries: List[Optional[dict]] = [None] * len(items)
    stopping = threading.Event()

    def close(k, entry, started, outcome):
        """outcome: (result, error, the time it ended)."""
        result, error, ended = outcome
        if error is None:
            entry["status"], entry["content_hash"] = result
            entry["warnings"] = manifest_warnings(os.path.join(out, entry["name"]))
        else:
            entry["error"] = str(error) or type(error).__name__
        entry["seconds"] = ended - started
        entry["preview"] = os.path.isfile(os.path.join(out, entry["name"], "preview.png"))
        entries[k] = entry
        display.finished(entry)

    def progress_of(name):
        return lambda stage, fraction: not stopping.is_set() and display.stage(name, stage, fraction)

    def timed(finish, name):
        """finish's outcome and the time it ended (on the worker: not when collected)."""
        try:
            return finish(progress_of(name), display.line), None, time.perf_counter()
        except Exception as e:  # the world's failure
            return None, e, time.perf_counter()

    pending = {}
    pool = ThreadPoolExecutor(max_workers=jobs, thread_name_prefix="iblbake-batch") if jobs > 1 else None

    def collect(block):
        finished = wait(list(pending), return_when=FIRST_COMPLETED)[0] if block else [
            f for f in pending if f.done()]
        for f in finished:
            k, entry, started = pending.pop(f)
            close(k, entry, started, f.result())

    try:
        for k, world in enumerate(items):
            while len(pending) >= jobs:
                collect(True)
            collect(False)
            display.started(world["name"])
            entry = dict(world, status="failed", content_hash="", error="", seconds=0.0, preview=False, warnings=[])
            started = time.perf_counter()
            try:
                got = bake_one(world)
            except Exception as e:  # keep going; every failure is in the index and the summary
                close(k, entry, started, (None, e, time.perf_counter()))
                continue
            if not callable(got):
                close(k, entry, started, (got, None, time.perf_counter()))
            elif pool is not None:
                pending[pool.submit(timed, got, world["name"])] = (k, entry, started)
            else:
                close(k, entry, started, timed(got, world["name"]))
            got = None  # the world's pixels go with the bake, not with this loop
        while pending:
            collect(True)
    except BaseException:
        stopping.set()  # the running bakes' progress says stop; they end as Cancelled
        while pending:
            collect(True)
        raise
    finally:
        if pool is not None:
            pool.shutdown(wait=True)
        display.close()
        done = [e for e in entries if e is not None]
        os.makedirs(out, exist_ok=True)
        core.write_batch_index(out, done, shard)
    return done
