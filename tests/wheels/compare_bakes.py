"""Compares two folders of bake_cases.py output, file by file:

  python3 compare_bakes.py REFERENCE OUT [--wheel] [--expect-foreign]

The same files must be there. A file is the same when its bytes are; an EXR
or PNG whose bytes differ is the same when every pixel is (idiff -fail 0:
another OpenEXR or zlib may compress the same pixels into other bytes), and
manifest.json when it is, but for the times it records and whether the LUT came from the cache (VOLATILE) and the
bytes and sha256 of the files it lists that matched by their pixels. Prints one line per
case and exits 1 on any difference. --expect-foreign: OUT's report must show
the foreign OpenImageIO, OpenEXR and TBB loaded beside our module. --wheel:
OUT's module is a wheel's, which has no OpenImageIO plugin: the report must
show a TIFF recognised and refused with a reason (a Radiance .hdr is baked:
every build reads it itself)."""
import hashlib
import json
import os
import subprocess
import sys

# Manifest entries that measure the run, not the bake: the native times, and
# the add-on's waits before the native bake, whether the LUT came from its cache.
VOLATILE = (("timings",), ("blender", "waited"), ("brdf_lut", "from_cache"))


def files_under(root):
    out = set()
    for dirpath, _, filenames in os.walk(root):
        for fn in filenames:
            out.add(os.path.relpath(os.path.join(dirpath, fn), root))
    return out


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def same_pixels(a, b):
    p = subprocess.run(["idiff", "-q", "-fail", "0", "-failpercent", "0", "-warn", "0", a, b],
                       capture_output=True, text=True)
    return p.returncode == 0


def same_manifest(a, b, by_pixels=()):
    """Equal but for VOLATILE, and for the bytes and sha256 the manifest lists
    of files `by_pixels` (names relative to the manifest's folder) that
    matched by their pixels only."""
    def load(p):
        with open(p) as f:
            m = json.load(f)
        for name in by_pixels:
            if isinstance(m.get("files"), dict) and name in m["files"]:
                m["files"][name] = "same pixels"
        for path in VOLATILE:
            parent = m
            for k in path[:-1]:
                parent = parent.get(k, {}) if isinstance(parent, dict) else {}
            if isinstance(parent, dict):
                parent.pop(path[-1], None)
        return m
    return load(a) == load(b)


def compare(ref, out):
    """[(case, file, how)] of the differences; how the same files were matched."""
    diffs, how = [], {"bytes": 0, "pixels": 0, "manifest": 0}
    ref_files = {f for f in files_under(ref) if f != "report.json"}
    out_files = {f for f in files_under(out) if f != "report.json"}
    for f in sorted(ref_files ^ out_files):
        diffs.append((f, "only in %s" % ("the reference" if f in ref_files else "the output")))
    by_pixels = set()
    manifests = []
    for f in sorted(ref_files & out_files):
        a, b = os.path.join(ref, f), os.path.join(out, f)
        if sha256(a) == sha256(b):
            how["bytes"] += 1
        elif os.path.basename(f) == "manifest.json":
            manifests.append(f)  # after the files it lists
        elif f.endswith((".exr", ".png")) and same_pixels(a, b):
            how["pixels"] += 1
            by_pixels.add(f)
        else:
            diffs.append((f, "differs"))
    for f in manifests:
        folder = os.path.dirname(f)
        mine = {os.path.relpath(p, folder) for p in by_pixels if os.path.dirname(p).startswith(folder)}
        if same_manifest(os.path.join(ref, f), os.path.join(out, f), mine):
            how["manifest"] += 1
        else:
            diffs.append((f, "differs"))
    return diffs, how


def main():
    ref, out = sys.argv[1:3]
    with open(os.path.join(out, "report.json")) as f:
        report = json.load(f)
    diffs, how = compare(ref, out)
    problems = ["%s: %s" % d for d in diffs]
    if "--wheel" in sys.argv[3:]:  # no OpenImageIO plugin: a TIFF is refused, saying what to do
        tif = report.get("tif", {})
        if tif.get("format") != ["tiff", False] or "convert the image to EXR" not in tif.get("error", ""):
            problems.append("a .tif file in a wheel: %s" % tif)
    if "--expect-foreign" in sys.argv[3:]:
        libs = " ".join(report["libraries"])
        for name in ("libOpenImageIO", "libOpenEXR", "libtbb"):
            if name not in libs:
                problems.append("the foreign %s was not loaded" % name)
    print("compare: %s (Python %s): %d files the same (%d to the byte, %d by pixels, %d manifests but for "
          "their times), %d differences" % (report["module"], report["python"], sum(how.values()), how["bytes"],
                                           how["pixels"], how["manifest"], len(diffs)))
    for p in problems:
        print("  " + p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
