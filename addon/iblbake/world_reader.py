"""Reads the scene's world into a core.world.WorldSource and its pixels.

World Output -> Background -> Environment Texture (optionally through a
Mapping node fed by the view direction) is read pixel by pixel; a
Background with an unlinked colour is a plain colour; anything else is
rendered by Cycles to a lat-long and that image is baked."""
import math
import os
import tempfile

import bpy
import numpy as np

from .compat import SUN_DISC_SKIES, uses_nodes
from .core import native
from .core.world import COLOR, IMAGE, RENDER, Mapping, WorldSource


class WorldError(Exception):
    """The world cannot be read (a missing image file, ...): the message says why."""


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


def classify(world) -> WorldSource:
    """What the node tree is, without reading pixels or rendering."""
    name = world.name if world else None
    if world is None:
        return WorldSource(RENDER, "the scene has no world", world=None)
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
        return WorldSource(RENDER, "the World Output is fed by a %s node" % bg.bl_idname, world=name)
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
        return WorldSource(RENDER, "Background Color is fed by %s" % env.bl_idname, world=name)
    if env.projection != "EQUIRECTANGULAR":
        return WorldSource(RENDER, "Environment Texture projection %s" % env.projection, world=name)
    img = env.image
    if img is None:
        raise WorldError("the world's Environment Texture '%s' has no image" % env.name)
    if img.source not in ("FILE", "GENERATED"):
        return WorldSource(RENDER, "image source %s" % img.source, world=name)
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
        return None, "the Environment Texture's Vector comes from %s" % node.bl_idname
    src = _linked_node(node.inputs["Vector"])
    if src is None:
        return None, "the Mapping node's Vector is unlinked (a constant lookup)"
    if not (src[0].bl_idname == "ShaderNodeTexCoord" and src[1].name == "Generated"):
        return None, "the Mapping node's Vector comes from %s" % src[0].bl_idname
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
    return Mapping(node.vector_type, vals["Location"], vals["Rotation"], vals["Scale"]), ""


class NeedsRender(Exception):
    """The image's pixels are not what Cycles shows (e.g. straight alpha)."""


def read_image_pixels(src: WorldSource):
    """The Environment Texture's radiance, (H, W, 3) float32 rows top-down."""
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
    if (img.alpha_mode not in ("CHANNEL_PACKED", "NONE") and src.colorspace not in ("Non-Color", "Raw")
            and float(flat[3::4].min()) < 1.0):
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


def render_world(world, width: int, samples: int, frame: int = 1):
    """The world as it lights the scene (lighting_copy), as a (width/2,
    width, 3) float32 lat-long (SPEC.md section 1's layout), rendered by
    Cycles in a scratch scene with nothing in it at `frame` (box pixel
    filter: each pixel is its texel's mean). Blocks until done. Returns
    (pixels, notes on what lighting_copy changed)."""
    scene = bpy.data.scenes.new("iblbake render")
    scene.frame_current = frame
    cam_data = bpy.data.cameras.new("iblbake pano")
    cam = bpy.data.objects.new("iblbake pano", cam_data)
    tmp = tempfile.mkdtemp(prefix="iblbake-render-")
    path = os.path.join(tmp, "world.exr")
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
        scene.view_settings.view_transform = "Standard"
        bpy.ops.render.render(write_still=True, scene=scene.name)
        if not os.path.isfile(path):
            raise WorldError("Cycles did not render the world")
        return native.load().read_image(path), notes
    finally:
        bpy.data.objects.remove(cam)
        bpy.data.cameras.remove(cam_data)
        bpy.data.scenes.remove(scene)
        if lit is not None:
            bpy.data.worlds.remove(lit)
        for f in os.listdir(tmp):
            os.remove(os.path.join(tmp, f))
        os.rmdir(tmp)


def read_world(scene, render_width: int, render_samples: int):
    """(WorldSource, pixels or None for a plain colour)."""
    src = classify(scene.world)
    if src.path == IMAGE:
        try:
            return src, read_image_pixels(src)
        except NeedsRender as e:
            src = WorldSource(RENDER, str(e), world=src.world)
    if src.path == RENDER:
        notes = []
        if render_width < SUN_DISC_MIN_WIDTH and _has_sun_disc(scene.world):
            notes.append("render width raised from %d to %d: a sun disc narrower than a pixel is hit by "
                         "too few samples" % (render_width, SUN_DISC_MIN_WIDTH))
            render_width = SUN_DISC_MIN_WIDTH
        src.render = {"width": render_width, "height": max(1, render_width // 2), "samples": render_samples,
                      "engine": "CYCLES", "camera": "panoramic equirectangular", "denoising": False,
                      "pixel_filter": "box 1 px", "frame": scene.frame_current}
        pixels, copy_notes = render_world(scene.world, render_width, render_samples, scene.frame_current)
        src.render["notes"] = notes + copy_notes
        return src, pixels
    return src, None


# Nishita's (5.x: Single Scattering's) sun is 0.545 degrees across by default: at 1024 pixels across
# (0.35 degrees each) it covers about two pixels, which 16 samples resolve.
SUN_DISC_MIN_WIDTH = 1024


def _has_sun_disc(world):
    if world is None or not uses_nodes(world):
        return False
    return any(n.bl_idname == "ShaderNodeTexSky" and n.sky_type in SUN_DISC_SKIES and n.sun_disc and not n.mute
               for n in world.node_tree.nodes)

