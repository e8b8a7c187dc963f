"""World Properties > Image-Based Lighting: what will be baked, and the button."""
import bpy
from bpy.app.handlers import persistent

from . import operators, preferences, world_reader
from .core.world import COLOR, IMAGE, RENDER


def _world_line(scene):
    try:
        src = world_reader.classify(scene.world)
    except world_reader.WorldError as e:
        return "ERROR", str(e)
    if src.path == IMAGE:
        extra = []
        if src.mapping is not None and not src.mapping.is_identity():
            rot = src.mapping.to_json()["rotation_degrees"]
            extra.append("rotation %.0f/%.0f/%.0f" % tuple(rot))
        if src.strength != 1.0:
            extra.append("strength %.3g" % src.strength)
        return "IMAGE_DATA", "Image %s%s" % (src.image_name, (" (" + ", ".join(extra) + ")") if extra else "")
    if src.path == COLOR:
        return "COLOR", "Plain colour (%.3g, %.3g, %.3g): closed form" % tuple(src.color)
    return "RENDER_STILL", "Cycles render: %s" % src.why


# The scene analysis, kept between redraws until the scene changes (a redraw
# must not walk every object of a large scene).
_needs_cache = {}


@persistent
def _forget_needs(*_args):
    _needs_cache.clear()


def _needs_lines(context, scene):
    key = (scene.name, scene.iblbake.use_scene_options, scene.iblbake.face_size, scene.iblbake.mip_count,
           scene.iblbake.output_dir)
    if key not in _needs_cache:
        _needs_cache[key] = _compute_needs_lines(context, scene)
    return _needs_cache[key]


def _compute_needs_lines(context, scene):
    try:
        settings = operators.gather_settings(context, scene)
    except Exception as e:  # e.g. no folder yet: still show what the scene needs
        settings = None
        folder = str(e)
    else:
        folder = settings.out_dir
    from .core.settings import BakeSettings
    s = settings or BakeSettings()
    needs = operators.scene_needs_for(scene, s)
    lines = []
    if not needs.analysed:
        lines.append(("INFO", "No visible surfaces: everything is baked"))
    else:
        lines.append(("CHECKMARK" if needs.irradiance else "X", "Irradiance" if needs.irradiance
                      else "No irradiance: " + needs.reasons.get("irradiance", "")))
        if needs.specular:
            lo, hi = needs.roughness
            lines.append(("CHECKMARK", "Specular levels %d-%d of %d (roughness %.2f-%.2f)"
                          % (needs.levels[0], needs.levels[1], s.resolved_mip_count() - 1, lo, hi)))
        else:
            lines.append(("X", "No specular: " + needs.reasons.get("specular", "")))
    return lines, folder


class IBLBAKE_PT_world(bpy.types.Panel):
    bl_label = "Image-Based Lighting"
    bl_idname = "IBLBAKE_PT_world"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        props = scene.iblbake
        icon, text = _world_line(scene)
        layout.label(text=text, icon=icon)
        layout.prop(props, "output_dir")

        box = layout.box()
        box.prop(props, "auto_skip")
        row = box.row(align=True)
        row.prop(props, "bake_irradiance", toggle=True)
        row.prop(props, "bake_specular", toggle=True)
        row.prop(props, "bake_lut", toggle=True)
        if props.auto_skip:
            lines, folder = _needs_lines(context, scene)
            col = box.column(align=True)
            for ic, t in lines:
                col.label(text=t, icon=ic)
        else:
            folder = ""
        if folder:
            layout.label(text="-> " + folder, icon="FILE_FOLDER")

        layout.prop(props, "use_scene_options")
        if props.use_scene_options or preferences.get(context) is None:
            sub = layout.column()
            sub.use_property_split = True
            preferences.draw_options(sub, props)
        layout.prop(props, "force")

        row = layout.row()
        row.scale_y = 1.4
        row.operator(operators.IBLBAKE_OT_bake.bl_idname, icon="WORLD")
        row.operator(operators.IBLBAKE_OT_open_output.bl_idname, text="", icon="FILEBROWSER")
        if props.last_status:
            layout.label(text=props.last_status, icon="ERROR" if props.last_error else "INFO")


classes = (IBLBAKE_PT_world,)
HANDLERS = ((bpy.app.handlers.depsgraph_update_post, _forget_needs), (bpy.app.handlers.load_post, _forget_needs))
