"""The UI's gaps around a Sky world, in Blender's window (issue 26, point 5).

    Xvfb :77 -screen 0 1280x1024x24 -nolisten tcp &
    DISPLAY=:77 EXP_MODE=world EXP_OUT=world.json blender --factory-startup -p 0 0 1280 1024 \
        --python bench/ui_gaps_sky_world.py

A 10 ms timer records every gap between its runs (time, gap, phase). After
3 s, EXP_MODE=world assigns a new Nishita Sky world (the Properties editor
on its World tab) and does nothing else for 6 s; EXP_MODE=popen writes the
world to a .blend and renders it in a child `blender -b` at nice 19 with the
add-on's render_child.py, as world_reader.ChildRender does. Measured
2026-11-26 (Blender 3.4.1, Xvfb, quiet host): `world`, eight gaps of 0.16 to
0.31 s in the 1.9 s after the switch, with no bake; `popen`, the child's
start and its Cycles render, no gap over 14 ms. So the GUI test waits for
the new world's previews before it bakes the Sky world."""
import bpy, json, os, sys, time, threading, subprocess, tempfile, shutil
OUT = os.environ["EXP_OUT"]
MODE = os.environ.get("EXP_MODE", "popen")
events, gaps = [], []
t0 = time.perf_counter()
last = [t0]
state = {"phase": "idle"}

def mark(what):
    events.append((round(time.perf_counter() - t0, 4), what, state["phase"]))

def make_sky():
    w = bpy.data.worlds.new("Sky")
    w.use_nodes = True
    nt = w.node_tree
    sky = nt.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "NISHITA"
    nt.links.new(sky.outputs[0], nt.nodes["Background"].inputs[0])
    return w
w = make_sky()
if MODE != "world":
    bpy.context.scene.world = w
for win in bpy.context.window_manager.windows:
    for area in win.screen.areas:
        if area.type == "PROPERTIES":
            area.spaces[0].context = "WORLD"
tmp = tempfile.mkdtemp()
script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "addon", "iblbake", "render_child.py")

def child():
    cmd = ["nice", "-n", "19", bpy.app.binary_path, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1",
           "--python", script, "--", os.path.join(tmp, "w.blend"), "Sky", "1024", "16", "1",
           os.path.join(tmp, "w.exr"), os.path.join(tmp, "notes.json")]
    a = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True)
    mark("popen returned after %.4f s" % (time.perf_counter() - a))
    first = True
    for line in p.stdout:
        if first:
            mark("first line: " + line.strip()[:60]); first = False
        if "Sample" in line and state["phase"] != "sampling":
            state["phase"] = "sampling"; mark("sampling")
    p.wait()
    state["phase"] = "done"
    mark("child exit %s" % p.returncode)

def tick():
    now = time.perf_counter()
    gaps.append((round(now - t0, 4), round(now - last[0], 4), state["phase"]))
    last[0] = now
    el = now - t0
    if state["phase"] == "idle" and el > 3.0:
        state["phase"] = "write"
        a = time.perf_counter()
        bpy.data.libraries.write(os.path.join(tmp, "w.blend"), {w}, path_remap="ABSOLUTE")
        mark("libraries.write %.4f s" % (time.perf_counter() - a))
        state["phase"] = "starting"
        if MODE == "popen":
            threading.Thread(target=child, daemon=True).start()
        else:
            bpy.context.scene.world = w
            mark("world switched")
    if MODE == "world" and el > 9.0:
        state["phase"] = "done"
    if state["phase"] == "done" or el > 40:
        json.dump({"events": events, "gaps": gaps}, open(OUT, "w"))
        bpy.ops.wm.quit_blender()
        return None
    return 0.01

bpy.app.timers.register(tick, first_interval=0.5)
