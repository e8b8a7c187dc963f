"""The UI's bake as a state machine (addon/iblbake/core/job.py's BakeRun),
driven without Blender: fake stages stand in for Blender's buffer, the
Cycles child render, the file reads and the bake, so every path, every
failure and a cancel at every stage run in milliseconds."""
import os
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
import iblbake_core as ib  # noqa: E402
from iblbake.core.job import (READING_BUFFER, READING_FILE, RENDERING, STARTING_RENDER, BakeJob, BakeRun,  # noqa: E402
                              Steps)
from iblbake.core.pipeline import BakeReport  # noqa: E402
from iblbake.core.settings import BakeSettings  # noqa: E402
from iblbake.core.world import COLOR, IMAGE, RENDER, FileNotAsBlenderShowsIt, NeedsRender, WorldSource  # noqa: E402

PIXELS = np.ones((2, 4, 3), np.float32)


class Boom(Exception):
    """A stage's failure."""


class Render:
    """A fake child render: running until finish() or cancel()."""

    def __init__(self, fails):
        self.fraction, self.ended, self.cancelled, self.cleaned, self.fails = 0.0, False, False, False, fails
        self.sampling = False

    def done(self):
        return self.ended

    def finish(self):
        self.fraction, self.ended = 1.0, True

    def result(self):
        if self.fails:
            raise Boom("render_result")
        return "world.exr", ["a note from the child"]

    def cancel(self):
        self.cancelled = self.ended = True

    def cleanup(self):
        self.cleaned = True


class Fake:
    """Every stage, recording its calls: `fail` names the stage that raises,
    `hold` the worker-thread stage that waits until released."""

    def __init__(self, out_dir, fail=None, hold=None, plan=True, not_as_shown=False, needs_render=False,
                 render_runs=False):
        self.out_dir, self.fail, self.hold, self.plan = out_dir, fail, hold, plan
        self.not_as_shown, self.needs_render, self.render_runs = not_as_shown, needs_render, render_runs
        self.calls, self.render, self.baked = [], None, None
        self.held, self.release = threading.Event(), threading.Event()

    def steps(self):
        return Steps(self.file_plan, self.read_buffer, self.start_render, self.read_file, self.read_render, self.bake)

    def _enter(self, name):
        self.calls.append(name)
        if name == self.fail:
            raise Boom(name)
        if name == self.hold:
            self.held.set()
            assert self.release.wait(10)

    def file_plan(self, source):
        self._enter("file_plan")
        return (source.image_path, True) if self.plan else None

    def read_file(self, source, alpha_matters, progress=None):
        self._enter("read_file")
        for f in (0.5, 1.0):
            progress(f)
        if self.not_as_shown:
            raise FileNotAsBlenderShowsIt("the file has an alpha channel")
        return PIXELS

    def read_buffer(self, source):
        self._enter("read_buffer")
        if self.needs_render:
            raise NeedsRender("the image has alpha below 1")
        return PIXELS

    def start_render(self, source):
        self._enter("start_render")
        source.render = {"width": 64, "notes": ["render width raised"]}
        self.render = Render(self.fail == "render_result")
        if not self.render_runs:
            self.render.finish()
        return self.render

    def read_render(self, path, progress=None):
        self._enter("read_render")
        assert path == "world.exr"
        return PIXELS

    def bake(self, source, pixels, settings, needs, progress, extra):
        self._enter("bake")
        for stage in ("hashing", "specular", "writing"):
            if progress(stage, 0.5) is False:
                raise ib.Cancelled()
        self.baked = (source, pixels, extra)
        return BakeReport("baked", self.out_dir, "0123abcd")


def source(kind):
    if kind == "colour":
        return WorldSource(COLOR, world="w", color=(1.0, 0.5, 0.25))
    if kind == "render":
        return WorldSource(RENDER, "a Sky Texture", world="w")
    return WorldSource(IMAGE, world="w", image_name="sky", image_path="/images/sky.exr")


def start(tmp_path, kind, **kw):
    fake = Fake(str(tmp_path), plan=kind != "buffer", **kw)
    run = BakeRun(source(kind), BakeSettings(out_dir=str(tmp_path)), None, {"scene": "Scene"}, fake.steps())
    return run, fake


def drive(run, until=None, timeout=10.0):
    """Polls as the operator's timer does, until `until(run)` (or the end);
    returns the (stage, fraction) pairs the panel would have shown."""
    shown = [(run.stage, run.fraction)]
    deadline = time.monotonic() + timeout
    while not (until(run) if until else run.finished):
        assert time.monotonic() < deadline, shown
        run.poll()
        shown.append((run.stage, run.fraction))
        time.sleep(0.001)
    return shown


PATHS = {  # source -> (the fake's options, the stages called, the stages timed)
    "colour": ({}, ["bake"], ["bake"]),
    "image": ({}, ["file_plan", "read_file", "bake"], ["read_image_file", "bake"]),
    "buffer": ({}, ["file_plan", "read_buffer", "bake"], ["read_image_buffer", "bake"]),
    "render": ({}, ["start_render", "read_render", "bake"], ["render_world", "read_render", "bake"]),
    "file_not_as_shown": (dict(not_as_shown=True), ["file_plan", "read_file", "read_buffer", "bake"],
                          ["read_image_buffer", "bake"]),
    "needs_render": (dict(needs_render=True), ["file_plan", "read_buffer", "start_render", "read_render", "bake"],
                     ["render_world", "read_render", "bake"]),
}
KINDS = {"file_not_as_shown": "image", "needs_render": "buffer"}


@pytest.mark.parametrize("path", sorted(PATHS))
def test_every_path_bakes_and_says_how_long_each_stage_took(tmp_path, path):
    options, calls, timed = PATHS[path]
    run, fake = start(tmp_path, KINDS.get(path, path), **options)
    shown = drive(run)
    assert fake.calls == calls
    assert (run.cancelled, run.error) == (False, None) and run.report.status == "baked"
    assert [name for name, _ in run.stages] == timed and all(sec >= 0 for _, sec in run.stages)
    assert run.report.seconds >= sum(sec for _, sec in run.stages[:-1])
    baked_source, pixels, extra = fake.baked
    assert (pixels is None) == (path == "colour")
    # The manifest's blender.waited: what ran before the native bake.
    assert extra == {"scene": "Scene", "waited": {name: pytest.approx(sec, abs=1e-4) for name, sec in run.stages[:-1]}}
    fractions = [f for _, f in shown]
    assert fractions == sorted(fractions) and fractions[-1] <= 1.0
    if "render_world" in timed:
        assert baked_source.path == RENDER and STARTING_RENDER in {stage for stage, _ in shown}
        assert baked_source.render["notes"] == ["render width raised", "a note from the child"]
    if path == "needs_render":
        assert baked_source.why == "the image has alpha below 1"
    run.cleanup()
    assert fake.render is None or fake.render.cleaned


# (source, failing stage, whether it runs on the main thread: then poll() raises it)
FAILURES = [("image", "file_plan", True), ("image", "read_file", False), ("buffer", "read_buffer", True),
            ("render", "start_render", True), ("render", "render_result", True), ("render", "read_render", False),
            ("image", "bake", False), ("colour", "bake", False)]


@pytest.mark.parametrize("kind,stage,main_thread", FAILURES)
def test_a_failure_at_any_stage_ends_the_run_with_that_error(tmp_path, kind, stage, main_thread):
    run, fake = start(tmp_path, kind, fail=stage)
    if main_thread:
        with pytest.raises(Boom, match=stage):
            drive(run)
        assert not run.finished
    else:
        drive(run)
        assert isinstance(run.error, Boom) and str(run.error) == stage
        assert (run.report, run.cancelled) == (None, False)
    assert fake.baked is None
    run.cancel()  # what the operator does after any failure: nothing is left running
    run.cleanup()
    assert fake.render is None or fake.render.cleaned


def at_buffer(run, fake):
    return run.stage == READING_BUFFER


def rendering(run, fake):
    return fake.render is not None


def held(run, fake):
    return fake.held.is_set()


def before_start(run, fake):
    return True


# stage -> (source, the fake's options, when to cancel, the stages that ran)
CANCELS = {
    "start": ("image", {}, before_start, []),
    "read_image_buffer": ("buffer", {}, at_buffer, ["file_plan"]),
    "read_image_file": ("image", dict(hold="read_file"), held, ["file_plan", "read_file", "bake"]),
    "render_world": ("render", dict(render_runs=True), rendering, ["start_render"]),
    "read_render": ("render", dict(hold="read_render"), held, ["start_render", "read_render", "bake"]),
    "bake": ("image", dict(hold="bake"), held, ["file_plan", "read_file", "bake"]),
}


@pytest.mark.parametrize("stage", sorted(CANCELS))
def test_a_cancel_at_any_stage_stops_it_without_a_bake(tmp_path, stage):
    kind, options, when, ran = CANCELS[stage]
    run, fake = start(tmp_path, kind, **options)
    drive(run, until=lambda r: when(r, fake))
    fraction = run.fraction
    run.cancel()
    assert (run.stage, run.fraction) == ("Cancelling", fraction)
    fake.release.set()  # a file read in progress ends on its own; the bake stops at its next progress report
    drive(run)
    assert run.cancelled and (run.report, run.error, fake.baked) == (None, None, None)
    assert fake.calls == ran
    if stage == "render_world":
        assert fake.render.cancelled
    run.cleanup()
    assert fake.render is None or fake.render.cleaned


def test_the_bar_follows_the_files_rows_and_the_renders_samples(tmp_path):
    """Reading: the share of the file's rows read (iblbake_core.read_image's
    progress); rendering: Cycles' tiles and samples, once it samples."""
    run, fake = start(tmp_path, "image", hold="bake")
    drive(run, until=lambda r: fake.held.is_set())
    run.poll()  # the fake read reported 0.5, then 1.0 of its rows; the bake has not reported yet
    assert (run.stage, run.fraction) == (READING_FILE, pytest.approx(0.15))
    fake.release.set()
    drive(run)

    run, fake = start(tmp_path, "render", render_runs=True)
    drive(run, until=lambda r: fake.render is not None)
    render = fake.render
    run.poll()
    assert run.stage == STARTING_RENDER  # Blender starting, Cycles syncing: no sample yet
    render.sampling, render.fraction = True, 0.5
    run.poll()
    assert run.stage == RENDERING and run.fraction == pytest.approx(0.02 + (0.6 - 0.02) * 0.5)
    render.finish()
    drive(run)
    assert run.report.status == "baked"


def test_a_bake_done_before_the_cancel_is_reported_as_done(tmp_path):
    run, fake = start(tmp_path, "colour")
    run.poll()  # starts the worker
    deadline = time.monotonic() + 10
    while fake.baked is None:  # the bake returned (and wrote) before the key press
        assert time.monotonic() < deadline
        time.sleep(0.001)
    run.cancel()
    drive(run)
    assert not run.cancelled and run.report.status == "baked" and run.stages[-1][0] == "bake"


def test_a_failure_after_the_cancel_counts_as_the_cancel(tmp_path):
    run, fake = start(tmp_path, "image", hold="read_file")
    drive(run, until=lambda r: fake.held.is_set())
    fake.fail = "bake"
    run.cancel()
    fake.release.set()
    drive(run)
    assert run.cancelled and run.error is None and fake.calls[-1] == "bake"


# --- the real thing: core/worker.py's BakeProcess (the add-on's job) ---------------
from iblbake.core import worker  # noqa: E402
from iblbake.core.worker import BakeProcess, Work  # noqa: E402


def small_settings(tmp_path, **kw):
    kw = dict(dict(face_size=16, irradiance_size=4, lut_size=16), **kw)
    return BakeSettings(out_dir=str(tmp_path / "out"), lut_cache_dir=str(tmp_path / "cache"), **kw)


def exr_source(tmp_path, h=64, w=128):
    rgb = (0.5 + np.random.default_rng(5).random((h, w, 3))).astype(np.float32)
    path = str(tmp_path / "sky.exr")
    ib.write_exr(path, rgb)
    return WorldSource(IMAGE, world="w", image_name="sky.exr", image_path=path, colorspace="Linear"), rgb


def follow(job, timeout=120):
    """The (stage, fraction) pairs job.status() went through, until it is done."""
    seen = []
    deadline = time.monotonic() + timeout
    while not job.done():
        assert time.monotonic() < deadline, seen
        s = job.status()
        if not seen or seen[-1] != s:
            seen.append(s)
        time.sleep(0.002)
    return seen


def test_the_bake_process_reads_bakes_and_reports_like_the_thread(tmp_path):
    """A child Python at nice 19 reads the file (the rows' progress), bakes
    and hands back the report, its thumbnail and the read's time; the same
    work on a thread (BakeJob) writes the same files."""
    source, rgb = exr_source(tmp_path)
    job = BakeProcess(Work("file", source.image_path, False, timed="read_image_file"), source,
                      small_settings(tmp_path), None, {"scene": "Scene", "waited": {}}).start()
    seen = follow(job)
    assert job.fallback == "" and job.error is None and not job.cancelled, (job.fallback, job.error)
    report = job.result
    assert report.status == "baked" and report.thumbnail is not None and report.thumbnail.shape[2] == 4
    assert [name for name, _ in job.stages] == ["read_image_file"]
    assert "read_image_file" in report.manifest["blender"]["waited"]
    # Every event the child sent, not a 2 ms poller's sample of them.
    assert job.reached.get("reading") == 1.0 and "specular" in job.reached, (job.reached, seen)
    files = sorted(os.listdir(tmp_path / "out"))
    # The same work on a thread: the same content hash.
    thread = BakeJob(lambda p: worker.run_work(Work("array", array=rgb), source, small_settings(tmp_path, force=True),
                                               None, {}, p)[0]).start()
    assert thread.wait(120) and thread.result.content_hash == report.content_hash
    assert sorted(os.listdir(tmp_path / "out")) == files
    job.cleanup()
    assert not os.path.exists(job.tmp)


def test_the_bake_process_runs_at_the_lowest_priority(tmp_path):
    source, _ = exr_source(tmp_path)
    job = BakeProcess(Work("file", source.image_path, False), source, small_settings(tmp_path, face_size=128), None,
                      {}).start()
    deadline = time.monotonic() + 60
    while job.proc is None or job.status()[0] == "starting":
        assert time.monotonic() < deadline and not job.done()
        time.sleep(0.001)
    # Every thread (numpy's BLAS starts some at import, before the child lowers itself): proc(5) fields 19 and 41.
    seen = set()
    for tid in os.listdir("/proc/%d/task" % job.proc.pid):
        try:
            fields = open("/proc/%d/task/%s/stat" % (job.proc.pid, tid)).read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        seen.add((int(fields[16]), int(fields[38])))
    job.wait(120)
    assert job.result is not None
    assert seen == {(19, os.SCHED_IDLE)}, seen  # Blender's drawing threads preempt them at once
    assert not os.path.exists(job.tmp)  # removed once the child ended, with no cleanup() called


@pytest.mark.parametrize("when", ["reading", "specular"])
def test_a_cancelled_bake_process_leaves_the_folder_as_it_was(tmp_path, when):
    source, rgb = exr_source(tmp_path, 512, 1024)
    first = BakeProcess(Work("array", array=rgb * 2), source, small_settings(tmp_path), None, {}).start()
    assert first.wait(120) and first.result.status == "baked"
    before = {n: open(tmp_path / "out" / n, "rb").read() for n in os.listdir(tmp_path / "out")}
    job = BakeProcess(Work("file", source.image_path, False), source, small_settings(tmp_path, face_size=256), None,
                      {}).start()
    deadline = time.monotonic() + 120
    while job.status()[0] != when:
        assert time.monotonic() < deadline and not job.done(), job.status()
        time.sleep(0.0005)
    job.cancel()
    assert job.wait(60) and job.cancelled and (job.result, job.error) == (None, None)
    assert {n: open(tmp_path / "out" / n, "rb").read() for n in os.listdir(tmp_path / "out")} == before
    assert sorted(os.listdir(tmp_path)) == ["cache", "out", "sky.exr"]  # no staging folder left
    assert not os.path.exists(first.tmp) and not os.path.exists(job.tmp)  # nor the jobs' own folders
    job.cleanup()


PARENT = """
import os, sys, time
sys.path.insert(0, sys.argv[1])
from test_addon_run import BakeProcess, Work, exr_source, small_settings
import pathlib
tmp_path = pathlib.Path(sys.argv[2])
source, rgb = exr_source(tmp_path, 512, 1024)
job = BakeProcess(Work("file", source.image_path, False), source, small_settings(tmp_path, face_size=256), None,
                  {}).start()
deadline = time.monotonic() + 120
while job.status()[0] != sys.argv[3]:
    assert time.monotonic() < deadline and not job.done(), job.status()
    time.sleep(0.0005)
print(job.tmp, job.proc.pid, flush=True)
os._exit(0)  # as a Blender that closes or crashes mid-bake: no cancel(), no cleanup()
"""


@pytest.mark.parametrize("when", ["reading", "specular"])
def test_a_bake_process_whose_blender_is_gone_removes_its_folder(tmp_path, when):
    here = os.path.dirname(os.path.abspath(__file__))
    out = subprocess.run([sys.executable, "-c", PARENT, here, str(tmp_path), when], capture_output=True, text=True,
                         timeout=180, check=True).stdout.split()
    folder, pid = out[0], int(out[1])
    assert folder.startswith(tempfile.gettempdir()) and "iblbake-bake-" in folder
    deadline = time.monotonic() + 60
    while os.path.exists(folder) or os.path.exists("/proc/%d" % pid) and not zombie(pid):
        assert time.monotonic() < deadline, os.listdir(folder) if os.path.exists(folder) else "running"
        time.sleep(0.01)


def zombie(pid):
    try:
        return open("/proc/%d/stat" % pid).read().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def test_without_an_interpreter_the_bake_runs_on_a_thread(tmp_path):
    source, rgb = exr_source(tmp_path)
    job = BakeProcess(Work("array", array=rgb), source, small_settings(tmp_path), None, {},
                      python=str(tmp_path / "no-python")).start()
    assert job.wait(120) and job.result.status == "baked"
    assert "its own process could not start" in job.fallback
    assert not os.path.exists(job.tmp)


def test_errors_cross_the_process_boundary_as_their_own_types(tmp_path):
    from iblbake.core.pipeline import BakeError
    source, rgb = exr_source(tmp_path)
    job = BakeProcess(Work("array", array=rgb), source, small_settings(tmp_path, formats=[]), None, {}).start()
    assert job.wait(120) and isinstance(job.error, BakeError) and "formats" in str(job.error)
    alpha = WorldSource(IMAGE, world="w", image_path=source.image_path, colorspace="Filmic Log")
    job = BakeProcess(Work("file", source.image_path, False), alpha, small_settings(tmp_path), None, {}).start()
    assert job.wait(120) and isinstance(job.error, FileNotAsBlenderShowsIt)
    assert not os.path.exists(job.tmp)
