"""Scenes for the add-on's tests, run inside headless Blender:

  blender -b --factory-startup --python tests/blender/cases.py -- CASE WORKDIR [key=value ...]

Each case builds a scene, drives the add-on through bpy.ops.iblbake.bake()
and writes what it saw to WORKDIR/result.json for test_addon.py to check
(numbers are compared there, outside Blender)."""
import json
import math
import os
import sys
from pathlib import Path

import bpy
import mathutils
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "addon"))
import iblbake  # noqa: E402
from iblbake import operators, scene_settings, world_reader  # noqa: E402
from iblbake.compat import ALWAYS_NODES  # noqa: E402
from iblbake.core import native, pipeline  # noqa: E402
from iblbake.core.job import BakeJob  # noqa: E402

iblbake.register()


def direction_field(width, height):
    """A lat-long whose colour is its direction: rgb = 0.5 + 0.5 (x, y, z)
    (Blender axes), so any flip or turn of an axis changes the colour."""
    v = 1.0 - (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    lat = (v - 0.5) * math.pi
    phi = (0.5 - u) * 2 * math.pi
    x = np.cos(lat)[:, None] * np.cos(phi)[None, :]
    y = np.cos(lat)[:, None] * np.sin(phi)[None, :]
    z = np.broadcast_to(np.sin(lat)[:, None], x.shape)
    return (0.5 + 0.5 * np.stack([x, y, z], -1)).astype(np.float32)


def save_exr(path, rgb):
    """Writes a (H, W, 3) top-down array as a float EXR (the native writer:
    Blender's Image.save() would encode the float buffer for display)."""
    native.load().write_exr(str(path), np.ascontiguousarray(rgb, dtype=np.float32))
    return str(path)


def save_png_srgb(path, rgb):
    """Writes a (H, W, 3) linear array as an 8-bit sRGB PNG through Blender
    (a byte image's pixels are its stored, sRGB-encoded values)."""
    h, w, _ = rgb.shape
    enc = np.where(rgb <= 0.0031308, rgb * 12.92, 1.055 * np.power(np.maximum(rgb, 0), 1 / 2.4) - 0.055)
    img = bpy.data.images.new(Path(path).stem, w, h, alpha=True, float_buffer=False)
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = np.clip(enc, 0, 1)
    img.pixels.foreach_set(rgba[::-1].reshape(-1))
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)
    return str(path)


def image_world(path, strength=1.0, rotation=(0, 0, 0), mapping_type="POINT"):
    world = bpy.data.worlds.new("image world")
    if not ALWAYS_NODES:
        world.use_nodes = True
    nt = world.node_tree
    bg = nt.nodes["Background"]
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(path), check_existing=False)
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = strength
    if any(rotation):
        mapping = nt.nodes.new("ShaderNodeMapping")
        mapping.vector_type = mapping_type
        coords = nt.nodes.new("ShaderNodeTexCoord")
        mapping.inputs["Rotation"].default_value = [math.radians(a) for a in rotation]
        nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    bpy.context.scene.world = world
    return world


def empty_scene(face_size=32):
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    p = scene.iblbake
    p.use_scene_options = True
    p.auto_skip = True  # "Bake For: This Scene's Materials" (the UI's default bakes every roughness)
    p.face_size, p.irradiance_size, p.lut_size = face_size, 8, 32
    return scene


def bake(out, **props):
    scene = bpy.context.scene
    scene.iblbake.output_dir = str(out)
    for k, v in props.items():
        setattr(scene.iblbake, k, v)
    try:
        result = bpy.ops.iblbake.bake()
    except RuntimeError:  # an operator that reports an error raises in scripts
        result = {"CANCELLED"}
    return {"result": sorted(result), "status": scene.iblbake.last_status, "error": scene.iblbake.last_error}


def render_directions(dirs, samples=16):
    """Cycles' own view of the world along each Blender direction: the mean
    of a narrow (1 degree) perspective render."""
    scene = bpy.context.scene
    cam_data = bpy.data.cameras.new("probe")
    cam_data.angle = math.radians(1.0)
    cam = bpy.data.objects.new("probe", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x = r.resolution_y = 8
    r.resolution_percentage = 100
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.view_settings.view_transform = "Standard"
    out = []
    for d in dirs:
        cam.rotation_euler = mathutils.Vector(d).to_track_quat("-Z", "Y").to_euler()
        r.filepath = os.path.join(WORK, "probe.exr")
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(r.filepath, check_existing=False)
        px = np.empty(len(img.pixels), np.float32)
        img.pixels.foreach_get(px)
        out.append(px.reshape(-1, 4)[:, :3].mean(0).tolist())
        bpy.data.images.remove(img)
    bpy.data.objects.remove(cam)
    return out


# Along +-X, +-Y and +-Z, the poles tilted 2 degrees: within half a texel of a
# pole Cycles repeats the image vertically (the top row blends with the
# bottom one) where SPEC.md clamps, and a 1-degree probe there would mix both.
PROBES = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0.0349, 0, 0.9994), (0.0349, 0, -0.9994),
          (0.6, 0.48, 0.64), (-0.36, 0.8, -0.48)]


def case_orientation(args):
    """A direction-coded world (optionally through a Mapping node and a
    Strength) baked by the add-on, and rendered by Cycles along PROBES."""
    empty_scene(face_size=int(args.get("face", 64)))
    if args.get("format") == "png":
        path = save_png_srgb(os.path.join(WORK, "field.png"), direction_field(512, 256))
    else:
        path = save_exr(os.path.join(WORK, "field.exr"), direction_field(512, 256))
    rot = tuple(float(a) for a in args.get("rotation", "0,0,0").split(","))
    image_world(path, float(args.get("strength", 1.0)), rot, args.get("mapping_type", "POINT"))
    res = bake(os.path.join(WORK, "out"), lut=False, mip_count=2)
    res["probes"] = PROBES
    res["cycles"] = render_directions(PROBES)
    return res


def case_sky(args):
    """A Sky Texture world: rendered to a lat-long by Cycles, then baked."""
    scene = empty_scene()
    world = bpy.data.worlds.new("sky")
    if not ALWAYS_NODES:
        world.use_nodes = True
    nt = world.node_tree
    sky = nt.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "HOSEK_WILKIE"
    sky.sun_direction = mathutils.Vector((0.3, -0.5, 0.4)).normalized()
    nt.links.new(sky.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    scene.world = world
    scene.iblbake.render_width, scene.iblbake.render_samples = 256, 16
    res = bake(os.path.join(WORK, "out"), lut=False, mip_count=2)
    probes = [(0, 0, 1), (0.7, 0.0, 0.714), (-0.5, 0.6, 0.624), (0.0, -0.8, 0.6), (-0.9, -0.1, 0.42)]
    res["probes"] = probes
    res["cycles"] = render_directions(probes)
    return res


def case_sun_disc(args):
    """Which sky worlds get the wider render for their sun disc: the
    sun-disc sky of this Blender (Nishita; 5.x: Single and Multiple
    Scattering), with and without the disc, and a sky without one."""
    kinds = [k for k in ("NISHITA", "SINGLE_SCATTERING", "MULTIPLE_SCATTERING", "HOSEK_WILKIE")
             if k in {e.identifier for e in bpy.types.ShaderNodeTexSky.bl_rna.properties["sky_type"].enum_items}]
    res = {}
    for kind in kinds:
        for disc in (True, False):
            world = bpy.data.worlds.new("%s %s" % (kind, disc))
            if not ALWAYS_NODES:
                world.use_nodes = True
            sky = world.node_tree.nodes.new("ShaderNodeTexSky")
            sky.sky_type = kind
            sky.sun_disc = disc
            world.node_tree.links.new(sky.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
            res["%s %s" % (kind, disc)] = world_reader._has_sun_disc(world)
    return res


def case_color(args):
    scene = empty_scene()
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.4, 0.8, 1.0)
    bg.inputs["Strength"].default_value = 1.5
    return bake(os.path.join(WORK, "out"))


def baked_field_world(width=64, height=32):
    """An empty scene whose world is a direction field, baked once into
    WORK/out: (world, image path, out folder, the bake's result, its manifest text)."""
    empty_scene()
    path = save_exr(os.path.join(WORK, "field.exr"), direction_field(width, height))
    world = image_world(path)
    out = os.path.join(WORK, "out")
    first = bake(out)
    return world, path, out, first, open(os.path.join(out, "manifest.json")).read()


def case_unchanged(args):
    """Bake, bake again (skipped), change Strength (baked again)."""
    world, _, out, first, _ = baked_field_world()
    mtime = os.stat(os.path.join(out, "manifest.json")).st_mtime_ns
    second = bake(out)
    same_file = os.stat(os.path.join(out, "manifest.json")).st_mtime_ns == mtime
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 2.0
    third = bake(out)
    forced = bake(out, force=True)
    return {"first": first, "second": second, "untouched": same_file, "third": third, "forced": forced}


def add_cube(material):
    bpy.ops.mesh.primitive_cube_add()
    bpy.context.active_object.data.materials.append(material)


def material(name, kind, **inputs):
    mat = bpy.data.materials.new(name)
    if not ALWAYS_NODES:
        mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        if n.bl_idname != "ShaderNodeOutputMaterial":
            nt.nodes.remove(n)
    node = nt.nodes.new(kind)
    nt.links.new(node.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    for k, v in inputs.items():
        if v == "texture":
            tex = nt.nodes.new("ShaderNodeTexNoise")
            nt.links.new(tex.outputs["Fac"], node.inputs[k])
        else:
            node.inputs[k].default_value = v
    return mat


def case_needs(args):
    """What the materials use decides what is baked."""
    empty_scene(face_size=32)  # 6 levels, r_m = m / 5
    path = save_exr(os.path.join(WORK, "field.exr"), direction_field(64, 32))
    image_world(path)
    out = {}
    add_cube(material("diffuse", "ShaderNodeBsdfDiffuse"))
    out["diffuse_only"] = bake(os.path.join(WORK, "diffuse_only"))
    bpy.context.active_object.data.materials[0] = material(
        "plastic", "ShaderNodeBsdfPrincipled", Roughness=0.3, Metallic=0.0)
    out["principled_0.3"] = bake(os.path.join(WORK, "principled"))
    bpy.context.active_object.data.materials[0] = material(
        "metal", "ShaderNodeBsdfPrincipled", Roughness="texture", Metallic=1.0)
    out["metal_textured"] = bake(os.path.join(WORK, "metal"))
    out["metal_no_auto_skip"] = bake(os.path.join(WORK, "metal_all"), auto_skip=False)
    return out


def case_needs_edges(args):
    """Materials the render shows though the viewport does not, or only
    through instances or muted nodes, still count."""
    scene = empty_scene(face_size=32)
    image_world(save_exr(os.path.join(WORK, "field.exr"), direction_field(64, 32)))
    add_cube(material("diffuse", "ShaderNodeBsdfDiffuse"))
    metal = material("metal", "ShaderNodeBsdfPrincipled", Roughness=0.1, Metallic=1.0)
    out = {}

    def needs():
        from iblbake.core.settings import BakeSettings
        n = scene_settings.scene_needs_for(scene, BakeSettings(face_size=32))
        return {"specular": n.specular, "levels": list(n.levels) if n.levels else None}

    out["diffuse"] = needs()
    add_cube(metal)
    hidden = bpy.context.active_object
    hidden.hide_set(True)
    out["hidden_in_viewport"] = needs()
    hidden.hide_render = True
    out["hidden_in_render"] = needs()
    coll = bpy.data.collections.new("instanced")
    coll.objects.link(hidden)
    inst = bpy.data.objects.new("inst", None)
    inst.instance_type, inst.instance_collection = "COLLECTION", coll
    scene.collection.objects.link(inst)
    out["collection_instance"] = needs()
    bpy.data.objects.remove(inst)
    mix = material("mutedmix", "ShaderNodeMixShader")
    nt = mix.node_tree
    glossy = nt.nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Roughness"].default_value = 0.0
    nt.links.new(glossy.outputs[0], nt.nodes["Mix Shader"].inputs[1])
    nt.nodes["Mix Shader"].mute = True
    bpy.data.objects.remove(hidden)
    add_cube(mix)
    out["muted_mix"] = needs()
    return out


def case_light_path(args):
    """A world showing a grey backdrop to the camera and the image to
    everything else is baked as it lights the scene: the image."""
    scene = empty_scene()
    path = save_exr(os.path.join(WORK, "field.exr"), direction_field(64, 32))
    world = image_world(path)
    nt = world.node_tree
    bg = nt.nodes["Background"]
    backdrop = nt.nodes.new("ShaderNodeBackground")
    backdrop.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1)
    mix = nt.nodes.new("ShaderNodeMixShader")
    lp = nt.nodes.new("ShaderNodeLightPath")
    nt.links.new(lp.outputs["Is Camera Ray"], mix.inputs["Fac"])
    nt.links.new(bg.outputs[0], mix.inputs[1])
    nt.links.new(backdrop.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], nt.nodes["World Output"].inputs["Surface"])
    world.cycles_visibility.camera = False
    scene.iblbake.render_width, scene.iblbake.render_samples = 64, 4
    res = bake(os.path.join(WORK, "out"), lut=False)
    return res


def case_cancel(args):
    """A bake cancelled half-way (the modal operator's background job) leaves
    the earlier bake as it was."""
    world, _, out, first, before = baked_field_world(128, 64)
    scene = bpy.context.scene
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 3.0
    settings, needs, source, pixels, extra = operators.prepare(bpy.context, scene)
    stages = []

    def work(progress):
        def watch(stage, fraction):
            stages.append(stage)
            if stage == "specular":
                job.cancel()
            return progress(stage, fraction)
        return pipeline.bake(source, pixels, settings, needs, watch, extra)

    job = BakeJob(work)  # bound before it starts: watch() may run before start() returns
    job.start()
    finished = job.wait(120)
    after = open(os.path.join(out, "manifest.json")).read()
    siblings = sorted(os.listdir(WORK))
    return {"first": first, "finished": finished, "cancelled": job.cancelled,
            "error": str(job.error) if job.error else None, "stages": stages, "unchanged": before == after, "siblings": siblings}


def case_missing(args):
    """A world whose image file is gone: a clear error, the earlier bake kept."""
    world, path, out, first, before = baked_field_world()
    os.remove(path)
    img = world.node_tree.nodes["Environment Texture"].image
    img.filepath = os.path.join(WORK, "gone.exr")
    img.reload()
    second = bake(out, force=True)
    after = open(os.path.join(out, "manifest.json")).read()
    return {"first": first, "second": second, "unchanged": before == after}


def case_save_blend(args):
    """Saves a .blend whose world is the direction field, for the batch test."""
    empty_scene()
    path = save_exr(os.path.join(WORK, "field.exr"), direction_field(64, 32))
    image_world(path, strength=2.0)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(WORK, "scene.blend"))
    return {"saved": True}


def _world(name="hostile"):
    world = bpy.data.worlds.new(name)
    if not ALWAYS_NODES:
        world.use_nodes = True
    bpy.context.scene.world = world
    return world, world.node_tree


def _env_world(image_file=None, to_background=True):
    """A world with an Environment Texture (of WORK/image_file, an orange field, when given), its Color
    linked to the Background's unless told not to: (node tree, node)."""
    _, nt = _world()
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    if image_file:
        orange = np.tile(np.float32([0.9, 0.3, 0.05]), (32, 64, 1))
        env.image = bpy.data.images.load(save_exr(os.path.join(WORK, image_file), orange))
    if to_background:
        nt.links.new(env.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    return nt, env


def case_save_hostile_world(args):
    """Saves WORK/scene.blend whose world looks right but is not (issue 24):
    kind = udim, udim_1001, sequence_gap, mix_missing, mapping_nan, srgb_float, driver_black, emoji_name."""
    kind = args["kind"]
    empty_scene()
    if kind == "emoji_name":
        _env_world("orange.exr")
        bpy.context.scene.world.name = args.get("world_name", "\U0001F600\U0001F30D")
    elif kind in ("udim", "udim_1001"):
        nt, env = _env_world("tile.1001.exr" if kind == "udim_1001" else None)
        img = bpy.data.images.new("tiles", 64, 32, float_buffer=True, tiled=True)
        img.source = "TILED"
        img.filepath = os.path.join(WORK, "tile.<UDIM>.exr")
        env.image = img
    elif kind == "sequence_gap":
        nt, env = _env_world("seq.0001.exr")
        env.image.source = "SEQUENCE"
        env.image_user.frame_duration = 1
        env.image_user.frame_start = 1
        env.image_user.use_cyclic = False
        env.image_user.frame_offset = 4  # frame 1 shows seq.0005.exr, which does not exist
    elif kind == "mix_missing":
        nt, env = _env_world("gone.exr", to_background=False)
        mix = nt.nodes.new("ShaderNodeMixRGB")
        mix.inputs["Fac"].default_value = 0.5
        mix.inputs["Color2"].default_value = (0.1, 0.1, 0.1, 1)
        nt.links.new(env.outputs["Color"], mix.inputs["Color1"])
        nt.links.new(mix.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    elif kind == "mapping_nan":
        nt, env = _env_world("orange.exr")
        mapping, coords = nt.nodes.new("ShaderNodeMapping"), nt.nodes.new("ShaderNodeTexCoord")
        mapping.name = "Sky Turn"
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, float("nan"))
        nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    elif kind == "srgb_float":
        value = float(args.get("value", 4.0))
        world = image_world(save_exr(os.path.join(WORK, "bright.exr"), np.full((32, 64, 3), value, np.float32)))
        world.node_tree.nodes["Environment Texture"].image.colorspace_settings.name = "sRGB"
    elif kind == "driver_black":
        world, nt = _world()
        bg = nt.nodes["Background"]
        bg.inputs["Strength"].default_value = 0.0
        fc = bg.inputs["Strength"].driver_add("default_value")
        fc.driver.type = "SCRIPTED"
        fc.driver.expression = "__import__('math').sqrt(4.0) / 2"  # a Python expression, not a simple one
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(WORK, "scene.blend"))
    if kind == "mix_missing":
        os.remove(os.path.join(WORK, "gone.exr"))
    return {"saved": True}


def sun_checks(src, sun_free, sun):
    """What test_addon.py checks of a split (numpy, texel-centre sums):
    per channel the removed light's cosine integral at the light's direction
    against sun.json's E, and the brightest sun-free texel within one
    diameter against the brightest 1 to 3 diameters away (luminance)."""
    h, w = src.shape[:2]
    lat = (0.5 - (np.arange(h) + 0.5) / h) * np.pi
    phi = (0.5 - (np.arange(w) + 0.5) / w) * 2 * np.pi
    d = np.stack([np.cos(lat)[:, None] * np.cos(phi)[None, :], np.cos(lat)[:, None] * np.sin(phi)[None, :],
                  np.repeat(np.sin(lat)[:, None], w, 1)], -1)
    omega = (2 * np.pi / w) * (np.sin(np.pi / 2 - np.pi * np.arange(h) / h) - np.sin(np.pi / 2 - np.pi * (np.arange(h) + 1) / h))
    out = {"texels_changed": int(np.count_nonzero(np.any(src[..., :3] != sun_free, -1)))}
    if not sun.get("found"):
        return out
    cosd = np.clip(d @ np.asarray(sun["direction"]), 0, None)
    removed = ((src[..., :3].astype(np.float64) - sun_free) * (cosd * omega[:, None])[..., None]).sum((0, 1))
    out["removed_cosine"] = removed.tolist()
    ang = np.degrees(np.arccos(np.clip(d @ np.asarray(sun["direction"]), -1, 1)))
    dia = max(sun["angular_diameter_deg"], 180.0 / h)
    lum = sun_free @ np.array([0.2126, 0.7152, 0.0722])
    out["inner_max"] = float(lum[ang < dia].max())
    out["ring_max"] = float(lum[(ang >= dia) & (ang <= 3 * dia)].max())
    out["negative"] = int(np.count_nonzero(sun_free < 0))
    return out


def nishita_world(disc):
    world = bpy.data.worlds.new("nishita %s" % disc)
    if not ALWAYS_NODES:
        world.use_nodes = True
    sky = world.node_tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "NISHITA" if "NISHITA" in {e.identifier for e in
                                              bpy.types.ShaderNodeTexSky.bl_rna.properties["sky_type"].enum_items} \
        else "MULTIPLE_SCATTERING"
    sky.sun_disc = disc
    world.node_tree.links.new(sky.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    return world


def case_sun_nishita(args):
    """A Nishita sky (every setting at its default: the sun 15 degrees up),
    with and without its sun disc, rendered by Cycles as the add-on renders
    a world (1024 x 512, 16 samples; cached in CACHE, it takes half a minute
    here), then split (iblbake_core.split_sun)."""
    core = native.load()
    cache = args["cache"]
    os.makedirs(cache, exist_ok=True)
    res = {}
    for disc in (True, False):
        path = os.path.join(cache, "nishita_1024_16_%s_%s.exr" % ("disc" if disc else "nodisc",
                                                                  "_".join(map(str, bpy.app.version))))
        if not os.path.isfile(path):
            pixels, _ = world_reader.render_world(nishita_world(disc), 1024, 16)
            core.write_exr(path + ".tmp.exr", np.ascontiguousarray(pixels, dtype=np.float32))
            os.replace(path + ".tmp.exr", path)
        src = core.read_image(path)
        sun_free, sun = core.split_sun(src)
        res["disc" if disc else "nodisc"] = {"sun": sun, "checks": sun_checks(src, sun_free, sun), "path": path}
    return res


def case_sun_lamp(args):
    """sunset.exr as the world, baked with Sun: Split; the panel's sentence;
    Add Sun Lamp, twice (the second updates the first); the lamp as made."""
    scene = empty_scene()
    image_world(args["hdri"])
    res = bake(os.path.join(WORK, "out"), sun="split", auto_skip=False, mip_count=2, lut=False)
    from iblbake import outputs, state
    from iblbake.core import describe
    sun = state.last(scene.name).sun
    res["sun"] = sun
    res["sentence"] = describe.sun_sentence(sun)
    res["poll"] = bpy.ops.iblbake.add_sun_lamp.poll()
    res["ops"] = [sorted(bpy.ops.iblbake.add_sun_lamp()), sorted(bpy.ops.iblbake.add_sun_lamp())]
    lamps = [o for o in scene.objects if o.type == "LIGHT"]
    res["lamps"] = len(lamps)
    obj = bpy.data.objects[outputs.SUN_LAMP]
    minus_z = obj.matrix_world.to_3x3() @ mathutils.Vector((0, 0, -1))
    res["lamp"] = {"type": obj.data.type, "energy": obj.data.energy, "color": list(obj.data.color),
                   "angle_deg": math.degrees(obj.data.angle), "shines_along": list(minus_z),
                   "bake": obj.get("iblbake_bake")}
    # A bake without the split: the panel says nothing of a sun, and no lamp can be added.
    res["off"] = bake(os.path.join(WORK, "off"), sun="off")
    res["off_sentence"] = describe.sun_sentence(state.last(scene.name).sun)
    return res


CASES = {name[5:]: fn for name, fn in list(globals().items()) if name.startswith("case_")}

if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:]
    case, WORK = argv[0], argv[1]
    kv = dict(a.split("=", 1) for a in argv[2:])
    os.makedirs(WORK, exist_ok=True)
    result = CASES[case](kv)
    with open(os.path.join(WORK, "result.json"), "w") as f:
        json.dump(result, f, indent=1)
