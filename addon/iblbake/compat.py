"""What differs between the Blender versions the add-on runs on (3.4 to 5.x),
in one place."""
import bpy

# Blender 5.0: every world and material is a node tree; `use_nodes` is
# deprecated (reading or setting it warns) and always True.
ALWAYS_NODES = bpy.app.version >= (5, 0, 0)


def uses_nodes(idblock) -> bool:
    """Whether a world or material is shaded by its node tree."""
    if idblock.node_tree is None:
        return False
    return True if ALWAYS_NODES else bool(idblock.use_nodes)
