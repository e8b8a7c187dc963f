from blender_helpers import case  # noqa: F401  (the fixture)
