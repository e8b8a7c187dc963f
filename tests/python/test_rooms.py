"""The native code's rooms point one way: a lower room never includes a higher one.

Rooms, lowest first (a room may include its own headers and those of any
lower level; rooms of one level know nothing of each other):

    0  math, util        numbers and geometry; the threading helper
    1  image             images and cubes in memory, their layouts and encodings
    2  ibl, io           the integrators; files in and out (neither knows the other)
    3  bake              compute_bake: the integrators composed, the LUT cache
    4  export            engine presets, containers, encoders (own input types)
    5  pipeline          the plan, bake_file, BakeWriter and the manifest, preview
    6  cli, python       the two front ends

and one pair more that the order alone would allow: export never includes
bake (it takes its own input types; the pipeline converts a BakeResult), so
the exporters and the bake are built and tested apart.

Every `#include "iblbake/<room>/..."` (or <...>) under native/include/iblbake/<room>/,
native/src/<room>/, native/cli/ and native/python/ is checked. Run as a script
with a native/ folder to list the violations of another tree:
    python3 tests/python/test_rooms.py /path/to/native
"""
import os
import re
import sys

LEVEL = {
    "math": 0, "util": 0,
    "image": 1,
    "ibl": 2, "io": 2,
    "bake": 3,
    "export": 4,
    "pipeline": 5,
    "cli": 6, "python": 6,
}
# (room, room it must not include) beyond the order.
FORBIDDEN = {("export", "bake"): "export takes its own input types; the pipeline converts a BakeResult"}
NATIVE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "native")
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]iblbake/([^/">]+)/')
SOURCE_EXT = (".h", ".hpp", ".cpp", ".cc", ".inl")


def rooms_of(native):
    """(room, path) of every source file that belongs to a room."""
    for base, room_from_dir in ((os.path.join(native, "include", "iblbake"), True),
                                (os.path.join(native, "src"), True),
                                (os.path.join(native, "cli"), False),
                                (os.path.join(native, "python"), False)):
        if not os.path.isdir(base):
            continue
        for root, _, files in os.walk(base):
            for name in sorted(files):
                if not name.endswith(SOURCE_EXT):
                    continue
                path = os.path.join(root, name)
                rel = os.path.relpath(path, base)
                room = rel.split(os.sep)[0] if room_from_dir else os.path.basename(base)
                if room_from_dir and os.sep not in rel:
                    room = None  # a file beside the rooms belongs to none: reported
                yield room, path


def violations(native):
    """'file:line: ...' for every include that points up or sideways."""
    out = []
    for room, path in rooms_of(native):
        rel = os.path.relpath(path, native)
        if room not in LEVEL:
            out.append(f"{rel}:1: in no known room ({room!r}); add it to test_rooms.py's LEVEL")
            continue
        with open(path, encoding="utf-8", errors="replace") as f:
            for n, line in enumerate(f, 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                target = m.group(1)
                if target not in LEVEL:
                    out.append(f"{rel}:{n}: includes unknown room '{target}'")
                elif target != room and LEVEL[target] >= LEVEL[room]:
                    how = "a higher" if LEVEL[target] > LEVEL[room] else "a same-level"
                    out.append(f"{rel}:{n}: room '{room}' includes {how} room '{target}': {line.strip()}")
                elif (room, target) in FORBIDDEN:
                    out.append(f"{rel}:{n}: room '{room}' may not include '{target}' "
                               f"({FORBIDDEN[room, target]}): {line.strip()}")
    return out


def test_rooms_point_one_way():
    found = violations(NATIVE)
    assert not found, "rooms include upwards or sideways:\n" + "\n".join(found)


def test_every_room_is_checked():
    # A tree without the rooms would pass vacuously.
    rooms = {room for room, _ in rooms_of(NATIVE)}
    assert {"math", "util", "image", "ibl", "io", "bake", "export", "pipeline", "cli", "python"} <= rooms


if __name__ == "__main__":
    found = violations(sys.argv[1] if len(sys.argv) > 1 else NATIVE)
    print("\n".join(found) if found else "rooms: every include points down")
    sys.exit(1 if found else 0)
