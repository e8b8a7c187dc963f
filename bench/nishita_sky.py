"""blender -b --factory-startup --python bench/nishita_sky.py -- OUT.exr [WIDTH] [SAMPLES]
        [--sun-elevation DEG] [--sun-rotation DEG] [--sun-intensity X]

A benchmark source: Blender's Sky Texture (Nishita, every setting at its
default, sun disc included, unless the options set the sun's elevation,
rotation or intensity) rendered by Cycles to a lat-long through the add-on's
own render path (addon/iblbake/world_reader.render_world: panoramic
equirectangular camera, box pixel filter, no denoising), written as float EXR.
Issue 25's strong, low sun: --sun-elevation 4 (a disc of about
(1e6, 4.7e5, 7e4), reddened by the long path, over a blue sky and a dark
ground)."""
import math
import sys
from pathlib import Path

import bpy
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "addon"))
from iblbake import world_reader  # noqa: E402
from iblbake.core import native  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
argv, options = [], {}
while args:
    if args[0].startswith("--"):
        options[args[0][2:]] = float(args[1])
        args = args[2:]
    else:
        argv.append(args.pop(0))
out = argv[0]
width = int(argv[1]) if len(argv) > 1 else 2048
samples = int(argv[2]) if len(argv) > 2 else 32

world = bpy.data.worlds.new("nishita")
world.use_nodes = True
nt = world.node_tree
bg = nt.nodes["Background"]
sky = nt.nodes.new("ShaderNodeTexSky")
sky.sky_type = "NISHITA"
for key, value in options.items():
    if key == "sun-elevation":
        sky.sun_elevation = math.radians(value)
    elif key == "sun-rotation":
        sky.sun_rotation = math.radians(value)
    elif key == "sun-intensity":
        sky.sun_intensity = value
    else:
        raise SystemExit("unknown option --" + key)
nt.links.new(sky.outputs["Color"], bg.inputs["Color"])
pixels, _ = world_reader.render_world(world, width, samples)
core = native.load()
core.write_exr(out, np.ascontiguousarray(pixels, dtype=np.float32))
print("nishita sky %dx%d, %d samples, %s, peak %s, mean %s -> %s"
      % (pixels.shape[1], pixels.shape[0], samples, options or "defaults",
         pixels.reshape(-1, 3).max(axis=0), pixels.reshape(-1, 3).mean(axis=0), out))
