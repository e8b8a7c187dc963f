#!/usr/bin/env python3
"""Copies a tree into the wheel build's source folder by content: a file whose
bytes changed (or that is new) is written now, so it is newer than every object
built before; an unchanged file keeps its old copy and mtime, so it is not
compiled again; a file gone from the tree is removed.

    sync_tree.py FROM INTO

Mtimes alone cannot decide this: the build folder is shared by every checkout
and worktree that runs scripts/package.sh, and a file checked out before
another tree's build looks older than that build's objects even when its
content differs (a stale module in a wheel)."""
import os
import shutil
import sys


def files(top):
    out = set()
    for d, _, names in os.walk(top):
        for n in names:
            out.add(os.path.relpath(os.path.join(d, n), top))
    return out


def same(a, b):
    try:
        if os.path.getsize(a) != os.path.getsize(b):
            return False
        with open(a, "rb") as fa, open(b, "rb") as fb:
            return fa.read() == fb.read()
    except OSError:
        return False


def main(src, dst):
    new, old = files(src), files(dst) if os.path.isdir(dst) else set()
    written = 0
    for rel in sorted(new):
        a, b = os.path.join(src, rel), os.path.join(dst, rel)
        if not same(a, b):
            os.makedirs(os.path.dirname(b), exist_ok=True)
            if os.path.lexists(b):
                os.remove(b)
            shutil.copy(a, b)  # no copystat: written now
            written += 1
    for rel in sorted(old - new):
        os.remove(os.path.join(dst, rel))
    print("sync_tree: %d of %d files changed, %d removed" % (written, len(new), len(old - new)))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
