"""Bake worlds' image-based lighting with iblbake's add-on in headless Blender.

  blender -b scene.blend --python blender_scripts/bake_world.py -- --out DIR [options]
      the open file's scene world -> DIR
  blender -b --factory-startup --python blender_scripts/bake_world.py -- --hdri world.exr --out DIR
      an HDRI file, set up as the world's Environment Texture -> DIR
  blender -b --factory-startup --python blender_scripts/bake_world.py -- --batch a.blend b.hdr DIR/ ... --out OUT
      each .blend file's world, or each image as a world -> OUT/<name>, with OUT/index.json and index.html
      (--list FILE: sources from a file; --shard I/N: every N-th world, for a farm; docs/farm.md;
      --jobs N: up to N worlds baked at once while Blender reads the next; a progress bar on a terminal)

Exits 1 with the reason on stderr when any bake fails (a batch bakes the
others first); an earlier bake in a folder survives a failed one. A bake
replaces the folder's earlier bake, as scripts expect, and prints what it
removed (levels, the irradiance, an engine's folder, a bake of another world).
"""
import argparse
import math
import os
import sys
import time
from pathlib import Path

import bpy


class Usage(Exception):
    """A wrong command line (exit code 1, like every other failure)."""


class Parser(argparse.ArgumentParser):
    def error(self, message):
        raise Usage(message)


def finite(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("must be a finite number, got %r" % text)
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError("must be a finite number, got %s" % text)
    return v


def positive_int(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("must be a whole number, got %r" % text)
    if not 1 <= v <= 64:
        raise argparse.ArgumentTypeError("must be 1 to 64, got %d" % v)
    return v


def addon_module(name):
    """A module of the loaded add-on ("iblbake" or "bl_ext.<repo>.iblbake")."""
    import importlib
    return importlib.import_module(bpy.types.IBLBAKE_OT_bake.__module__.rsplit(".", 1)[0] + "." + name)


def option_arg(row):
    """argparse's type of a row of the options table (core/options.py): the
    value checked as the add-on and the CLI check it, before it reaches a
    Blender property (which would clamp it silently)."""
    table = addon_module("core.options")

    def convert(text):
        try:
            if row["kind"] == "int":
                value = int(text)
            elif row["kind"] == "float":
                value = float(text)
            elif row["kind"] == "list":
                value = [n.strip() for n in text.split(",") if n.strip()]
            else:
                value = text
            return table.check(row, value)
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e))
    return convert


def parse_args(argv):
    p = Parser(prog="bake_world.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output folder (a batch: the parent of one folder per input)")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--hdri", help="bake this image as the world instead of the open file's world")
    src.add_argument("--batch", nargs="*", metavar="FILE",
                     help=".blend files, images and folders of them, one bake each into OUT/<name>/")
    p.add_argument("--list", action="append", metavar="FILE",
                   help="--batch: a file naming sources, one a line ('#' comments); repeatable")
    p.add_argument("--shard", metavar="I/N", default="", help="--batch: bake worlds I, I+N, ... (0 <= I < N)")
    p.add_argument("--jobs", type=positive_int, default=1,
                   help="--batch: bake up to N worlds at once while Blender reads the next (default 1)")
    p.add_argument("--scene", help="scene to bake (default: the active one)")
    p.add_argument("--strength", type=finite, default=1.0, help="--hdri/--batch images: Background Strength")
    p.add_argument("--rotation-z", type=finite, default=0.0, help="--hdri/--batch images: Mapping rotation, degrees")
    p.add_argument("--no-auto-skip", action="store_true", help="bake everything, whatever the materials use")
    p.add_argument("--force", action="store_true", help="bake even when nothing changed since the last bake")
    # Every option of the table (core/options.py), as the CLI spells it.
    table = addon_module("core.options")
    for row in table.rows():
        flag, name = table.cli_flag(row), row["name"]
        if row["kind"] == "bool":
            off = row["default"] and flag.startswith("--no-")
            text = row["help"][len("also "):] if row["help"].startswith("also ") else row["help"]
            p.add_argument(flag, dest=name, action="store_const", const=not row["default"],
                           help=("do not " + text) if off else row["help"])
            continue
        extra = {}
        if row["kind"] == "list":
            extra = dict(action="append", metavar="NAME")  # repeat or comma-separate
        elif row.get("choices"):
            extra = dict(metavar="|".join(c["value"] for c in row["choices"]))
        default = ",".join(row["default"]) if isinstance(row["default"], list) else str(row["default"])
        names = ": " + ", ".join(c["value"] for c in row["choices"]) if row["kind"] == "list" else ""
        p.add_argument(flag, dest=name, type=option_arg(row),
                       help="%s%s (default %s)" % (row["help"], names, default or "none"), **extra)
    args = p.parse_args(argv)
    if (args.list or args.shard or args.jobs != 1) and args.batch is None:
        raise Usage("--list, --shard and --jobs go with --batch")
    if args.batch == [] and not args.list:
        raise Usage("--batch needs files or folders, or --list FILE")
    for row in table.rows():  # a list given several times: one list
        value = getattr(args, row["name"])
        if row["kind"] == "list" and value is not None:
            setattr(args, row["name"], [n for item in value for n in item])
    try:  # what ties options together (an empty --format), checked as the add-on checks it
        settings = addon_module("core.settings").BakeSettings(out_dir=args.out)
        for row in table.rows():
            if getattr(args, row["name"]) is not None and row["name"] != "presets":
                setattr(settings, row["name"], getattr(args, row["name"]))
        settings.validate()
    except ValueError as e:
        raise Usage(str(e))
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
    """The scene's own settings (started from the preferences' defaults if it
    has none yet), with the command line's options on top."""
    props = scene.iblbake
    addon_module("properties").initialise_options(scene)
    for row in addon_module("core.options").rows():
        value = getattr(args, row["name"])
        if value is None or row["name"] == "presets":  # presets: the operator's override below
            continue
        setattr(props, row["name"], set(value) if row["kind"] == "list" else value)
    # An image alone has no materials to inspect: bake everything.
    props.auto_skip = not (args.no_auto_skip or image_only)
    props.force = args.force
    props.output_dir = os.path.abspath(out_dir)


def chosen_scene(args, out_dir: str, image=None):
    """The scene to bake, its world set to `image` when given, configured."""
    scene = bpy.data.scenes.get(args.scene) if args.scene else bpy.context.scene
    if scene is None:
        raise RuntimeError("no scene named %r" % args.scene)
    if image is not None:
        scene.world = hdri_world(image, args.strength, args.rotation_z)
    configure(scene, args, out_dir, image is not None)
    return scene


def bake_scene(args, out_dir: str, image=None):
    scene = chosen_scene(args, out_dir, image)
    override = {} if args.presets is None else {"override_presets": True, "presets": ",".join(args.presets)}
    with bpy.context.temp_override(scene=scene):
        result = bpy.ops.iblbake.bake(**override)
    if "FINISHED" not in result:
        raise RuntimeError(scene.iblbake.last_error or "the bake did not finish")
    print("iblbake: %s" % scene.iblbake.last_status, flush=True)
    last = addon_module("state").last(scene.name)
    return last.outcome or "baked", last.content_hash


def run_batch(args):
    """The CLI's batch machinery (core/batch.py over iblbake_core): the same
    worlds, folder names, shards and index; each world baked through Blender.
    Returns the failures."""
    batch = addon_module("core.batch")
    if args.preview is None:
        args.preview = True  # the index's gallery shows each world's preview sheet

    operators = addon_module("operators")

    def in_words(call, *args):
        """call(*args); any failure as a RuntimeError in the operator's words."""
        try:
            return call(*args)
        except Exception as e:
            raise RuntimeError(str(operators._words(e))) from e

    def bake_one(world):
        """Blender's half on this thread (open the file or make the image's
        world, read or render it); returns the bake's bpy-free rest."""
        item = world["source"]
        image = None
        if item.lower().endswith(batch.BLEND_SUFFIX):
            if not os.path.isfile(item):
                raise RuntimeError("no .blend file at %s" % item)
            bpy.ops.wm.open_mainfile(filepath=os.path.abspath(item))
        else:
            bpy.ops.wm.read_homefile(use_empty=True)
            image = item
        scene = chosen_scene(args, os.path.join(args.out, world["name"]), image)
        with bpy.context.temp_override(scene=scene):
            run = in_words(operators.headless_bake, bpy.context, scene, args.presets)

        def finish(progress, say):
            report = in_words(run, progress, say)
            return report.status, report.content_hash
        return finish

    start = time.perf_counter()
    worlds = batch.worlds(args.batch, args.list or [], args.shard)
    entries = batch.run(worlds, args.out, bake_one, args.shard, log=lambda line: print("iblbake: " + line, flush=True),
                        jobs=args.jobs, tty=sys.stderr.isatty())
    count = {s: sum(e["status"] == s for e in entries) for s in ("baked", "unchanged", "failed")}
    print("iblbake: batch: %(baked)d baked, %(unchanged)d unchanged, %(failed)d failed" % count
          + " of %d worlds in %.1f s" % (len(entries), time.perf_counter() - start), flush=True)
    return [(e["source"], e["error"]) for e in entries if e["status"] == "failed"]


def main(argv):
    load_addon()
    args = parse_args(argv)
    args.out = os.path.expanduser(args.out)  # a quoted '~/x' is the user's folder, as the shell would have made it
    failures = []
    if args.batch is not None:
        failures = run_batch(args)
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
