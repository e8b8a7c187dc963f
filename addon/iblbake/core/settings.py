"""Everything a bake is asked to do, as one plain object (the operator copies
the scene's and the preferences' properties into it)."""
from dataclasses import asdict, field, make_dataclass

from . import options as table


def _fields():
    """The settings: where the bake goes, every option of the table (core/options.py)
    with Blender's default, and what the add-on decides itself."""
    out = [("out_dir", str, field(default=""))]
    for row in table.rows():
        default = row["default"]
        if isinstance(default, list):
            out.append((row["name"], list, field(default_factory=lambda d=tuple(default): list(d))))
        else:
            out.append((row["name"], type(default), field(default=default)))
    return out + [
        ("auto_skip", bool, field(default=True)),  # skip what the scene's materials don't use (the UI defaults to off)
        ("force", bool, field(default=False)),     # bake even when the world and settings are unchanged
        ("lut_cache_dir", str, field(default="")),  # "": the native default (~/.cache/iblbake)
        ("threads", int, field(default=0)),
    ]


def _resolved_mip_count(self) -> int:
    return self.mip_count if self.mip_count > 0 else max(1, self.face_size).bit_length()


def _validate(self):
    """Raises ValueError naming the first setting at fault."""
    if not self.out_dir:
        raise ValueError("no output folder: set one in the World panel or the add-on preferences")
    for row in table.rows():
        value = getattr(self, row["name"])
        if row["kind"] == "list" and not (isinstance(value, (list, tuple)) and all(isinstance(v, str) and v
                                                                                   for v in value)):
            raise ValueError("%s must be a list of names, not %r" % (row["name"], value))
        table.check(row, value)
    if not self.formats:
        raise ValueError("formats must be a non-empty list of 'exr' and 'png'")


def _hash_fields(self) -> dict:
    """The settings that change the files (not where they go, nor how fast)."""
    d = asdict(self)
    for k in ("out_dir", "force", "lut_cache_dir", "threads"):
        d.pop(k)
    return d


BakeSettings = make_dataclass(
    "BakeSettings", _fields(),
    namespace={"resolved_mip_count": _resolved_mip_count, "validate": _validate, "hash_fields": _hash_fields,
               "__doc__": "Everything a bake is asked to do, as one plain object (the operator copies the "
                          "scene's and the preferences' properties into it)."})
BakeSettings.__module__ = __name__
