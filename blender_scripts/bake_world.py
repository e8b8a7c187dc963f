"""Bake worlds' image-based lighting with iblbake's add-on in headless Blender.

  blender -b scene.blend --python blender_scripts/bake_world.py -- --out DIR [options]
      the open file's scene world -> DIR
  blender -b --factory-startup --python blender_scripts/bake_world.py -- --hdri world.exr --out DIR
      an HDRI file, set up as the world's Environment Texture -> DIR
  blender -b --factory-startup --python blender_scripts/bake_world.py -- --batch a.blend b.hdr ... --out DIR
      each .blend file's world, or each image as a world -> DIR/<name>

Exits 1 with the reason on stderr when any bake fails (a batch bakes the
others first); an earlier bake in a folder survives a failed one.
"""
import argparse
import math
import os
import sys
import time
from pathlib import Path

import bpy

BLEND_SUFFIXES = (".blend",)


class Usage(Exception):
    """A wrong command line (exit code 1, like every other failure)."""


class Parser(argparse.ArgumentParser):
    def error(self, message):
        raise Usage(message)


def positive(text):
    v = int(text)
    if v < 1:
        raise argparse.ArgumentTypeError("must be at least 1, got %s" % text)
    return v


def count(text):
    v = int(text)
    if v < 0:
        raise argparse.ArgumentTypeError("must be 0 (automatic) or more, got %s" % text)
    return v


def finite(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("must be a finite number, got %r" % text)
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError("must be a finite number, got %s" % text)
    return v


# Options checked by the native module exactly as the CLI checks them, before
# they reach Blender's properties (which would clamp them silently).
NATIVE_CHECKED = (("face_size", "face_size"), ("irradiance_size", "irradiance_size"), ("mips", "mip_count"),
                  ("lut_size", "lut_size"), ("exposure", "exposure"))


def check_native_options(args):
    import importlib
    package = bpy.types.IBLBAKE_OT_bake.__module__.rsplit(".", 1)[0]  # "iblbake" or "bl_ext.<repo>.iblbake"
    native = importlib.import_module(package + ".core.native")
    settings = importlib.import_module(package + ".core.settings")
    opts = {name: getattr(args, arg) for arg, name in NATIVE_CHECKED if getattr(args, arg) is not None}
    try:
        native.load().check_options(**opts)
        s = settings.BakeSettings(out_dir=args.out)
        for arg in ("render_width", "render_samples"):
            if getattr(args, arg) is not None:
                setattr(s, arg, getattr(args, arg))
        s.validate()
    except ValueError as e:
        raise Usage(str(e))


def parse_args(argv):
    p = Parser(prog="bake_world.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output folder (a batch: the parent of one folder per input)")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--hdri", help="bake this image as the world instead of the open file's world")
    src.add_argument("--batch", nargs="+", metavar="FILE", help=".blend files and/or images, one bake each")
    p.add_argument("--scene", help="scene to bake (default: the active one)")
    p.add_argument("--face-size", type=positive, help="specular mip 0 face size (default 256)")
    p.add_argument("--irradiance-size", type=positive, help="irradiance face size (default 32)")
    p.add_argument("--mips", type=count, help="specular levels (default 0: full chain)")
    p.add_argument("--lut-size", type=positive, help="BRDF LUT size (default 512)")
    p.add_argument("--lut-model", choices=["karis", "height-correlated", "multiscatter"])
    p.add_argument("--format", default=None, help="exr, png or exr,png (default exr)")
    p.add_argument("--png-encoding", choices=["srgb", "rgbm"])
    p.add_argument("--exposure", type=finite, help="PNG exposure in stops")
    p.add_argument("--render-width", type=positive, help="Cycles lat-long width for procedural worlds (default 1024)")
    p.add_argument("--render-samples", type=positive, help="Cycles samples for procedural worlds (default 16)")
    p.add_argument("--strength", type=finite, default=1.0, help="--hdri/--batch images: Background Strength")
    p.add_argument("--rotation-z", type=finite, default=0.0, help="--hdri/--batch images: Mapping rotation, degrees")
    p.add_argument("--no-irradiance", action="store_true")
    p.add_argument("--no-specular", action="store_true")
    p.add_argument("--no-lut", action="store_true")
    p.add_argument("--no-auto-skip", action="store_true", help="bake everything, whatever the materials use")
    p.add_argument("--force", action="store_true", help="bake even when nothing changed since the last bake")
    p.add_argument("--preset", action="append", metavar="NAME",
                   help="engine preset, written into OUT/NAME (repeat or comma-separate): three, khronos, bevy, "
                        "filament, babylon, unity, source; NAME:FORMAT picks a pixel format (docs/export.md). "
                        "Replaces the presets chosen in the scene")
    args = p.parse_args(argv)
    if args.preset is not None:
        args.preset = [n.strip() for item in args.preset for n in item.split(",") if n.strip()]
    return args


def load_addon():
    """The add-on from this checkout when there is one, else the installed one."""
    if hasattr(bpy.types, "IBLBAKE_OT_bake"):
        return
    addon_dir = Path(__file__).resolve().parents[1] / "addon"
    if (addon_dir / "iblbake" / "__init__.py").is_file():
        sys.path.insert(0, str(addon_dir))
        import iblbake
        iblbake.register()
    else:  # an installed add-on ("iblbake") or 4.2+ extension ("bl_ext.<repo>.iblbake")
        import addon_utils
        names = [m.__name__ for m in addon_utils.modules() if m.__name__.split(".")[-1] == "iblbake"]
        if not names or addon_utils.enable(names[0], default_set=True) is None:
            raise RuntimeError("the iblbake add-on is neither in this checkout nor installed")


def hdri_world(path: str, strength: float, rotation_z: float):
    """A world showing `path` as its Environment Texture."""
    if not os.path.isfile(path):
        raise RuntimeError("no image file at %s" % path)
    world = bpy.data.worlds.new(Path(path).stem)
    if bpy.app.version < (5, 0, 0):  # 5.0+: always a node tree (use_nodes deprecated)
        world.use_nodes = True
    nt = world.node_tree
    bg = nt.nodes["Background"]
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(os.path.abspath(path), check_existing=True)
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = strength
    if rotation_z:
        mapping = nt.nodes.new("ShaderNodeMapping")
        coords = nt.nodes.new("ShaderNodeTexCoord")
        mapping.inputs["Rotation"].default_value[2] = rotation_z * 3.141592653589793 / 180.0
        nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    return world


def configure(scene, args, out_dir: str, image_only: bool):
    props = scene.iblbake
    props.use_scene_options = True
    for arg, name in (("face_size", "face_size"), ("irradiance_size", "irradiance_size"), ("mips", "mip_count"),
                      ("lut_size", "lut_size"), ("lut_model", "lut_model"), ("png_encoding", "png_encoding"),
                      ("exposure", "exposure"), ("render_width", "render_width"),
                      ("render_samples", "render_samples")):
        value = getattr(args, arg)
        if value is not None:
            setattr(props, name, value)
    if args.format is not None:
        formats = {f.strip() for f in args.format.split(",") if f.strip()}
        if not formats or formats - {"exr", "png"}:
            raise RuntimeError("--format takes exr, png or exr,png")
        props.write_exr, props.write_png = "exr" in formats, "png" in formats
    props.bake_irradiance = not args.no_irradiance
    props.bake_specular = not args.no_specular
    props.bake_lut = not args.no_lut
    # An image alone has no materials to inspect: bake everything.
    props.auto_skip = not (args.no_auto_skip or image_only)
    props.force = args.force
    props.output_dir = os.path.abspath(out_dir)


def bake_scene(args, out_dir: str, image=None):
    scene = bpy.data.scenes.get(args.scene) if args.scene else bpy.context.scene
    if scene is None:
        raise RuntimeError("no scene named %r" % args.scene)
    if image is not None:
        scene.world = hdri_world(image, args.strength, args.rotation_z)
    configure(scene, args, out_dir, image is not None)
    override = {} if args.preset is None else {"override_presets": True, "presets": ",".join(args.preset)}
    with bpy.context.temp_override(scene=scene):
        result = bpy.ops.iblbake.bake(**override)
    if "FINISHED" not in result:
        raise RuntimeError(scene.iblbake.last_error or "the bake did not finish")
    print("iblbake: %s" % scene.iblbake.last_status, flush=True)


def batch_folders(items, out):
    """One output folder per input, named after its stem; two inputs of one
    name would overwrite each other, so that is refused up front."""
    folders = {}
    for item in items:
        stem = Path(item).stem
        if stem in folders:
            raise Usage("two inputs would bake into %s: %s and %s (rename one, or bake them separately)"
                        % (os.path.join(out, stem), folders[stem], item))
        folders[stem] = item
    return [(item, os.path.join(out, stem)) for stem, item in folders.items()]


def main(argv):
    args = parse_args(argv)
    args.out = os.path.expanduser(args.out)  # a quoted '~/x' is the user's folder, as the shell would have made it
    load_addon()
    check_native_options(args)
    failures = []
    if args.batch:
        for item, out in batch_folders(args.batch, args.out):
            start = time.perf_counter()
            try:
                if item.lower().endswith(BLEND_SUFFIXES):
                    if not os.path.isfile(item):
                        raise RuntimeError("no .blend file at %s" % item)
                    bpy.ops.wm.open_mainfile(filepath=os.path.abspath(item))
                    bake_scene(args, out)
                else:
                    bpy.ops.wm.read_homefile(use_empty=True)
                    bake_scene(args, out, image=item)
                print("iblbake: %s done in %.2f s" % (item, time.perf_counter() - start), flush=True)
            except Exception as e:  # keep going; report every failure at the end
                failures.append((item, str(e)))
                print("iblbake: error: %s: %s" % (item, e), file=sys.stderr, flush=True)
    else:
        try:
            bake_scene(args, args.out, image=args.hdri)
        except Exception as e:
            failures.append((args.hdri or bpy.data.filepath or "scene", str(e)))
    if failures:
        for item, why in failures:
            print("iblbake: error: %s: %s" % (item, why), file=sys.stderr, flush=True)
        sys.exit(1)


if __name__ == "__main__":
    try:
        main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    except SystemExit:
        raise
    except Usage as e:
        print("iblbake: error: %s (see --help)" % e, file=sys.stderr, flush=True)
        sys.exit(1)
    except BaseException as e:  # a missing add-on or module, anything: never exit 0 on a failure
        print("iblbake: error: %s: %s" % (type(e).__name__, e), file=sys.stderr, flush=True)
        sys.exit(1)
