"""Reads the visible objects' materials into core.needs Lobes (bpy side of
the skip rules; the rules themselves are in core/needs.py)."""
from typing import List, Tuple

from .core.needs import FULL, Lobe, node_lobes, principled_lobes

SURFACE_TYPES = frozenset({"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD"})
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


def _upstream_shaders(sock, seen):
    """Shader nodes feeding `sock`, through mixes, adds, reroutes and groups."""
    for link in sock.links:
        if not link.is_valid or link.is_muted:
            continue
        node = link.from_node
        if node in seen:
            continue
        seen.add(node)
        if node.mute:
            continue
        if node.bl_idname == "NodeReroute":
            yield from _upstream_shaders(node.inputs[0], seen)
        elif node.bl_idname in ("ShaderNodeMixShader", "ShaderNodeAddShader"):
            for s in node.inputs:
                if s.type == "SHADER":
                    yield from _upstream_shaders(s, seen)
        elif node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
            out = next((n for n in node.node_tree.nodes if n.bl_idname == "NodeGroupOutput" and n.is_active_output),
                       None)
            sock_out = out.inputs.get(link.from_socket.name) if out else None
            if sock_out is not None:
                yield from _upstream_shaders(sock_out, seen)
            else:
                yield node
        else:
            yield node


def material_lobes(mat) -> List[Lobe]:
    if mat is None:
        return list(DEFAULT_LOBES)
    name = mat.name
    if not mat.use_nodes or mat.node_tree is None:
        return principled_lobes(name, (mat.roughness,) * 2, (mat.metallic,) * 2, (mat.specular_intensity,) * 2)
    outputs = [n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    out = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if out is None:
        return []  # renders black: reads nothing
    lobes = []
    for node in _upstream_shaders(out.inputs["Surface"], set()):
        src = "%s / %s" % (name, node.name)
        if node.bl_idname == "ShaderNodeBsdfPrincipled":
            lobes += principled_lobes(
                src, socket_range(node, "Roughness"), socket_range(node, "Metallic"),
                socket_range(node, "Specular", "Specular IOR Level"),
                socket_range(node, "Transmission", "Transmission Weight"),
                socket_range(node, "Clearcoat", "Coat Weight"),
                socket_range(node, "Clearcoat Roughness", "Coat Roughness"))
        else:
            rough = socket_range(node, "Roughness") if "Roughness" in node.inputs else FULL
            if getattr(node, "distribution", "") == "SHARP":
                rough = (0.0, 0.0)
            lobes += node_lobes(node.bl_idname, src, rough)
    return lobes


def visible_surfaces(scene, view_layer=None):
    view_layer = view_layer or scene.view_layers[0]
    for obj in scene.objects:
        if obj.type in SURFACE_TYPES and not obj.hide_render and obj.visible_get(view_layer=view_layer):
            yield obj


def scene_lobes(scene, view_layer=None) -> Tuple[List[Lobe], int]:
    """(lobes of every material on a visible surface, number of such surfaces)."""
    lobes, seen, count = [], set(), 0
    for obj in visible_surfaces(scene, view_layer):
        count += 1
        mats = [slot.material for slot in obj.material_slots] or [None]
        for mat in mats:
            key = mat.name if mat is not None else None
            if key in seen:
                continue
            seen.add(key)
            lobes += material_lobes(mat)
    return lobes, count
