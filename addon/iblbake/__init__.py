"""iblbake: bake a world's image-based lighting (irradiance, GGX prefiltered
specular, BRDF LUT) from World Properties or `blender -b`. This file only
registers; see operators.py, outputs.py, panel.py, preferences.py,
properties.py, scene_settings.py and the bpy-free core/ package."""

bl_info = {
    "name": "iblbake",
    "author": "iblbake developers",
    "version": (0, 3, 0),
    "blender": (3, 4, 0),
    "location": "Properties > World > Image-Based Lighting",
    "description": "Bake the world into engine-ready IBL: irradiance + SH9, prefiltered specular, BRDF LUT",
    "category": "Lighting",
}

import os
import re
import sys

try:
    import bpy
except ImportError:  # iblbake.core used outside Blender (tests, pipelines): nothing to register
    bpy = None


def python_mismatch(folder=os.path.dirname(os.path.abspath(__file__)), cache_tag=sys.implementation.cache_tag):
    """Why this package's compiled module cannot load in this Python, or "".
    A packaged zip carries iblbake_core built for one Python (its file name says
    which, e.g. cpython-313); a source checkout carries none (the module is
    found in build/native)."""
    tags = sorted({m.group(1) for m in (re.match(r"iblbake_core\.(cpython-(\d)(\d+))", f) for f in os.listdir(folder))
                   if m} if os.path.isdir(folder) else set())
    found = [re.match(r"cpython-(\d)(\d+)", t) for t in tags]
    if not found or cache_tag in tags:
        return ""
    built = ", ".join("%s.%s" % m.groups() for m in found)
    running = re.match(r"cpython-(\d)(\d+)", cache_tag)
    running = "%s.%s" % running.groups() if running else cache_tag
    return ("this iblbake package was built for Python %s, but this Blender runs Python %s: install the "
            "iblbake zip whose name says python%s (build it on the system whose Blender this is)"
            % (built, running, running))


# The submodules need the compiled module (the options table comes from it):
# a module built for another Python is refused in register(), in words.
_MISMATCH = python_mismatch() if bpy is not None else ""
if bpy is not None and not _MISMATCH:
    if "operators" in locals():  # F8 / script reload: re-import the submodules
        import importlib
        # Each module after the ones it imports, so that it binds their new versions.
        for _m in (core.native, core.names, core.options, core.settings, core.needs, core.world,  # noqa: F821
                   core.describe, core.folder, core.pipeline, core.worker, core.job, compat, state,  # noqa: F821
                   properties, world_reader, scene_needs, scene_settings,  # noqa: F821
                   operators, outputs, panel, preferences):  # noqa: F821
            importlib.reload(_m)
    from . import core  # noqa: F401
    from .core import describe  # noqa: F401
    from . import (compat, state, operators, outputs, panel, preferences, properties, scene_needs,  # noqa: F401
                   scene_settings, world_reader)

    _CLASSES = properties.classes + preferences.classes + operators.classes + outputs.classes + panel.classes
    _HANDLERS = properties.HANDLERS + operators.HANDLERS + outputs.HANDLERS + panel.HANDLERS


def register():
    if _MISMATCH:  # refuse before registering anything: Blender shows this and leaves the add-on off
        raise RuntimeError("iblbake: " + _MISMATCH)
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    properties.register_props()
    for handlers, fn in _HANDLERS:
        handlers.append(fn)


def unregister():
    if _MISMATCH:
        return
    for handlers, fn in reversed(_HANDLERS):
        if fn in handlers:
            handlers.remove(fn)
    panel.free_previews()
    properties.unregister_props()
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
