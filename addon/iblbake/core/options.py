"""The options a bake of a Blender world takes, as one table: the native
module's rows offered in Blender (iblbake_core.options(), the table the CLI
is made from too) and the add-on's own (how a procedural world is rendered),
in the same form. From it come BakeSettings' fields (settings.py), the
add-on's properties (properties.py), the panel's option rows (panel.py) and
blender_scripts/bake_world.py's argparse. A new option is one row: in the
native table (native/src/bake/options.cpp, native/src/pipeline/options.cpp)
or, for Blender alone, in ADDON_ROWS below. bpy-free."""
from . import native

# The add-on's own options (iblbake_core.options()'s form).
ADDON_ROWS = [
    dict(name="render_width", kind="int", label="Render Width", default=1024, min=16, max=16384,
         cli="--render-width", cli_negated=False, blender=True, method=None, note="", open_choices=False,
         help="worlds that are not an image or a plain colour are rendered by Cycles to a lat-long of this "
              "width (height is half)"),
    dict(name="render_samples", kind="int", label="Render Samples", default=16, min=1, max=4096,
         cli="--render-samples", cli_negated=False, blender=True, method=None, note="", open_choices=False,
         help="Cycles samples per pixel for that render (denoising is off)"),
]

# Where Blender differs from the CLI's defaults: the panel writes the preview sheet.
BLENDER_DEFAULTS = {"preview": True}

# Options the World panel sets per scene ("what to bake"); the rest are the
# options the preferences give new scenes (and a scene may override). The
# sun (off or split, issue 27) is a choice of the scene's world too.
SCENE_OUTPUTS = ("irradiance", "specular", "lut", "sun")

# Rows shown only when another option has a value (the panel hides them otherwise).
REQUIRES = {"png_encoding": ("formats", "png"), "exposure": ("formats", "png")}


def rows():
    """Every option offered in Blender, native ones first, each a dict as
    iblbake_core.options() gives it (with Blender's own default)."""
    out = []
    for row in native.load().options():
        if row["blender"]:
            row = dict(row)
            row["default"] = BLENDER_DEFAULTS.get(row["name"], row["default"])
            out.append(row)
    return out + [dict(r) for r in ADDON_ROWS]


def native_names():
    """The options iblbake_core.bake() takes from the settings."""
    return [r["name"] for r in native.load().options() if r["blender"]]


def cli_flag(row) -> str:
    """bake_world.py's flag: the CLI's, or --no-<name> for a switch that is on by default."""
    if row["kind"] == "bool":
        return "--no-" + row["name"].replace("_", "-") if row["default"] else "--" + row["name"].replace("_", "-")
    return row["cli"] or "--" + row["name"].replace("_", "-")


def check(row, value):
    """value as the row's kind takes it; ValueError naming the option otherwise."""
    kind, name = row["kind"], row["name"]
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError("%s must be a whole number, not %r" % (name, value))
    elif kind == "float":
        value = float(value)
        if value != value or value in (float("inf"), float("-inf")):
            raise ValueError("%s must be a finite number" % name)
    elif kind == "bool":
        return bool(value)
    elif kind == "choice":
        if value not in [c["value"] for c in row["choices"]]:
            raise ValueError("%s: %r is not one of %s" % (name, value, ", ".join(c["value"] for c in row["choices"])))
    elif kind == "list":
        value = list(value)
        if not row.get("open_choices"):
            bad = [v for v in value if v not in [c["value"] for c in row["choices"]]]
            if bad:
                raise ValueError("%s: %s not among %s" % (name, ", ".join(bad),
                                                         ", ".join(c["value"] for c in row["choices"])))
    if kind in ("int", "float") and row.get("min") is not None and row.get("max") is not None \
            and not row["min"] <= value <= row["max"]:
        raise ValueError("%s must be in %s..%s%s" % (name, row["min"], row["max"], row.get("note", "")))
    return value
