"""The add-on in a real Blender window (run by test_gui.py under Xvfb):

  blender --factory-startup -p 0 0 W H --python gui_session.py -- ZIP WORK BIG_EXR

Installs the add-on from the built zip and shows World Properties in the
factory layout's own Properties editor, at Blender's default width (the
screenshots are of that editor, scrolled to what each one shows). Clicks
Bake IBL the way the UI does (the operator's invoke, then its modal job)
for an 8K image world and a Sky Texture world. A timer that runs every 10 ms
watches the event loop: the gaps between its runs are how long the UI stood
still, recorded one by one, during the bakes and during idle windows of
the same run (the Properties editor redrawn every 50 ms, as it is at most
while baking). It records the panel's progress and stage, answers Blender's
dialog before a bake that would remove files (Esc keeps them, Return bakes),
presses Esc (xdotool, a real key event) or the Cancel button's operator at
each stage of further bakes and checks that the earlier bake is untouched,
reopens the saved file, opens the preferences, takes screenshots (ImageMagick's
import) and writes WORK/result.json. Numbers are judged by test_gui.py."""
import glob
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import traceback

import addon_utils
import bpy

ZIP, WORK, BIG_EXR = sys.argv[sys.argv.index("--") + 1:][:3]
FOREST = "/usr/share/blender/datafiles/studiolights/world/forest.exr"
CITY = "/usr/share/blender/datafiles/studiolights/world/city.exr"
SUNSET = "/usr/share/blender/datafiles/studiolights/world/sunset.exr"
bpy.context.preferences.view.show_splash = False  # read before the first window opens
RESULT = {"errors": [], "bakes": {}, "cancels": {}, "screenshots": [], "idle": [], "checks": {}}
SKY_WIDTH = int(os.environ.get("IBLBAKE_GUI_SKY_WIDTH", "1024"))


# --- the event loop's pulse ------------------------------------------------
def schedstat():
    """(seconds on a CPU, seconds runnable but waiting for one) of this thread."""
    try:
        with open("/proc/self/task/%d/schedstat" % threading.get_native_id()) as f:
            run, wait, _ = f.read().split()
        return int(run) * 1e-9, int(wait) * 1e-9
    except (OSError, ValueError):
        return 0.0, 0.0


class Pulse:
    """A 10 ms app timer: the gaps between its runs are the UI's stalls, kept
    one by one (for the longest and the 99th percentile). Each gap is also
    told without the time the main thread stood runnable waiting for a CPU
    (the kernel's schedstat): on a loaded machine that part is the load's,
    the rest is the main thread working or blocked."""

    def __init__(self):
        self.last = None
        self.label = "idle"
        self.reset("idle")

    def __call__(self):
        now = time.perf_counter()
        _, wait = schedstat()
        cpu = time.thread_time()
        run = addon("state").RUN
        label = run.stage if run is not None else self.label
        if self.last is not None:
            gap = now - self.last
            self.all.append(gap)
            self.ends.append(now)
            own = gap - (wait - self.last_wait)
            if gap > self.gaps.get(label, 0.0):
                self.gaps[label] = gap
            if own > self.own.get(label, 0.0):
                self.own[label] = own
            busy = cpu - self.last_cpu
            if busy > self.cpu.get(label, 0.0):
                self.cpu[label] = busy
        self.ticks[label] = self.ticks.get(label, 0) + 1
        if run is not None:
            wm = bpy.context.window_manager
            self.trace.append((now, run.stage, float(wm.iblbake_progress)))
        self.last, self.last_wait, self.last_cpu = now, wait, cpu
        return 0.01

    def reset(self, label):
        self.gaps, self.own, self.cpu, self.ticks, self.trace, self.label = {}, {}, {}, {}, [], label
        self.all = []       # every gap (s), in order
        self.ends = []      # when each gap ended (perf_counter)
        self.last_cpu = time.thread_time()
        self.code = {}      # our main-thread callbacks: name -> longest call (s)
        self.last = time.perf_counter()
        self.last_wait = schedstat()[1]


PULSE = Pulse()


def proc_stat(path):
    """(name, fields after the name) of a /proc/PID[/task/TID]/stat file:
    fields[k] is proc(5)'s field k + 3 (the name may hold spaces and parentheses)."""
    with open(path) as f:
        stat = f.read()
    return stat[stat.index("(") + 1:stat.rindex(")")], stat[stat.rindex(")") + 2:].split()


def cpu_ticks():
    """{(pid, tid): (process name, thread name, clock ticks on a CPU)} of every
    thread on the host, from /proc: who used the CPU between two calls."""
    out = {}
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/comm" % pid) as f:
                proc = f.read().strip()
            tids = os.listdir("/proc/%s/task" % pid)
        except OSError:
            continue
        for tid in tids:
            try:
                name, fields = proc_stat("/proc/%s/task/%s/stat" % (pid, tid))
            except OSError:
                continue
            out[(int(pid), int(tid))] = (proc, name, int(fields[11]) + int(fields[12]))  # utime + stime
    return out


UPDATES = []  # (time, names of the IDs a depsgraph update touched): what makes Blender redraw or re-render


@bpy.app.handlers.persistent
def note_updates(_scene, depsgraph):
    UPDATES.append((time.perf_counter(), sorted({u.id.name for u in depsgraph.updates})))


DRAWS = []  # (time, editor): every region redraw of the editors below


def count_draws():
    """Notes each redraw of these editors' main regions (what the window spends its GL time on)."""
    for space in (bpy.types.SpaceView3D, bpy.types.SpaceProperties, bpy.types.SpaceImageEditor,
                  bpy.types.SpaceOutliner, bpy.types.SpaceTimeline if hasattr(bpy.types, "SpaceTimeline") else
                  bpy.types.SpaceDopeSheetEditor):
        space.draw_handler_add(lambda name=space.__name__: DRAWS.append((time.perf_counter(), name)), (),
                               "WINDOW", "POST_PIXEL")


def draws_since(start):
    seen = {}
    for t, name in DRAWS:
        if t >= start:
            seen[name] = seen.get(name, 0) + 1
    return seen


def big_gaps(start, top=8):
    """The longest gaps since `start`, each with the redraws and status changes that fell in it."""
    pairs = sorted(zip(PULSE.all, PULSE.ends), reverse=True)[:top]
    return [[round(g, 3), round(e - start, 2), [n for t, n in DRAWS if e - g <= t <= e]] for g, e in pairs]


def updates_since(start):
    """The depsgraph updates since `start`: how many, and the IDs they touched most often."""
    seen = {}
    count = 0
    for t, names in UPDATES:
        if t >= start:
            count += 1
            for n in names:
                seen[n] = seen.get(n, 0) + 1
    return {"count": count, "ids": sorted(seen.items(), key=lambda kv: -kv[1])[:5]}


def busiest(before, seconds, top=6):
    """The threads that used the most CPU since `before` (cpu_ticks()), as
    "process/thread pid: share of a core", busiest first; threads of one
    process with one name (llvmpipe-0..N, TBB's workers) are added up."""
    hz = os.sysconf("SC_CLK_TCK")
    use = {}
    for key, (proc, name, ticks) in cpu_ticks().items():
        used = ticks - before.get(key, (proc, name, 0))[2]
        if used > 0:
            label = "%s/%s %d" % (proc, name.rstrip("0123456789-:") or name, key[0])
            use[label] = use.get(label, 0) + used
    ranked = sorted(use.items(), key=lambda kv: -kv[1])[:top]
    return ["%s: %.2f" % (label, ticks / hz / max(seconds, 1e-3)) for label, ticks in ranked]


def timed(cls, name):
    """Wraps cls.name so each call's duration is recorded (our code on the main thread)."""
    inner = getattr(cls, name)
    key = cls.__name__ + "." + name

    def note(t):
        PULSE.code[key] = max(PULSE.code.get(key, 0.0), time.perf_counter() - t)

    # Blender checks a callback's argument count: keep the signatures.
    if name == "draw":
        def wrapper(self, context):
            t = time.perf_counter()
            try:
                return inner(self, context)
            finally:
                note(t)
    else:
        def wrapper(self, context, event):
            t = time.perf_counter()
            try:
                return inner(self, context, event)
            finally:
                note(t)
    setattr(cls, name, wrapper)


ADDON = [None]  # the add-on's module name: "iblbake", or "bl_ext.user_default.iblbake" as an extension


def install():
    """The zip as a user installs it: an extension on Blender 4.2+, else Preferences > Add-ons > Install."""
    if "extension" in os.path.basename(ZIP):
        bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)
        ADDON[0] = "bl_ext.user_default.iblbake"
    else:
        bpy.ops.preferences.addon_install(filepath=ZIP)
        addon_utils.enable("iblbake", default_set=True)
        ADDON[0] = "iblbake"
    if ADDON[0] not in bpy.context.preferences.addons:
        raise RuntimeError("the add-on %s did not install from %s" % (ADDON[0], ZIP))


def addon(submodule):
    return sys.modules[ADDON[0] + "." + submodule]


def prefs():
    return bpy.context.preferences.addons[ADDON[0]].preferences


def shot(name, whole=False, scroll=None):
    """A screenshot (generator: the caller yields from it), scrolled first
    ("top", or steps of 40 pixels down) and redrawn."""
    if scroll is not None:
        scroll_to(scroll)
        yield 0.8
    screenshot(name, whole)
    yield 0.8


def screenshot(name, whole=False):
    """The Properties editor (or the whole screen) as the X server shows it (ImageMagick's import)."""
    path = os.path.join(WORK, name + ".png")
    win, area, _ = properties_area()
    top = win.height - (area.y + area.height)
    crop = [] if whole else ["-crop", "%dx%d+%d+%d" % (area.width, area.height, area.x, top)]
    subprocess.Popen(["import", "-window", "root", *crop, path], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    RESULT["screenshots"].append(path)


def scroll_to(where):
    """Scrolls the Properties editor: "top", or down by `where` steps of 40 pixels."""
    win, area, region = properties_area()
    with bpy.context.temp_override(window=win, area=area, region=region):
        if where == "top":
            for _ in range(60):
                bpy.ops.view2d.scroll_up(deltax=0, deltay=40)
        else:
            for _ in range(where):
                bpy.ops.view2d.scroll_down(deltax=0, deltay=40)


def press(key, move=True):
    """A real key press through the X server, with the pointer over the window
    (move=False: where it is, over a dialog, which moving away would close)."""
    win = bpy.context.window_manager.windows[0]
    where = "xdotool mousemove %d %d " % (win.width // 2, win.height // 2) if move else "xdotool "
    subprocess.Popen(["sh", "-c", where + "key " + key])


def properties_area():
    """The factory layout's Properties editor (Blender's default width)."""
    win = bpy.context.window_manager.windows[0]
    areas = [a for a in win.screen.areas if a.type == "PROPERTIES"]
    if not areas:
        raise RuntimeError("no Properties editor")
    area = max(areas, key=lambda a: a.width * a.height)
    return win, area, next(r for r in area.regions if r.type == "WINDOW")


def in_panel(fn):
    """fn() in the Properties editor's context, as a click there runs it."""
    win, area, region = properties_area()
    with bpy.context.temp_override(window=win, area=area, region=region, screen=win.screen):
        return fn()


def click_bake():
    return in_panel(lambda: bpy.ops.iblbake.bake("INVOKE_DEFAULT"))


def snapshot(folder):
    """Every file's name and sha256, preset folders included: an earlier bake is intact when this is unchanged."""
    out = {}
    for root, _dirs, files in os.walk(folder):
        for name in sorted(files):
            path = os.path.join(root, name)
            with open(path, "rb") as f:
                out[os.path.relpath(path, folder)] = hashlib.sha256(f.read()).hexdigest()
    return out


def du(folder):
    return sum(os.path.getsize(os.path.join(r, f)) for r, _d, fs in os.walk(folder) for f in fs)


def image_world(path, name="big image"):
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(path, check_existing=False)
    nt.links.new(env.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    return world


def sky_world():
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    nt = world.node_tree
    sky = nt.nodes.new("ShaderNodeTexSky")
    types = [item.identifier for item in sky.bl_rna.properties["sky_type"].enum_items]
    sky.sky_type = "NISHITA" if "NISHITA" in types else types[-1]  # Blender 5: the scattering skies
    nt.links.new(sky.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    return world


def status_lines():
    """What the panel says below the button: this session's result, its note, the folder's Last bake line."""
    scene = bpy.context.scene
    panel, folder = addon("panel"), addon("core.folder")
    plan = panel._plan(bpy.context, scene)
    old = panel._folder_state(plan.folder)[0] if plan.folder else None
    last = addon("state").last(scene.name)
    return {"status": last.status, "note": last.note,
            "last_bake": folder.last_bake_line(old, folder.freshness(old, plan.world_fingerprint,
                                                                     plan.settings_hash)) if old else ""}


def children_priorities():
    """{process name: sorted "policy/nice" of its threads} for this Blender's
    child processes (the bake's Python, the Cycles render's Blender):
    policy 5 is SCHED_IDLE (proc(5), /proc/PID/stat fields 19 and 41)."""
    out = {}
    me = os.getpid()
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            name, fields = proc_stat("/proc/%s/stat" % pid)
            if int(fields[1]) != me or name in ("import", "xdotool"):
                continue  # the screenshots' and the key presses' are the test's
            seen = set()
            for tid in os.listdir("/proc/%s/task" % pid):
                fields = proc_stat("/proc/%s/task/%s/stat" % (pid, tid))[1]
                seen.add("%s/%s" % (fields[38], fields[16]))
            out[name + " " + pid] = sorted(seen)
        except (OSError, ValueError, IndexError):
            continue
    return out


def bake_and_watch(key, shot=True, confirm=None):
    """Clicks Bake and follows it to the end (the generator's caller waits).
    confirm: the key that answers Blender's dialog, if the bake asks first."""
    state = addon("state")
    settled = yield from settle()
    PULSE.reset(key)
    start, before = time.perf_counter(), cpu_ticks()
    result = click_bake()
    asked = "RUNNING_MODAL" in result and state.RUN is None
    if confirm:
        yield 1.0
        screenshot(key + "_dialog", whole=True)
        yield 0.7
        press(confirm, move=False)
        yield 1.0
    shot_taken, past = not shot, None
    priorities, entered = {}, {}
    deadline = time.perf_counter() + 900
    while state.RUN is not None and time.perf_counter() < deadline:
        # The children's CPU priority, a tenth of a second into the file's reading or the Cycles render.
        stage = state.RUN.stage
        if stage in ("Reading the image", "Rendering with Cycles") and stage not in priorities:
            entered.setdefault(stage, time.perf_counter())
            if time.perf_counter() - entered[stage] > 0.1:
                priorities[stage] = children_priorities()
        # A quarter second past "Starting", once the panel has redrawn the
        # bar (a fast bake's integration stages can pass between two polls;
        # reading or rendering lasts longer).
        if past is None and state.RUN.stage != "Starting":
            past = time.perf_counter()
        if not shot_taken and past is not None and time.perf_counter() - past > 0.25:
            screenshot(key + "_during")
            shot_taken = True
        yield 0.02
    scene = bpy.context.scene
    RESULT["bakes"][key] = {
        "invoke": sorted(result), "asked": asked, "seconds": time.perf_counter() - start,
        "status": scene.iblbake.last_status, "error": scene.iblbake.last_error, "gaps": dict(PULSE.gaps),
        "own": dict(PULSE.own), "cpu": dict(PULSE.cpu), "code": dict(PULSE.code), "ticks": dict(PULSE.ticks),
        "all_gaps": list(PULSE.all), "trace": [(t - start, s, f) for t, s, f in PULSE.trace],
        "progress": [f for _, _, f in PULSE.trace], "stages": [s for _, s, _ in PULSE.trace],
        "out": scene.iblbake.last_output, "busiest": busiest(before, time.perf_counter() - start),
        "draws": draws_since(start), "updates": updates_since(start),
        "big_gaps": big_gaps(start), "settled": settled, "priorities": priorities}
    PULSE.reset("idle")


def settle(quiet=1.0, longest=10.0):
    """Waits until no editor but the Properties has redrawn for `quiet`
    seconds (at most `longest`); returns how long it waited. A change of any
    scene property (the panel's settings, as cancel_at() restores them)
    makes the 3D Viewport draw its anti-aliasing samples again: eight
    redraws of about 0.3 s each on Xvfb's software OpenGL, Blender's own
    work, which neither a bake nor its idle baseline must be charged with."""
    start = time.perf_counter()
    yield 0.2  # the notifiers of a change made just before are handled in the next turns of the event loop
    while time.perf_counter() - start < longest:
        now = time.perf_counter()
        if not any(now - t < quiet for t, name in DRAWS if name != "SpaceProperties"):
            break
        yield 0.1
    return time.perf_counter() - start


def idle_window(name, seconds=4.0):
    """No bake: the UI doing what it does while a bake runs - World
    Properties and the status bar redrawn as often as the bar is at most
    (operators.REDRAW_INTERVAL) - so that what a bake adds is what its work
    takes from the UI; the gaps kept for the baseline. (Each redraw draws
    the whole window: a software renderer on Xvfb feels it.)"""
    settled = yield from settle()
    PULSE.reset("idle")
    interval = addon("operators").REDRAW_INTERVAL
    before, start = cpu_ticks(), time.perf_counter()
    end = start + seconds
    while time.perf_counter() < end:
        addon("state").redraw(bpy.context, only_world=True)
        yield interval
    with open("/proc/loadavg") as f:
        load = f.read().split()[0]
    RESULT["idle"].append({"gaps": list(PULSE.all), "own": max(PULSE.own.values() or [0.0]),
                           "cpu": max(PULSE.cpu.values() or [0.0]), "load": load, "name": name, "settled": settled,
                           "busiest": busiest(before, time.perf_counter() - start),
                           "updates": updates_since(start), "draws": draws_since(start)})
    PULSE.reset("idle")


def blender_temp_folders():
    """The blender_XXXXXX folders in the system's temporary folder (a
    Blender's own, which it removes when it quits; this Blender's is there
    throughout)."""
    return set(glob.glob(os.path.join(tempfile.gettempdir(), "blender_*")))


def cancel_at(key, stage_prefix, how, folder, face_size=None):
    """Bakes again (forced; with face_size, a slower bake whose specular stage
    outlasts a key press's way through the X server) and stops it with Esc
    or Cancel once the stage starts; the folder must be as it was."""
    state = addon("state")
    before = snapshot(folder)
    blender_tmp = blender_temp_folders()
    props = bpy.context.scene.iblbake
    old_face = props.face_size
    if face_size:
        props.face_size = face_size
    props.force = True
    PULSE.reset(key)
    click_bake()
    seen = False
    deadline = time.perf_counter() + 300
    while state.RUN is not None and time.perf_counter() < deadline:
        if state.RUN.stage.startswith(stage_prefix) and not seen:
            seen = True
            if how == "esc":
                press("Escape")
            else:
                in_panel(lambda: bpy.ops.iblbake.cancel())
        yield 0.01
    props.force = False
    props.face_size = old_face
    RESULT["cancels"][key] = {"stage_seen": seen, "how": how, "status": bpy.context.scene.iblbake.last_status,
                              "intact": snapshot(folder) == before, "gaps": dict(PULSE.gaps),
                              # a child Blender's temporary folder left behind (a cancelled render's)
                              "leaked": sorted(blender_temp_folders() - blender_tmp),
                              "own": dict(PULSE.own), "cpu": dict(PULSE.cpu), "code": dict(PULSE.code),
                              "stages": sorted(set(s for _, s, _ in PULSE.trace))}
    PULSE.reset("idle")


def keep_only_our_world_panels():
    """Only the World's context panel and ours, so the screenshots show ours."""
    for cls in list(bpy.types.Panel.__subclasses__()):
        if (getattr(cls, "bl_context", "") == "world" and not cls.__name__.startswith("IBLBAKE_PT_world")
                and not cls.__name__.endswith("_PT_context_world")):
            try:
                bpy.utils.unregister_class(cls)
            except RuntimeError:
                pass


def show_world_properties():
    _win, area, _region = properties_area()
    area.spaces.active.context = "WORLD"


def scenario():
    install()
    RESULT["module"] = addon("core.native").load().__file__
    p = prefs()
    p.default_output_dir = os.path.join(WORK, "out", "{world}")
    operators, panel = addon("operators"), addon("panel")
    for cls, names in ((operators.IBLBAKE_OT_bake, ("invoke", "modal")), (panel.IBLBAKE_PT_world, ("draw",))):
        for name in names:
            timed(cls, name)
    bpy.app.timers.register(PULSE, first_interval=0.01, persistent=True)
    bpy.app.handlers.depsgraph_update_post.append(note_updates)
    count_draws()
    keep_only_our_world_panels()
    yield 0.5
    win, area, _region = properties_area()
    RESULT["properties_width"] = [area.width, area.height]
    show_world_properties()
    scene = bpy.context.scene
    scene.world = image_world(FOREST, "forest")
    yield 1.0
    # The scene's settings started from the preferences' defaults (this file had none) once it
    # changed or the panel showed it.
    RESULT["checks"]["initialised"] = [scene.iblbake.options_initialised, scene.iblbake.output_dir]

    # 9. An unsaved file with a // folder: Bake IBL greyed out, the reason below the field.
    scene.iblbake.output_dir = "//ibl/{world}"
    yield 1.0
    RESULT["checks"]["unsaved"] = {"poll": in_panel(lambda: bpy.ops.iblbake.bake.poll()),
                                   "why": panel._plan(bpy.context, scene).folder_error}
    yield from shot("unsaved_relative_folder", scroll="top")
    scene.iblbake.output_dir = p.default_output_dir

    # The idle baseline's first window, then the 8K image world (the stall figures).
    scene.world = image_world(BIG_EXR)
    yield 1.0
    yield from shot("image_before", scroll="top")
    yield from idle_window("before_image")
    yield from bake_and_watch("image")
    yield 1.0
    yield from shot("image_after", scroll="top")
    yield from shot("image_files", scroll=30)
    yield from idle_window("after_image")
    folder = RESULT["bakes"]["image"]["out"]

    # Open Output Folder without a file manager: the panel says where the files are, below the bake's result.
    path_env = os.environ.get("PATH", "")
    os.environ["PATH"] = ""
    try:
        in_panel(lambda: bpy.ops.iblbake.open_output())
    finally:
        os.environ["PATH"] = path_env
    RESULT["open_folder"] = dict(status_lines(), clipboard=bpy.context.window_manager.clipboard)
    yield 0.5
    yield from shot("no_file_manager", scroll="top")

    # Cancels at every stage of the 8K world (Esc or Cancel): the earlier bake stays.
    yield from cancel_at("image_read_esc", "Reading the image", "esc", folder)
    yield from cancel_at("image_check_button", "Checking for changes", "button", folder)
    yield from cancel_at("image_specular_esc", "Specular levels", "esc", folder, face_size=1024)
    yield from cancel_at("image_specular_button", "Specular levels", "button", folder)

    # A Sky Texture world: Cycles renders it in a child Blender (the stall figures).
    scene.world = sky_world()
    scene.iblbake.render_width = SKY_WIDTH
    # Blender renders the new world's previews (the World tab's icon) on
    # the UI's GL context: on Xvfb's software OpenGL that alone stalls the
    # UI for about 2 s (eight gaps of 0.16 to 0.31 s measured with no bake:
    # bench/ui_gaps_sky_world.py), which the bake must not be charged with:
    # let it finish, then an idle window in this state.
    yield 4.0
    yield from idle_window("before_sky")
    yield from bake_and_watch("sky")
    yield 1.0
    yield from shot("sky_after", scroll="top")
    yield from idle_window("after_sky")
    folder = RESULT["bakes"]["sky"]["out"]
    yield from cancel_at("sky_render_esc", "Rendering with Cycles", "esc", folder)
    yield from cancel_at("sky_render_button", "Rendering with Cycles", "button", folder)
    yield from cancel_at("sky_bake_button", "Specular levels", "button", folder, face_size=1024)
    yield from idle_window("after_sky_cancels")

    # 1-3. Every roughness with three.js and Khronos, then This Scene's Materials into the same
    # folder: Blender's dialog says what would go; Esc keeps it all, Return bakes.
    scene.world = image_world(FOREST, "forest")
    scene.iblbake.face_size = 256
    scene.iblbake.presets = {"three", "khronos"}  # the World panel's toggles: the scene's, not the preferences'
    RESULT["checks"]["prefs_presets"] = sorted(p.presets)
    yield 1.0
    yield from bake_and_watch("export", shot=False)
    folder = RESULT["bakes"]["export"]["out"]
    RESULT["checks"]["export"] = {"status": status_lines(), "du": du(folder),
                                  "files": panel._folder_state(folder)[1:],
                                  "grouped": panel.describe.grouped_files(panel._folder_state(folder)[1])}
    yield from shot("export_files", scroll=30)
    export_files = snapshot(folder)
    scene.iblbake.presets = set()
    scene.iblbake.auto_skip = True  # "Bake For: This Scene's Materials": the default cube reads level 4 of 9
    yield 1.0
    RESULT["scene_only_lines"] = panel._plan(bpy.context, scene).lines
    yield from shot("bake_for_scene", scroll=6)
    yield from bake_and_watch("scene_only_kept", shot=False, confirm="Escape")
    RESULT["checks"]["kept"] = {"intact": snapshot(folder) == export_files}
    yield from bake_and_watch("scene_only", shot=False, confirm="Return")
    RESULT["checks"]["scene_only"] = {"files": sorted(snapshot(folder)), "status": status_lines()}
    # The world's image changed (forest -> city) in the same world: the dialog names the other source.
    scene.world.node_tree.nodes["Environment Texture"].image = bpy.data.images.load(CITY, check_existing=False)
    yield 1.0
    RESULT["checks"]["world_changed"] = status_lines()
    yield from shot("world_changed", scroll="top")
    yield from bake_and_watch("other_source", shot=False, confirm="Return")

    # Issue 27's sun in this layout: Sun: Split (its row in the Bake For box) on sunset.exr, the
    # sentence and Add Sun Lamp below the Last bake line; Sun: Off again asks before the sun's files go.
    forest = scene.world
    scene.world = image_world(SUNSET, "sunset")
    scene.iblbake.sun = "split"
    yield 1.0
    yield from shot("sun_toggle", scroll=6)
    yield from bake_and_watch("sun_split", shot=False)
    yield 1.0
    sun_folder = RESULT["bakes"]["sun_split"]["out"]
    old = panel._folder_state(sun_folder)[0]
    RESULT["checks"]["sun"] = dict(status_lines(), sentence=panel.describe.sun_sentence(old.manifest.get("sun")),
                                   files=sorted(snapshot(sun_folder)),
                                   poll=in_panel(lambda: bpy.ops.iblbake.add_sun_lamp.poll()))
    yield from shot("sun_split", scroll="top")
    in_panel(lambda: bpy.ops.iblbake.add_sun_lamp())
    RESULT["checks"]["sun"]["lamp"] = [o.data.type for o in scene.objects if o.name == "IBL Sun"]
    scene.iblbake.sun = "off"
    yield 1.0
    yield from bake_and_watch("sun_off", shot=False, confirm="Return")
    RESULT["checks"]["sun_off"] = {"files": sorted(snapshot(sun_folder)), "status": status_lines()}
    scene.world = forest
    yield 1.0

    # 4. Open Preview: no Image Editor open, the panel shows the sheet large; with one (the
    # Timeline made an Image Editor), every click reuses it; saving keeps the sheet out of the file.
    windows = len(bpy.context.window_manager.windows)
    in_panel(lambda: bpy.ops.iblbake.open_preview())
    yield 1.0
    yield from shot("preview_in_panel", scroll=40)
    timeline = next(a for a in win.screen.areas if a.type in ("DOPESHEET_EDITOR", "TIMELINE"))
    timeline.type = "IMAGE_EDITOR"
    yield 0.5
    for _ in range(3):
        in_panel(lambda: bpy.ops.iblbake.open_preview())
        yield 0.5
    editors = [(a.spaces.active.image.name if a.spaces.active.image else None)
               for w in bpy.context.window_manager.windows for a in w.screen.areas if a.type == "IMAGE_EDITOR"]
    screenshot("preview_editor", whole=True)
    yield 1.0
    blend = os.path.join(WORK, "scene.blend")
    in_panel(lambda: bpy.ops.wm.save_as_mainfile(filepath=blend))
    yield 1.0
    RESULT["open_preview"] = {"windows_before": windows, "windows": len(bpy.context.window_manager.windows),
                              "image_editors": editors,
                              "editor_after_save": [(a.spaces.active.image.name if a.spaces.active.image else None)
                                                    for a in win.screen.areas if a.type == "IMAGE_EDITOR"]}

    # 9. Reopened: the panel reads the folder's manifest.
    in_panel(lambda: bpy.ops.wm.open_mainfile(filepath=blend))
    yield 2.0
    keep_only_our_world_panels()
    show_world_properties()
    scene = bpy.context.scene
    yield 1.0
    RESULT["checks"]["reopened"] = dict(status_lines(), images=[i.name for i in bpy.data.images],
                                        settings=[scene.iblbake.face_size, sorted(scene.iblbake.presets)])
    yield from shot("reopened", scroll="top")
    yield from shot("options", scroll=18)

    # 8. The preferences: the defaults for new files, headings that do not repeat a button.
    bpy.context.preferences.active_section = "ADDONS"
    bpy.context.window_manager.addon_search = "iblbake"
    in_panel(lambda: bpy.ops.screen.userpref_show())
    yield 1.0
    for mod in addon_utils.modules():  # the add-on's entry expanded, as its arrow does
        if mod.__name__ == ADDON[0]:
            addon_utils.module_bl_info(mod)["show_expanded"] = True
    for extra in bpy.context.window_manager.windows:
        for a in extra.screen.areas:
            a.tag_redraw()
    yield 1.5
    screenshot("preferences", whole=True)
    yield 1.0
    for extra in list(bpy.context.window_manager.windows)[1:]:  # back to one window: Esc goes to the first
        with bpy.context.temp_override(window=extra):
            bpy.ops.wm.window_close()
    yield 0.5

    # No world: refused with a message, nothing written.
    scene.world = None
    yield 0.5
    try:
        click_bake()
    except RuntimeError:  # an operator that reports an error raises when called from a script
        pass
    yield 0.5
    RESULT["no_world"] = {"status": scene.iblbake.last_status,
                          "written": os.path.isdir(os.path.join(WORK, "out", "no_world"))}
    yield from shot("no_world", scroll="top")


def driver(gen=scenario()):
    try:
        delay = next(gen)
        return max(0.0, float(delay))
    except StopIteration:
        pass
    except Exception:
        RESULT["errors"].append(traceback.format_exc())
    with open(os.path.join(WORK, "result.json"), "w") as f:
        json.dump(RESULT, f, indent=1)
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(driver, first_interval=1.0, persistent=True)
