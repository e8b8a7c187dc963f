"""Reads the scene's renderable materials into core.needs Lobes (bpy side of
the skip rules; the rules themselves are in core/needs.py).

It errs towards baking: every object the render can show counts (hidden in
the viewport or not, on any view layer), with the materials of collection
and particle instances and of Geometry Nodes' Set Material nodes; muted
nodes pass their first shader through, as Blender does."""
from typing import List, Tuple

from .compat import uses_nodes
from .core.needs import FULL, Lobe, node_lobes, principled_lobes

SURFACE_TYPES = frozenset({"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD", "VOLUME"})
# Blender's default surface (no material): a grey Principled at roughness 0.5.
DEFAULT_LOBES = principled_lobes("(no material)", (0.5, 0.5), (0.0, 0.0), (0.5, 0.5))


def socket_range(node, *names) -> Tuple[float, float]:
    """A socket's value as a range: linked sockets (textures, ramps, maths)
    count as the full range. The first of `names` that exists is read
    (socket names differ between Blender versions); (0, 0) when none does."""
    for name in names:
        sock = node.inputs.get(name)
        if sock is None:
            continue
        if sock.is_linked:
            return FULL
        v = float(sock.default_value)
        return (v, v)
    return (0.0, 0.0)


def _through_muted(node, from_socket):
    """The input a muted node passes to `from_socket` (its internal link)."""
    for link in node.internal_links:
        if link.to_socket == from_socket:
            return link.from_socket
    return None


def _upstream_shaders(sock, seen):
    """Shader nodes feeding `sock`, through mixes, adds, reroutes, muted nodes and groups."""
    for link in sock.links:
        if not link.is_valid or link.is_muted:
            continue
        node = link.from_node
        if node.mute:
            inner = _through_muted(node, link.from_socket)
            if inner is not None:
                yield from _upstream_shaders(inner, seen)
            continue
        if node in seen:
            continue
        seen.add(node)
        if node.bl_idname == "NodeReroute":
            yield from _upstream_shaders(node.inputs[0], seen)
        elif node.bl_idname in ("ShaderNodeMixShader", "ShaderNodeAddShader"):
            for s in node.inputs:
                if s.type == "SHADER":
                    yield from _upstream_shaders(s, seen)
        elif node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
            outs = [n for n in node.node_tree.nodes if n.bl_idname == "NodeGroupOutput"]
            out = next((n for n in outs if n.is_active_output), outs[0] if outs else None)
            sock_out = out.inputs.get(link.from_socket.name) if out else None
            if sock_out is not None:
                yield from _upstream_shaders(sock_out, seen)
        else:
            yield node


def _principled(node, src):
    rough = socket_range(node, "Roughness")
    if socket_range(node, "Anisotropic")[1] > 0.0:
        rough = (0.0, rough[1])  # anisotropy narrows the lobe along one axis
    trans = socket_range(node, "Transmission", "Transmission Weight")
    if trans[1] > 0.0 and "Transmission Roughness" in node.inputs:  # 3.x: its own roughness
        tr = socket_range(node, "Transmission Roughness")
        rough = (min(rough[0], tr[0]), max(rough[1], tr[1]))
    return principled_lobes(src, rough, socket_range(node, "Metallic"),
                            socket_range(node, "Specular", "Specular IOR Level"), trans,
                            socket_range(node, "Clearcoat", "Coat Weight"),
                            socket_range(node, "Clearcoat Roughness", "Coat Roughness"))


def node_tree_lobes(tree, name) -> List[Lobe]:
    """Lobes of every shader reaching any Material Output (EEVEE's and
    Cycles' alike: the union errs towards baking)."""
    lobes = []
    seen = set()
    for out in (n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"):
        for node in _upstream_shaders(out.inputs["Surface"], seen):
            src = "%s / %s" % (name, node.name)
            if node.bl_idname == "ShaderNodeBsdfPrincipled":
                lobes += _principled(node, src)
                continue
            rough = socket_range(node, "Roughness") if "Roughness" in node.inputs else FULL
            if getattr(node, "distribution", "") == "SHARP":
                rough = (0.0, 0.0)
            if socket_range(node, "Anisotropy")[1] > 0.0:
                rough = (0.0, rough[1])
            kind = node.bl_idname
            if kind == "ShaderNodeBsdfToon" and getattr(node, "component", "") == "GLOSSY":
                kind = "ShaderNodeBsdfGlossy"
                rough = FULL
            lobes += node_lobes(kind, src, rough)
    return lobes


def material_lobes(mat) -> List[Lobe]:
    if mat is None:
        return list(DEFAULT_LOBES)
    if not uses_nodes(mat):
        return principled_lobes(mat.name, (mat.roughness,) * 2, (mat.metallic,) * 2, (mat.specular_intensity,) * 2)
    return node_tree_lobes(mat.node_tree, mat.name)


def _node_group_materials(tree, seen_trees):
    """Materials Geometry Nodes may assign (Set Material and friends), recursively."""
    if tree is None or tree in seen_trees:
        return
    seen_trees.add(tree)
    for node in tree.nodes:
        for sock in node.inputs:
            if sock.type == "MATERIAL" and sock.default_value is not None:
                yield sock.default_value
        if getattr(node, "node_tree", None) is not None:
            yield from _node_group_materials(node.node_tree, seen_trees)


def _object_materials(obj, seen_objects, instanced=False):
    """(surfaces, materials) an object can show in a render, with its
    instances (an instanced object shows even when hidden itself)."""
    if obj in seen_objects or (obj.hide_render and not instanced):
        return
    seen_objects.add(obj)
    if obj.type in SURFACE_TYPES:
        mats = [slot.material for slot in obj.material_slots] or [None]
        for mod in obj.modifiers:
            if mod.type == "NODES" and mod.show_render:
                mats += list(_node_group_materials(mod.node_group, set()))
        yield obj, mats
    if obj.instance_type == "COLLECTION" and obj.instance_collection is not None:
        for inner in obj.instance_collection.all_objects:
            yield from _object_materials(inner, seen_objects, True)
    for psys in getattr(obj, "particle_systems", []):
        s = psys.settings
        if s.render_type == "OBJECT" and s.instance_object is not None:
            yield from _object_materials(s.instance_object, seen_objects, True)
        elif s.render_type == "COLLECTION" and s.instance_collection is not None:
            for inner in s.instance_collection.all_objects:
                yield from _object_materials(inner, seen_objects, True)


def _render_hidden_collections(scene):
    hidden = set()

    def walk(coll, parent_hidden):
        h = parent_hidden or coll.hide_render
        if h:
            hidden.add(coll)
        for child in coll.children:
            walk(child, h)
    walk(scene.collection, False)
    return hidden


def renderable_objects(scene):
    """Objects the render can show: not hidden for render themselves nor by
    every collection they are in (viewport hiding and view layers ignored)."""
    hidden = _render_hidden_collections(scene)
    for obj in scene.objects:
        if obj.hide_render:
            continue
        if obj.users_collection and all(c in hidden for c in obj.users_collection):
            continue
        yield obj


def scene_lobes(scene) -> Tuple[List[Lobe], int]:
    """(lobes of every material the render can show, number of surfaces)."""
    lobes, seen_mats, seen_objects, count = [], set(), set(), 0
    for top in renderable_objects(scene):
        for _obj, mats in _object_materials(top, seen_objects):
            count += 1
            for mat in mats:
                key = mat.as_pointer() if mat is not None else 0
                if key in seen_mats:
                    continue
                seen_mats.add(key)
                lobes += material_lobes(mat)
    return lobes, count
