"""The add-on in a real Blender window (run by test_gui.py under Xvfb):

  blender --factory-startup -p 0 0 W H --python gui_session.py -- ZIP WORK BIG_EXR

Installs the add-on from the built zip, shows World Properties, and clicks
Bake IBL the way the UI does (the operator's invoke, then its modal job) for
an 8K image world and a Sky Texture world. A timer that runs every 10 ms
watches the event loop: the longest gap between two of its runs is the
longest the UI stood still. It records the panel's progress property and
stage, presses Esc (xdotool, a real key event) or the Cancel button's
operator at each stage of further bakes, checks that the earlier bake is
untouched, takes screenshots (ImageMagick's import) and writes
WORK/result.json. Numbers are judged by test_gui.py."""
import hashlib
import json
import os
import subprocess
import sys
import threading
import time
import traceback

import addon_utils
import bpy

ZIP, WORK, BIG_EXR = sys.argv[sys.argv.index("--") + 1:][:3]
bpy.context.preferences.view.show_splash = False  # read before the first window opens
RESULT = {"errors": [], "bakes": {}, "cancels": {}, "screenshots": []}
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
    """A 10 ms app timer: the gaps between its runs are the UI's stalls. Each
    gap is also told without the time the main thread stood runnable waiting
    for a CPU (the kernel's schedstat): on a loaded machine that part is the
    load's, the rest is the main thread working or blocked (on the GIL, say)."""

    def __init__(self):
        self.last = None
        self.label = "idle"
        self.reset("idle")

    def __call__(self):
        now = time.perf_counter()
        cpu, wait = schedstat()
        cpu = time.thread_time()
        run = addon("state").RUN
        label = run.stage if run is not None else self.label
        if self.last is not None:
            gap = now - self.last
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
        self.last_cpu = time.thread_time()
        self.code = {}      # our main-thread callbacks: name -> longest call (s)
        self.last = time.perf_counter()
        self.last_wait = schedstat()[1]


PULSE = Pulse()


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


def screenshot(name, whole=False):
    """The Properties editor (or the whole screen) as the X server shows it (ImageMagick's import)."""
    path = os.path.join(WORK, name + ".png")
    win, area, _ = properties_area()
    top = win.height - (area.y + area.height)
    crop = [] if whole else ["-crop", "%dx%d+%d+%d" % (area.width, area.height, area.x, top)]
    subprocess.Popen(["import", "-window", "root", *crop, path], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    RESULT["screenshots"].append(path)


def press_escape():
    """A real Esc key press through the X server, with the pointer over the window."""
    win = bpy.context.window_manager.windows[0]
    subprocess.Popen(["sh", "-c", "xdotool mousemove %d %d key Escape" % (win.width // 2, win.height // 2)])


def properties_area():
    """The largest Properties editor (the 3D View turned into one, see scenario())."""
    win = bpy.context.window_manager.windows[0]
    areas = [a for a in win.screen.areas if a.type == "PROPERTIES"]
    if not areas:
        raise RuntimeError("no Properties editor")
    area = max(areas, key=lambda a: a.width * a.height)
    return win, area, next(r for r in area.regions if r.type == "WINDOW")


def click_bake():
    win, area, region = properties_area()
    with bpy.context.temp_override(window=win, area=area, region=region, screen=win.screen):
        return bpy.ops.iblbake.bake("INVOKE_DEFAULT")


def snapshot(folder):
    """Every file's name and sha256: an earlier bake is intact when this is unchanged."""
    out = {}
    for name in sorted(os.listdir(folder)):
        with open(os.path.join(folder, name), "rb") as f:
            out[name] = hashlib.sha256(f.read()).hexdigest()
    return out


def image_world(path):
    world = bpy.data.worlds.new("big image")
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


def wait_idle():
    state = addon("state")
    while state.RUN is not None:
        yield 0.05


def bake_and_watch(key):
    """Clicks Bake and follows it to the end (the generator's caller waits)."""
    state = addon("state")
    PULSE.reset(key)
    start = time.perf_counter()
    result = click_bake()
    shot, past = False, None
    while state.RUN is not None:
        # A quarter second past "Starting", once the panel has redrawn the
        # bar (a fast bake's integration stages can pass between two polls;
        # reading or rendering lasts longer).
        if past is None and state.RUN.stage != "Starting":
            past = time.perf_counter()
        if not shot and past is not None and time.perf_counter() - past > 0.25:
            screenshot(key + "_during")
            shot = True
        yield 0.02
    scene = bpy.context.scene
    RESULT["bakes"][key] = {
        "invoke": sorted(result), "seconds": time.perf_counter() - start, "status": scene.iblbake.last_status,
        "error": scene.iblbake.last_error, "gaps": dict(PULSE.gaps), "own": dict(PULSE.own), "cpu": dict(PULSE.cpu),
        "code": dict(PULSE.code), "ticks": dict(PULSE.ticks),
        "progress": [f for _, _, f in PULSE.trace], "stages": [s for _, s, _ in PULSE.trace],
        "out": scene.iblbake.last_output}
    PULSE.reset("idle")


def redraw_baseline(seconds=3.0):
    """No bake: the Properties editor redrawn every 50 ms as during a bake,
    to tell what drawing alone costs here (a software renderer on Xvfb)."""
    PULSE.reset("redraw only")
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        for area in bpy.context.window_manager.windows[0].screen.areas:
            area.tag_redraw()
        yield 0.05
    RESULT["baseline"] = {"gaps": dict(PULSE.gaps), "own": dict(PULSE.own), "cpu": dict(PULSE.cpu)}
    PULSE.reset("idle")


def cancel_at(key, stage_prefix, how, folder, face_size=None):
    """Bakes again (forced; with face_size, a slower bake whose specular stage
    outlasts a key press's way through the X server) and stops it with Esc
    or Cancel once the stage starts; the folder must be as it was."""
    state = addon("state")
    before = snapshot(folder)
    props = bpy.context.scene.iblbake
    opts = props if props.use_scene_options else bpy.context.preferences.addons[ADDON[0]].preferences
    old_face = opts.face_size
    if face_size:
        opts.face_size = face_size
    props.force = True
    PULSE.reset(key)
    click_bake()
    seen = False
    deadline = time.perf_counter() + 300
    while state.RUN is not None and time.perf_counter() < deadline:
        if state.RUN.stage.startswith(stage_prefix) and not seen:
            seen = True
            if how == "esc":
                press_escape()
            else:
                win, area, region = properties_area()
                with bpy.context.temp_override(window=win, area=area, region=region):
                    bpy.ops.iblbake.cancel()
        yield 0.01
    props.force = False
    opts.face_size = old_face
    RESULT["cancels"][key] = {"stage_seen": seen, "how": how, "status": bpy.context.scene.iblbake.last_status,
                              "intact": snapshot(folder) == before, "gaps": dict(PULSE.gaps),
                              "own": dict(PULSE.own), "cpu": dict(PULSE.cpu), "code": dict(PULSE.code),
                              "stages": sorted(set(s for _, s, _ in PULSE.trace))}
    PULSE.reset("idle")


def scenario():
    install()
    RESULT["module"] = addon("core.native").load().__file__
    prefs = bpy.context.preferences.addons[ADDON[0]].preferences
    prefs.default_output_dir = os.path.join(WORK, "out", "{world}")
    operators, panel = addon("operators"), addon("panel")
    for cls, names in ((operators.IBLBAKE_OT_bake, ("invoke", "modal")), (panel.IBLBAKE_PT_world, ("draw",))):
        for name in names:
            timed(cls, name)
    bpy.app.timers.register(PULSE, first_interval=0.01)
    # Only the World's Surface panel and ours, so the screenshots show ours whole.
    for cls in list(bpy.types.Panel.__subclasses__()):
        if (getattr(cls, "bl_context", "") == "world" and cls.__name__ != "IBLBAKE_PT_world"
                and not cls.__name__.endswith("_PT_surface") and not cls.__name__.endswith("_PT_context_world")):
            try:
                bpy.utils.unregister_class(cls)
            except RuntimeError:
                pass
    # The big 3D View becomes a Properties editor showing World Properties.
    win = bpy.context.window_manager.windows[0]
    view = max((a for a in win.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    view.type = "PROPERTIES"
    yield 0.5
    win, area, region = properties_area()
    area.spaces.active.context = "WORLD"
    scene = bpy.context.scene

    # An 8K image world.
    scene.world = image_world(BIG_EXR)
    yield 1.0
    screenshot("image_before")
    yield 1.0
    yield from redraw_baseline()
    yield from bake_and_watch("image")
    yield 1.0
    # Scroll the panel (the mouse wheel, through the X server) to show the files and the preview.
    top = win.height - (area.y + area.height)
    subprocess.Popen(["xdotool", "mousemove", str(area.x + area.width // 2), str(top + area.height // 2),
                      "click", "--repeat", "25", "5"])
    yield 2.0
    screenshot("image_after")
    yield 1.0
    folder = RESULT["bakes"]["image"]["out"]
    # Open Output Folder with no file manager: the panel says where the files are.
    path_env = os.environ.get("PATH", "")
    os.environ["PATH"] = ""
    try:
        with bpy.context.temp_override(window=win, area=area, region=region):
            bpy.ops.iblbake.open_output()
    finally:
        os.environ["PATH"] = path_env
    RESULT["open_folder"] = {"status": scene.iblbake.last_status, "clipboard": bpy.context.window_manager.clipboard}
    yield 0.5
    # Open Preview: no Image Editor on this screen, so a new window shows it.
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.ops.iblbake.open_preview()
    yield 2.0
    editors = [(a.spaces.active.image.name if a.spaces.active.image else None)
               for w in bpy.context.window_manager.windows for a in w.screen.areas if a.type == "IMAGE_EDITOR"]
    RESULT["open_preview"] = {"windows": len(bpy.context.window_manager.windows), "image_editors": editors}
    screenshot("preview_window", whole=True)
    yield 1.5
    for extra in list(bpy.context.window_manager.windows)[1:]:  # back to one window: Esc goes to the first
        with bpy.context.temp_override(window=extra):
            bpy.ops.wm.window_close()
    yield 0.5
    yield from cancel_at("image_read_esc", "Reading the world image", "esc", folder)
    yield from cancel_at("image_check_button", "Checking for changes", "button", folder)
    yield from cancel_at("image_specular_esc", "Specular levels", "esc", folder, face_size=1024)
    yield from cancel_at("image_specular_button", "Specular levels", "button", folder)

    # "Bake For: This Scene's Materials": the panel says what the default cube leaves out.
    scene.iblbake.auto_skip = True
    yield 1.0
    RESULT["scene_only_lines"] = addon("panel")._plan_lines(bpy.context, scene)[0]
    subprocess.Popen(["xdotool", "mousemove", str(area.x + area.width // 2), str(top + area.height // 2),
                      "click", "--repeat", "25", "4"])  # back to the top
    yield 2.0
    screenshot("bake_for_scene")
    yield 1.0
    scene.iblbake.auto_skip = False

    # A Sky Texture world: Cycles renders it in a child Blender.
    scene.world = sky_world()
    scene.iblbake.use_scene_options = True
    scene.iblbake.render_width = SKY_WIDTH
    yield 1.0
    yield from bake_and_watch("sky")
    yield 1.0
    screenshot("sky_after")
    folder = RESULT["bakes"]["sky"]["out"]
    yield from cancel_at("sky_render_esc", "Rendering the world", "esc", folder)
    yield from cancel_at("sky_render_button", "Rendering the world", "button", folder)
    yield from cancel_at("sky_bake_button", "Specular levels", "button", folder, face_size=1024)

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
    screenshot("no_world")
    yield 1.0


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


bpy.app.timers.register(driver, first_interval=1.0)
