"""iblbake: bake a world's image-based lighting (irradiance, GGX prefiltered
specular, BRDF LUT) from World Properties or `blender -b`. This file only
registers; see operators.py, panel.py, preferences.py, properties.py and the
bpy-free core/ package."""

bl_info = {
    "name": "iblbake",
    "author": "iblbake developers",
    "version": (0, 2, 0),
    "blender": (3, 4, 0),
    "location": "Properties > World > Image-Based Lighting",
    "description": "Bake the world into engine-ready IBL: irradiance + SH9, prefiltered specular, BRDF LUT",
    "category": "Lighting",
}

try:
    import bpy
except ImportError:  # iblbake.core used outside Blender (tests, pipelines): nothing to register
    bpy = None

if bpy is not None:
    if "operators" in locals():  # F8 / script reload: re-import the submodules
        import importlib
        for _m in (core.settings, core.needs, core.world, core.native, core.pipeline, core.job,  # noqa: F821
                   core.describe, state, properties, preferences, world_reader, scene_needs,  # noqa: F821
                   operators, panel):  # noqa: F821
            importlib.reload(_m)
    from . import core  # noqa: F401
    from .core import describe  # noqa: F401
    from . import state, operators, panel, preferences, properties, scene_needs, world_reader  # noqa: F401

    _CLASSES = properties.classes + preferences.classes + operators.classes + panel.classes
    _HANDLERS = operators.HANDLERS + panel.HANDLERS


def register():
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    properties.register_props()
    for handlers, fn in _HANDLERS:
        handlers.append(fn)


def unregister():
    for handlers, fn in reversed(_HANDLERS):
        if fn in handlers:
            handlers.remove(fn)
    panel.free_previews()
    properties.unregister_props()
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
