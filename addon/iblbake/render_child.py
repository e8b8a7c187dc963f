"""Renders a world with Cycles in a child Blender for the UI's bake
(world_reader.ChildRender starts it; the open Blender stays live and Esc
ends this process):

  blender -b --factory-startup --python render_child.py -- WORLD.blend NAME WIDTH SAMPLES FRAME OUT.exr NOTES.json

WORLD.blend holds the world (and what it uses); an empty path renders no
world. The render is world_reader.render_world_to_file, the same code the
headless bake runs in-process."""
import json
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from iblbake import world_reader  # noqa: E402  (the package folder is named iblbake in every install)
from iblbake.core.worker import lower_priority  # noqa: E402


def _print_samples(stats, *_):
    """Blender 5.x no longer prints Cycles' progress in background mode; its
    render_stats handler still gets it ("... | Sample 5/32"). Printed (and
    flushed) for world_reader.ChildRender, which reads the samples from this
    process's output to move the panel's progress bar. Earlier versions pass
    None here and print the line themselves."""
    if isinstance(stats, str) and "Sample" in stats:
        print(stats, flush=True)


def main(argv):
    lower_priority(all_threads=True)  # the open Blender's drawing first (Cycles' threads, made later, inherit it)
    bpy.app.handlers.render_stats.append(_print_samples)
    blend, name, width, samples, frame, out, notes_path = argv
    world = None
    if blend:
        with bpy.data.libraries.load(blend) as (src, dst):
            dst.worlds = [name]
        world = dst.worlds[0]
    notes = world_reader.render_world_to_file(world, int(width), int(samples), int(frame), out)
    with open(notes_path, "w") as f:
        json.dump(notes, f)


main(sys.argv[sys.argv.index("--") + 1:])
