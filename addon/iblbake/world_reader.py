"""Reads the scene's world into a core.world.WorldSource and its pixels.

World Output -> Background -> Environment Texture (optionally through a
Mapping node fed by the view direction) is read pixel by pixel; a
Background with an unlinked colour is a plain colour; anything else is
rendered by Cycles to a lat-long and that image is baked."""
import math
import os
import re
import shutil
import subprocess
import tempfile
import threading

import bpy
import numpy as np

from .compat import uses_nodes
from .core import native
from .core.worker import NICE
from .core.world import COLOR, IMAGE, RENDER, Mapping, NeedsRender, WorldSource


class WorldError(Exception):
    """The world cannot be read (a missing image file, ...): the message says why."""


NO_WORLD = ("this scene has no world, so there is no lighting to bake: add one in World Properties "
            "(New), or pick an existing world there")


def ui_name(node) -> str:
    """A node as Blender's UI names it ("a Sky Texture node"), muted ones said so."""
    words = ("muted " if node.mute else "") + (node.bl_label or node.bl_idname) + " node"
    return ("an " if words[0].lower() in "aeiou" else "a ") + words


def _linked_node(sock):
    """The node feeding `sock` (through reroutes), or None when unlinked."""
    while sock.is_linked:
        link = sock.links[0]
        if link.is_muted or not link.is_valid:
            return None
        node = link.from_node
        if node.bl_idname != "NodeReroute":
            return node, link.from_socket
        sock = node.inputs[0]
    return None


def _active_output(tree):
    """The World Output Cycles uses (Blender's ntreeShaderOutputNode): an
    output for exactly CYCLES beats one for ALL; among equals, the active one."""
    best = None
    for n in tree.nodes:
        if n.bl_idname != "ShaderNodeOutputWorld" or n.target not in ("ALL", "CYCLES"):
            continue
        if best is None:
            best = n
        elif n.target == best.target:
            if n.is_active_output:
                best = n
        elif n.target == "CYCLES":
            best = n
    return best


def _constant(sock):
    return not sock.is_linked


def classify(world, check_image: bool = False, frame: int = None) -> WorldSource:
    """What the node tree is, without reading pixels or rendering. With
    check_image (the bake does this; a panel's draw need not load the file),
    an Environment Texture whose image Blender cannot load raises WorldError.
    Every image the world's output uses must have pixels at `frame` (the
    scene's current frame by default): Cycles would render a missing one as
    its magenta (WorldError). Drivers Blender did not run are noted."""
    src = _classify(world, check_image)
    if world is not None and uses_nodes(world):
        check_world_images(world, bpy.context.scene.frame_current if frame is None else frame)
    src.drivers = failed_drivers(world)
    return src


def _classify(world, check_image: bool) -> WorldSource:
    name = world.name if world else None
    if world is None:
        raise WorldError(NO_WORLD)
    if not uses_nodes(world):
        return WorldSource(COLOR, world=name, color=tuple(world.color))
    out = _active_output(world.node_tree)
    if out is None:
        return WorldSource(COLOR, "no World Output node: black", world=name, color=(0.0, 0.0, 0.0))
    found = _linked_node(out.inputs["Surface"])
    if found is None:
        return WorldSource(COLOR, "nothing linked to the World Output: black", world=name, color=(0.0, 0.0, 0.0))
    bg, _ = found
    if bg.bl_idname != "ShaderNodeBackground" or bg.mute:
        return WorldSource(RENDER, "the World Output is fed by %s" % ui_name(bg), world=name)
    strength_sock, color_sock = bg.inputs["Strength"], bg.inputs["Color"]
    if not _constant(strength_sock):
        return WorldSource(RENDER, "Background Strength is linked", world=name)
    strength = float(strength_sock.default_value)
    found = _linked_node(color_sock)
    if found is None:
        c = color_sock.default_value
        return WorldSource(COLOR, world=name, color=(c[0] * strength, c[1] * strength, c[2] * strength),
                           strength=strength)
    env, env_out = found
    if env.bl_idname != "ShaderNodeTexEnvironment" or env.mute or env_out.name != "Color":
        return WorldSource(RENDER, "the Background's Color is fed by %s" % ui_name(env), world=name)
    if env.projection != "EQUIRECTANGULAR":
        return WorldSource(RENDER, "Environment Texture projection %s" % env.projection, world=name)
    img = env.image
    if img is None:
        raise WorldError("the world's Environment Texture '%s' has no image" % env.name)
    if img.source not in ("FILE", "GENERATED"):
        return WorldSource(RENDER, "image source %s" % img.source, world=name)
    # Before any fallback: an image Blender cannot load would render as its
    # missing-texture magenta, and that must never become a bake.
    # Without check_image (the UI's click, which must not load an 8K file on
    # the main thread) the cheap signs still count: a missing file, or an
    # image Blender already failed to load (no color space).
    why_not = _unreadable(img) if check_image else _unreadable_cheap(img)
    if why_not:
        raise WorldError("the world's image '%s' cannot be read: %s" % (img.name, why_not))
    mapping, why = _mapping(env.inputs["Vector"])
    if why:
        return WorldSource(RENDER, why, world=name)
    src = WorldSource(IMAGE, world=name, strength=strength, image_name=img.name, colorspace=img.colorspace_settings.name,
                      mapping=mapping)
    if img.source == "FILE" and img.packed_file is None:
        src.image_path = os.path.abspath(bpy.path.abspath(img.filepath, library=img.library))
    src.is_float = _is_float(img, src.image_path)
    try:
        src.check_colorspace()
    except ValueError as e:
        return WorldSource(RENDER, str(e), world=name)
    return src


def _used_nodes(tree, seen=None):
    """The nodes whose output reaches the tree's active output (or a group's
    Group Output), through node groups: (node, tree) pairs."""
    seen = set() if seen is None else seen
    if tree is None or tree.as_pointer() in seen:
        return []
    seen.add(tree.as_pointer())
    outs = [n for n in tree.nodes if n.bl_idname in ("ShaderNodeOutputWorld", "NodeGroupOutput")]
    world_out = _active_output(tree)
    if world_out is not None:
        outs = [world_out]
    found, stack, visited = [], list(outs), set()
    while stack:
        node = stack.pop()
        if node.as_pointer() in visited or node.mute:
            continue
        visited.add(node.as_pointer())
        found.append(node)
        if node.bl_idname == "ShaderNodeGroup":
            found += _used_nodes(node.node_tree, seen)
        for sock in node.inputs:
            for link in sock.links:
                if link.is_valid and not link.is_muted:
                    stack.append(link.from_node)
    return found


def _frame_file(img, user, frame: int) -> str:
    """The file an image sequence shows at `frame` (Blender's numbering: the
    last run of digits in the file name, at its width)."""
    length = max(1, user.frame_duration)
    f = frame - user.frame_start + 1
    if user.use_cyclic:
        f = f % length or length
    else:
        f = min(max(f, 1), length)
    number = f + user.frame_offset
    path = os.path.abspath(bpy.path.abspath(img.filepath, library=img.library))
    head, tail = os.path.split(path)
    m = re.search(r"(\d+)(?!.*\d)", tail)
    if not m:
        return path
    return os.path.join(head, tail[:m.start()] + str(number).zfill(len(m.group(1))) + tail[m.end():])


def _missing_pixels(node, img, frame: int) -> str:
    """Why an image node has no pixels at `frame` ('' when it has them)."""
    if img.packed_file is not None or img.source in ("GENERATED", "VIEWER"):
        return ""
    path = os.path.abspath(bpy.path.abspath(img.filepath, library=img.library)) if img.filepath else ""
    if img.source == "TILED":
        if node.bl_idname == "ShaderNodeTexEnvironment":
            return "it is a UDIM (tiled) image, which an Environment Texture cannot show (Cycles renders it as " \
                   "the missing-texture magenta): use a single image"
        missing = [t.number for t in img.tiles if not os.path.isfile(path.replace("<UDIM>", str(t.number)))]
        return "no file for its UDIM tile%s %s" % ("s" if len(missing) > 1 else "", ", ".join(map(str, missing))) \
            if missing else ""
    if img.source == "SEQUENCE":
        want = _frame_file(img, node.image_user, frame)
        return "" if os.path.isfile(want) else "its image sequence has no file for frame %d (%s)" % (frame, want)
    if img.source in ("FILE", "MOVIE"):
        return _unreadable_cheap(img)
    return ""


def check_world_images(world, frame: int):
    """Raises WorldError naming the first image the world's output uses that
    has no pixels at `frame` (a missing file, a frame a sequence lacks, a UDIM
    image in an Environment Texture), node groups included."""
    for node in _used_nodes(world.node_tree):
        if node.bl_idname not in ("ShaderNodeTexImage", "ShaderNodeTexEnvironment") or node.image is None:
            continue
        why = _missing_pixels(node, node.image, frame)
        if why:
            raise WorldError("the world's image '%s' (node '%s') cannot be shown: %s"
                             % (node.image.name, node.name, why))


def failed_drivers(world) -> list:
    """Warnings for the world's drivers that Blender did not run: invalid ones,
    and Python expressions where script auto-execution is off (headless
    Blender without --enable-autoexec): their properties keep stored values."""
    if world is None:
        return []
    autoexec = bool(bpy.context.preferences.filepaths.use_scripts_auto_execute) and not bpy.app.autoexec_fail
    out = []
    for owner, label in ((world, "world"), (getattr(world, "node_tree", None), "world's nodes")):
        anim = getattr(owner, "animation_data", None) if owner is not None else None
        for fc in (anim.drivers if anim is not None else []):
            d = fc.driver
            python = d.type == "SCRIPTED" and not getattr(d, "is_simple_expression", False)
            if not d.is_valid or (python and not autoexec):
                why = "Python drivers are off in this Blender (auto-run scripts; blender --enable-autoexec)" \
                    if python and not autoexec else "it is invalid"
                out.append("the driver on %s (%r) did not run: %s; its stored value is baked"
                           % (_driven(owner, label, fc.data_path), d.expression, why))
    return out


def _driven(owner, label: str, data_path: str) -> str:
    """What a driver drives, as the UI names it: "the Background node's Strength"."""
    if data_path.endswith(".default_value"):
        try:
            sock = owner.path_resolve(data_path[:-len(".default_value")])
            return "the %s node's %s" % (sock.node.name, sock.name)
        except (ValueError, AttributeError):
            pass
    return "the %s %s" % (label, data_path)


def _unreadable_cheap(img):
    """Why an image cannot be read, from what Blender knows without loading it."""
    if img.source != "FILE":
        return ""
    path = os.path.abspath(bpy.path.abspath(img.filepath, library=img.library)) if img.filepath else ""
    if img.packed_file is None and path and not os.path.isfile(path):
        return "no file at %s" % path
    if not img.colorspace_settings.name:
        return "Blender could not load %s (not an image, or a format it does not read)" % (path or "the packed file")
    return ""


def _unreadable(img):
    """Why Blender has no pixels for a file image ('' when it has them)."""
    cheap = _unreadable_cheap(img)
    if cheap or img.source != "FILE":
        return cheap
    path = os.path.abspath(bpy.path.abspath(img.filepath, library=img.library)) if img.filepath else ""
    if img.has_data:
        return ""
    w, h = img.size  # loads the file
    if w > 0 and h > 0:
        return ""
    return "Blender could not load %s (not an image, or a format it does not read)" % (path or "the packed file")


def _is_float(img, path):
    # is_float is only known once the buffer is loaded; an HDR file is float.
    if img.has_data:
        return bool(img.is_float)
    return os.path.splitext(path)[1].lower() in (".exr", ".hdr", ".tif", ".tiff") if path else True


def _mapping(vector_sock):
    """(Mapping or None, why-not) for the Environment Texture's Vector input."""
    found = _linked_node(vector_sock)
    if found is None:
        return None, ""
    node, out = found
    if node.bl_idname == "ShaderNodeTexCoord" and out.name == "Generated":
        return None, ""
    if node.bl_idname != "ShaderNodeMapping":
        return None, "the Environment Texture's Vector comes from %s" % ui_name(node)
    src = _linked_node(node.inputs["Vector"])
    if src is None:
        return None, "the Mapping node's Vector is unlinked (a constant lookup)"
    if not (src[0].bl_idname == "ShaderNodeTexCoord" and src[1].name == "Generated"):
        return None, "the Mapping node's Vector comes from %s" % ui_name(src[0])
    if node.mute:  # passes the vector through
        return None, ""
    vals = {}
    for key in ("Location", "Rotation", "Scale"):
        sock = node.inputs.get(key)
        if sock is None:
            vals[key] = (0.0, 0.0, 0.0) if key != "Scale" else (1.0, 1.0, 1.0)
            continue
        if sock.is_linked:
            return None, "the Mapping node's %s is linked" % key
        vals[key] = tuple(float(v) for v in sock.default_value)
        if not all(math.isfinite(v) for v in vals[key]):
            raise WorldError("the world's Mapping node '%s' has a %s that is not a finite number (%s): set it to "
                             "numbers" % (node.name, key, ", ".join("%g" % v for v in vals[key])))
    return Mapping(node.vector_type, vals["Location"], vals["Rotation"], vals["Scale"]), ""


def alpha_matters(img, colorspace: str) -> bool:
    """Whether Cycles multiplies the colour by the image's alpha (straight or
    premultiplied alpha of a colour image)."""
    return img.alpha_mode not in ("CHANNEL_PACKED", "NONE") and colorspace not in ("Non-Color", "Raw")


def file_read_plan(src: WorldSource):
    """(path, alpha matters) when the Environment Texture's pixels can be
    read from its file off the main thread (core.world.read_file_pixels),
    else None: Blender's own buffer is read (a packed, generated or edited
    image, or a format the native module does not read: the self-contained
    wheels read OpenEXR, PNG, JPEG and Radiance .hdr, not TIFF). Raises
    WorldError for a missing file."""
    img = bpy.data.images[src.image_name]
    if src.image_path and not os.path.isfile(src.image_path):
        raise WorldError("the world's image '%s' cannot be read: no file at %s" % (img.name, src.image_path))
    if not src.image_path or img.is_dirty:
        return None
    if not native.load().image_format(src.image_path)[1]:
        return None
    return src.image_path, alpha_matters(img, src.colorspace)


def read_image_pixels(src: WorldSource):
    """The Environment Texture's radiance from Blender's buffer, (H, W, 3)
    float32 rows top-down (main thread: one foreach_get of the whole image)."""
    img = bpy.data.images[src.image_name]
    if src.image_path and not os.path.isfile(src.image_path):
        raise WorldError("the world's image '%s' cannot be read: no file at %s" % (img.name, src.image_path))
    if src.image_path and not img.is_dirty:
        img.reload()  # the file may have changed since Blender read it
    w, h = img.size
    if w == 0 or h == 0 or not img.has_data:
        img.reload()
        w, h = img.size
    if w == 0 or h == 0:
        raise WorldError("the world's image '%s' cannot be read (%s)" % (img.name, src.image_path or "no data"))
    src.is_float = bool(img.is_float)
    flat = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(flat)
    # Cycles multiplies the colour by a straight alpha below 1: leave that to it.
    if alpha_matters(img, src.colorspace) and float(flat[3::4].min()) < 1.0:
        raise NeedsRender("the image has alpha below 1")
    from .core.world import prepare_pixels
    return prepare_pixels(src, flat, w, h, remap=native.load().remap_latlong)


# Cycles' equirectangular camera shows Blender's Environment Texture layout
# (u = 0.5 along +X, top row +Z) when rotated (90, 0, -90) degrees.
PANO_ROTATION = (math.radians(90.0), 0.0, math.radians(-90.0))


def lighting_copy(world):
    """A copy of the world as it lights the scene: visible to camera rays, and
    Light Path's Is Camera Ray read as 0 (a backdrop shown only to the camera
    is not what objects reflect). Returns (copy, notes)."""
    copy = world.copy()
    notes = []
    copy.cycles_visibility.camera = True
    if world.cycles_visibility.camera is False:
        notes.append("camera visibility of the world turned on for the render")
    if uses_nodes(copy):
        nt = copy.node_tree
        for node in list(nt.nodes):
            if node.bl_idname != "ShaderNodeLightPath":
                continue
            links = list(node.outputs["Is Camera Ray"].links)
            if links:
                zero = nt.nodes.new("ShaderNodeValue")
                zero.outputs[0].default_value = 0.0
                for link in links:
                    nt.links.new(zero.outputs[0], link.to_socket)
                notes.append("Light Path 'Is Camera Ray' read as 0 (%s)" % node.name)
    return copy, notes


def render_world_to_file(world, width: int, samples: int, frame: int, path: str):
    """Renders the world as it lights the scene (lighting_copy) into `path`,
    a (width/2, width) float EXR lat-long (SPEC.md section 1's layout), with
    Cycles in a scratch scene with nothing in it at `frame` (box pixel
    filter: each pixel is its texel's mean). Blocks until done (the UI runs
    it in a child Blender instead: render_child.py). Returns notes on what
    lighting_copy changed."""
    scene = bpy.data.scenes.new("iblbake render")
    scene.frame_current = frame
    cam_data = bpy.data.cameras.new("iblbake pano")
    cam = bpy.data.objects.new("iblbake pano", cam_data)
    lit, notes = None, []
    try:
        if world is not None:
            lit, notes = lighting_copy(world)
        scene.world = lit
        cam_data.type = "PANO"
        if hasattr(cam_data, "panorama_type"):        # Blender 4+
            cam_data.panorama_type = "EQUIRECTANGULAR"
        else:                                         # Blender 3.x: a Cycles setting
            cam_data.cycles.panorama_type = "EQUIRECTANGULAR"
        cam.rotation_euler = PANO_ROTATION
        scene.collection.objects.link(cam)
        scene.camera = cam
        r = scene.render
        r.engine = "CYCLES"
        r.resolution_x, r.resolution_y, r.resolution_percentage = width, max(1, width // 2), 100
        r.film_transparent = False
        r.use_compositing = r.use_sequencer = False
        r.image_settings.file_format = "OPEN_EXR"
        r.image_settings.color_depth = "32"
        r.image_settings.color_mode = "RGB"
        r.filepath = path
        c = scene.cycles
        c.device = "CPU"
        c.samples = samples
        c.use_denoising = False  # Debian's Blender has no OpenImageDenoise
        c.use_adaptive_sampling = False
        c.pixel_filter_type = "BOX"
        c.filter_width = 1.0
        c.seed = 0
        if hasattr(c, "use_auto_tile"):  # Blender 3.0+: tiles, so the progress moves (the pixels are the same)
            c.use_auto_tile = True
            c.tile_size = render_tile_size(width)
        scene.view_settings.view_transform = "Standard"
        bpy.ops.render.render(write_still=True, scene=scene.name)
        if not os.path.isfile(path):
            raise WorldError("Cycles did not render the world")
        return notes
    finally:
        bpy.data.objects.remove(cam)
        bpy.data.cameras.remove(cam_data)
        bpy.data.scenes.remove(scene)
        if lit is not None:
            bpy.data.worlds.remove(lit)


def render_world(world, width: int, samples: int, frame: int = 1):
    """render_world_to_file in this process, read back: ((width/2, width, 3)
    float32 lat-long, notes)."""
    tmp = tempfile.mkdtemp(prefix="iblbake-render-")
    path = os.path.join(tmp, "world.exr")
    try:
        notes = render_world_to_file(world, width, samples, frame, path)
        check_not_magenta(path)
        return native.load().read_image(path), notes
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def render_settings(scene, render_width: int, render_samples: int):
    """(src.render dict, notes) for a rendered world: the width is raised for a
    sun disc narrower than a pixel."""
    notes = []
    if render_width < SUN_DISC_MIN_WIDTH and _has_sun_disc(scene.world):
        notes.append("render width raised from %d to %d: a sun disc narrower than a pixel is hit by "
                     "too few samples" % (render_width, SUN_DISC_MIN_WIDTH))
        render_width = SUN_DISC_MIN_WIDTH
    render = {"width": render_width, "height": max(1, render_width // 2), "samples": render_samples,
              "engine": "CYCLES", "camera": "panoramic equirectangular", "denoising": False,
              "pixel_filter": "box 1 px", "frame": scene.frame_current}
    return render, notes


# Blender's missing-texture colour, (1, 0, 1) times whatever follows it.
def magenta_share(pixels) -> float:
    """The share of texels that are Blender's missing-texture magenta (red
    equal to blue, no green)."""
    px = np.asarray(pixels, dtype=np.float32).reshape(-1, 3)
    r, g, b = px[:, 0], px[:, 1], px[:, 2]
    magenta = (r > 1e-6) & (np.abs(r - b) <= 1e-3 * r) & (g <= 1e-3 * r)
    return float(magenta.mean()) if len(px) else 0.0


def check_not_magenta(path: str):
    """Refuses a rendered lat-long that is mostly Blender's magenta: an image in
    the world had no pixels (a check before the render missed it)."""
    share = magenta_share(native.load().read_image(path))
    if share > 0.5:
        raise WorldError("Cycles rendered %d %% of the world as Blender's missing-texture magenta: an image in the "
                         "world has no pixels (a missing file, frame or UDIM tile); fix the image and bake again"
                         % round(100 * share))


class ChildRender:
    """The world rendered by Cycles in a child Blender (`blender -b`, this
    add-on's render_child.py), so the UI stays live and Esc can stop it:
    start() writes the world to a scratch .blend (main thread, milliseconds)
    and starts the child; poll() says how far it got; cancel() ends it."""

    SAMPLE = re.compile(r"(?:Sample|Path Tracing Sample)\s+(\d+)\s*/\s*(\d+)|(\d+)\s*/\s*(\d+)\s+[Ss]amples")
    TILES = re.compile(r"Rendered\s+(\d+)\s*/\s*(\d+)\s+Tiles")

    def __init__(self, world, width: int, samples: int, frame: int):
        self.tmp = tempfile.mkdtemp(prefix="iblbake-render-")
        self.blend = os.path.join(self.tmp, "world.blend")
        self.exr = os.path.join(self.tmp, "world.exr")
        self.notes_path = os.path.join(self.tmp, "notes.json")
        self.args = (world.name if world is not None else "", width, samples, frame)
        self.world = world
        self.fraction = 0.0
        self.sampling = False  # Cycles has begun sampling (before: Blender starting, the scene's sync)
        self.saving = False    # Cycles has finished: the child writes the EXR and quits
        self.lines = []
        self.proc = None
        self._reader = None
        self._spawned = threading.Event()
        self._spawn_error = None
        self._cancelled = False

    def start(self):
        """Writes the world's .blend here (bpy, milliseconds); the child is
        started by the log's thread (starting a process from a process as
        large as Blender takes a moment the UI must not wait for)."""
        if self.world is not None:
            bpy.data.libraries.write(self.blend, {self.world}, path_remap="ABSOLUTE")
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "render_child.py")
        name, width, samples, frame = self.args
        cmd = [bpy.app.binary_path, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1",
               "--python", script, "--", self.blend if self.world is not None else "", name, str(width),
               str(samples), str(frame), self.exr, self.notes_path]
        # The open Blender's UI comes first (core/worker.py's lower_priority says how, and why that is fair;
        # render_child.py lowers its threads further before Cycles starts).
        if shutil.which("nice"):
            cmd = ["nice", "-n", str(NICE)] + cmd
        self._reader = threading.Thread(target=self._spawn_and_read, args=(cmd,), name="iblbake render log",
                                        daemon=True)
        self._reader.start()
        return self

    def _spawn_and_read(self, cmd):
        env = dict(os.environ)
        env.pop("PYTHONPATH", None)
        # The child's own temporary folder (Blender's blender_XXXXXX, with Cycles' tile buffers: a render's
        # worth of floats) inside ours, which cleanup() removes: a child ended by a cancel (SIGTERM, or
        # killed) leaves it behind otherwise. With --factory-startup the child has no preferences'
        # temporary folder, and Blender then takes TMPDIR's.
        env["TMPDIR"] = self.tmp
        try:
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                    stdin=subprocess.DEVNULL, env=env, text=True, errors="replace")
        except OSError as e:
            self._spawn_error = e
            self._spawned.set()
            return
        self.proc = proc
        self._spawned.set()
        if self._cancelled:
            proc.terminate()
        self._read()

    def _read(self):
        for line in self.proc.stdout:
            self.lines = (self.lines + [line.rstrip()])[-40:]
            if line.startswith("Saved:") or line.rstrip().endswith("| Finished"):
                self.saving = True
            m = self.SAMPLE.search(line)
            if m:
                done, total = (m.group(1), m.group(2)) if m.group(1) else (m.group(3), m.group(4))
                if int(total) > 0:
                    fraction = int(done) / int(total)
                    tiles = self.TILES.search(line)  # "Rendered 3/32 Tiles, Sample 5/16"
                    if tiles and int(tiles.group(2)) > 0:
                        fraction = (int(tiles.group(1)) + fraction) / int(tiles.group(2))
                    self.fraction = max(self.fraction, min(1.0, fraction))
                    self.sampling = True

    def done(self) -> bool:
        return self._spawned.is_set() and (self._spawn_error is not None or self.proc.poll() is not None)

    def result(self):
        """(path of the rendered EXR, notes); raises WorldError when the child failed."""
        if self._spawn_error is not None:
            raise WorldError("Cycles could not render the world: Blender could not be started (%s)"
                             % self._spawn_error)
        if self._reader is not None:
            self._reader.join(5)
        if self.proc.returncode != 0 or not os.path.isfile(self.exr):
            tail = [ln for ln in self.lines if ln.strip()][-3:]
            raise WorldError("Cycles could not render the world (exit code %s): %s"
                             % (self.proc.returncode, " / ".join(tail) or "no output"))
        check_not_magenta(self.exr)
        notes = []
        try:
            import json
            with open(self.notes_path) as f:
                notes = json.load(f)
        except (OSError, ValueError):
            pass
        return self.exr, notes

    def cancel(self):
        """Asks the child to stop (SIGTERM); returns at once (done() says when it has)."""
        self._cancelled = True
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()

    def cleanup(self):
        """Ends the child (killed if SIGTERM did not end it within a second) and removes its files."""
        self._cancelled = True
        self._spawned.wait(10)
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(1)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)


def read_world(scene, render_width: int, render_samples: int):
    """(WorldSource, pixels or None for a plain color), on the main thread
    (scripts and `blender -b`; the UI's operator runs these steps as a job)."""
    src = classify(scene.world, check_image=True)
    if src.path == IMAGE:
        try:
            return src, read_image_pixels(src)
        except NeedsRender as e:
            src = WorldSource(RENDER, str(e), world=src.world)
    if src.path == RENDER:
        src.render, notes = render_settings(scene, render_width, render_samples)
        pixels, copy_notes = render_world(scene.world, src.render["width"], render_samples, scene.frame_current)
        src.render["notes"] = notes + copy_notes
        return src, pixels
    return src, None


def render_tile_size(width: int) -> int:
    """Cycles' tile for a render `width` wide: 32 tiles or more, so that the
    progress (printed per tile) moves often."""
    return max(128, width // 32)


# Nishita's (5.x: Single Scattering's) sun is 0.545 degrees across by default: at 1024 pixels across
# (0.35 degrees each) it covers about two pixels, which 16 samples resolve.
SUN_DISC_MIN_WIDTH = 1024


def _has_sun_disc(world):
    if world is None or not uses_nodes(world):
        return False
    # Nishita's sky (Blender 5 splits it into single and multiple scattering) draws a sun disc.
    return any(n.bl_idname == "ShaderNodeTexSky" and n.sky_type not in ("PREETHAM", "HOSEK_WILKIE")
               and getattr(n, "sun_disc", False) and not n.mute for n in world.node_tree.nodes)



# -- whether the world changed since a bake ----------------------------------------
# Node properties that change how a node looks in the editor, not what it computes.
_UI_PROPS = frozenset({"rna_type", "name", "label", "location", "width", "width_hidden", "height", "dimensions",
                       "select", "show_options", "show_preview", "show_texture", "hide", "color", "use_custom_color",
                       "parent", "bl_idname", "bl_label", "bl_description", "bl_icon", "bl_static_type",
                       "bl_width_default", "bl_width_min", "bl_width_max", "bl_height_default", "bl_height_min",
                       "bl_height_max", "type", "internal_links", "inputs", "outputs", "is_active_output",
                       "warning_propagation", "use_alpha"})


def _value(v):
    """A property's value as JSON (vectors as lists, data-blocks by name and file)."""
    if isinstance(v, (bool, int, str)) or v is None:
        return v
    if isinstance(v, float):
        return round(v, 7)
    if isinstance(v, bpy.types.Image):
        path = os.path.abspath(bpy.path.abspath(v.filepath, library=v.library)) if v.filepath else ""
        try:
            st = os.stat(path)
            stamp = [st.st_size, st.st_mtime_ns]
        except OSError:
            stamp = None
        return ["image", v.name, path, stamp, v.source, v.colorspace_settings.name, v.alpha_mode, v.is_dirty]
    if isinstance(v, bpy.types.ID):
        return [type(v).__name__, v.name]
    try:
        return [_value(x) for x in v]
    except TypeError:
        return str(v)


def _tree_json(tree, seen):
    if tree is None or tree.name in seen:
        return None
    seen.add(tree.name)
    nodes = []
    for node in sorted(tree.nodes, key=lambda n: n.name):
        props = {}
        for prop in node.bl_rna.properties:
            key = prop.identifier
            if key in _UI_PROPS or prop.type in ("POINTER", "COLLECTION") and key not in ("image", "node_tree"):
                continue
            try:
                props[key] = _value(getattr(node, key))
            except (AttributeError, RuntimeError):
                continue
        if getattr(node, "node_tree", None) is not None:
            props["node_tree"] = _tree_json(node.node_tree, seen)
        inputs = [[s.identifier, s.is_linked, _value(getattr(s, "default_value", None))] for s in node.inputs]
        nodes.append([node.name, node.bl_idname, node.mute, props, inputs])
    links = sorted([link.from_node.name, link.from_socket.identifier, link.to_node.name, link.to_socket.identifier,
                    link.is_muted] for link in tree.links)
    return [nodes, links]


def fingerprint(world) -> str:
    """sha256 of what makes a world light the scene as it does: its node tree
    (every node's settings and inputs, the links, node groups) or colour, and
    its images' files (size and time). Cheap enough for the panel (cached
    there until the next change); a changed fingerprint tells the panel the
    folder's bake no longer shows the world."""
    import hashlib
    import json
    if world is None:
        data = None
    elif uses_nodes(world):
        data = ["nodes", _tree_json(world.node_tree, set()), world.cycles_visibility.camera]
    else:
        data = ["colour", _value(world.color)]
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()
