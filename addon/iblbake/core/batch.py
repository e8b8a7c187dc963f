"""A batch of worlds for blender_scripts/bake_world.py --batch, no bpy: the
worlds, their folders and the shard come from the native batch machinery
(iblbake_core.batch_worlds, the CLI's own pipeline/batch), and so does
OUT/index.json + index.html (write_batch_index), so a library baked by the
CLI or by Blender has the same names, shards and gallery. What differs is
the bake of one world (Blender renders or reads it through its world), which
the caller hands in."""
import json
import os
import time
from typing import Callable, List, Sequence, Tuple

from . import native

BLEND_SUFFIX = ".blend"

# bake_one(world) -> (status, content_hash): status "baked" or "unchanged";
# an exception is the world's failure.
BakeOne = Callable[[dict], Tuple[str, str]]


def worlds(inputs: Sequence[str], lists: Sequence[str] = (), shard: str = "") -> List[dict]:
    """[{source, name}] of the batch (.blend files and images; a folder: both
    kinds, sorted), in the CLI's order, names and shard."""
    core = native.load()
    return core.batch_worlds(list(inputs), list(lists), list(core.image_extensions()) + [BLEND_SUFFIX], shard)


def manifest_warnings(folder: str) -> List[str]:
    """The warnings of the bake in `folder` (its manifest's), as the CLI's batch lists them."""
    try:
        with open(os.path.join(folder, "manifest.json")) as f:
            warnings = json.load(f).get("warnings", [])
    except (OSError, ValueError, AttributeError):
        return []
    return [w for w in warnings if isinstance(w, str)] if isinstance(warnings, list) else []


def run(items: List[dict], out: str, bake_one: BakeOne, shard: str = "", log=print) -> List[dict]:
    """Bakes each world with bake_one, one line each ("[3/12] baked forest in
    1.20 s", then its warnings), keeps going after a failure and writes the
    index (with each world's warnings, from its manifest). Returns the
    index's entries."""
    core = native.load()
    entries = []
    for k, world in enumerate(items, 1):
        start = time.perf_counter()
        entry = dict(world, status="failed", content_hash="", error="", seconds=0.0, preview=False, warnings=[])
        try:
            entry["status"], entry["content_hash"] = bake_one(world)
            entry["warnings"] = manifest_warnings(os.path.join(out, world["name"]))
        except Exception as e:  # keep going; every failure is in the index and the summary
            entry["error"] = str(e) or type(e).__name__
        entry["seconds"] = time.perf_counter() - start
        entry["preview"] = os.path.isfile(os.path.join(out, world["name"], "preview.png"))
        entries.append(entry)
        took = " in %.2f s" % entry["seconds"] if entry["status"] == "baked" else ""
        log("[%d/%d] %s %s%s%s" % (k, len(items), entry["status"], world["name"], took,
                                  ": " + entry["error"] if entry["error"] else ""))
        for warning in entry["warnings"]:
            log("  warning: %s: %s" % (world["name"], warning))
    os.makedirs(out, exist_ok=True)
    core.write_batch_index(out, entries, shard)
    return entries
