"""Output folder names from a template ({blend}, {scene}, {world}), bpy-free."""
import hashlib
import re

PLACEHOLDERS = ("{blend}", "{scene}", "{world}")


class TemplateError(ValueError):
    """The output folder template cannot be used: the message says why."""


def safe_component(name: str) -> str:
    """A name as one path component: never empty, never "." or "..", and
    distinct names stay distinct where nothing of them is left (an emoji
    name, "..", "."): those get a short digest of the name."""
    s = re.sub(r"[^\w.-]+", "_", name).strip("_")
    if s.strip(".") == "":
        return "untitled-" + hashlib.sha1(name.encode("utf-8", "surrogatepass")).hexdigest()[:8] if name else "untitled"
    return s


def fill_template(template: str, blend: str, scene: str, world: str) -> str:
    """The template with its placeholders replaced by safe names; any other
    {word} is refused (it would become a literal folder name)."""
    text = template
    for key, value in zip(PLACEHOLDERS, (blend, scene, world)):
        text = text.replace(key, safe_component(value))
    unknown = re.findall(r"\{[^{}/\\]*\}", text)
    if unknown:
        raise TemplateError("the output folder %r names %s, which is not one of %s" % (
            template, ", ".join(sorted(set(unknown))), ", ".join(PLACEHOLDERS)))
    return text
