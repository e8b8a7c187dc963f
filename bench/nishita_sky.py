"""blender -b --factory-startup --python bench/nishita_sky.py -- OUT.exr [WIDTH] [SAMPLES]

A benchmark source: Blender's Sky Texture (Nishita, every setting at its
default, sun disc included) rendered by Cycles to a lat-long through the
add-on's own render path (addon/iblbake/world_reader.render_world: panoramic
equirectangular camera, box pixel filter, no denoising), written as float EXR."""
import sys
from pathlib import Path

import bpy
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "addon"))
from iblbake import world_reader  # noqa: E402
from iblbake.core import native  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
out = argv[0]
width = int(argv[1]) if len(argv) > 1 else 2048
samples = int(argv[2]) if len(argv) > 2 else 32

world = bpy.data.worlds.new("nishita")
world.use_nodes = True
nt = world.node_tree
bg = nt.nodes["Background"]
sky = nt.nodes.new("ShaderNodeTexSky")
sky.sky_type = "NISHITA"
nt.links.new(sky.outputs["Color"], bg.inputs["Color"])
pixels, _ = world_reader.render_world(world, width, samples)
core = native.load()
core.write_exr(out, np.ascontiguousarray(pixels, dtype=np.float32))
print("nishita sky %dx%d, %d samples, peak %.4g, mean %.4g -> %s"
      % (pixels.shape[1], pixels.shape[0], samples, float(pixels.max()), float(pixels.mean()), out))
