"""Bakes the wheel check's cases with one iblbake_core (scripts/check_wheels.sh
runs it in brand-new chroots with a wheel, and on the host with the build's
module for the reference):

  python3 bake_cases.py MODULE_DIR SOURCES OUT [--foreign]

MODULE_DIR holds iblbake_core (an unpacked wheel, or build/native). SOURCES
holds forest.exr, forest_zip.exr (4K, half, ZIP), forest.png, forest.hdr and
forest.tif. Each case writes OUT/<case>/; OUT/report.json says which module
ran, under which Python, and every shared library the process had mapped at
the end.

--foreign: first load, with global visibility, another OpenImageIO, OpenEXR
and TBB (Debian's python3-openimageio and whatever it pulls in), as Blender
has its own loaded before an add-on's module; the report lists them, and
the bakes must still give the same bits."""
import json
import os
import sys


def mapped_libraries():
    libs = set()
    with open("/proc/self/maps") as f:
        for line in f:
            path = line.split()[-1] if len(line.split()) >= 6 else ""
            if ".so" in os.path.basename(path):
                libs.add(path)
    return sorted(libs)


def load_foreign():
    """OpenImageIO's module and its OpenEXR/TBB, all RTLD_GLOBAL, before ours."""
    import ctypes
    import glob
    sys.setdlopenflags(os.RTLD_NOW | os.RTLD_GLOBAL)
    import OpenImageIO  # noqa: F401  (the point is what it loads)
    loaded = []
    for pattern in ("libOpenEXR-*.so.*", "libOpenEXRCore-*.so.*", "libImath-*.so.*", "libtbb.so.*",
                    "libOpenImageIO.so.*"):
        for path in sorted(glob.glob("/usr/lib/x86_64-linux-gnu/" + pattern))[:1]:
            ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
            loaded.append(path)
    # An OpenEXR call through the foreign library, so it is in use, not just mapped.
    buf = OpenImageIO.ImageBuf(OpenImageIO.ImageSpec(4, 4, 3, "float"))
    assert buf.write(os.path.join(os.environ.get("TMPDIR", "/tmp"), "foreign-probe.exr")), OpenImageIO.geterror()
    return loaded, OpenImageIO.VERSION_STRING


def main():
    module_dir, sources, out = sys.argv[1:4]
    foreign = "--foreign" in sys.argv[4:]
    report = {"python": sys.version.split()[0]}
    if foreign:
        report["foreign"], report["foreign_oiio"] = load_foreign()
    sys.path.insert(0, module_dir)
    import numpy as np
    import iblbake_core as ib
    report["module"] = ib.__file__
    presets = [p["name"] for p in ib.presets()]
    exr, png = os.path.join(sources, "forest.exr"), os.path.join(sources, "forest.png")
    hdr = os.path.join(sources, "forest.hdr")
    cases = {
        "hdr": lambda o: ib.bake_file(hdr, o),  # iblbake's own Radiance reader, in every build
        "exr": lambda o: ib.bake_file(exr, o),
        "exr_zip": lambda o: ib.bake_file(os.path.join(sources, "forest_zip.exr"), o),  # streamed, ZIP blocks
        "exr_presets": lambda o: ib.bake_file(exr, o, presets=presets, preview=True),
        "png": lambda o: ib.bake_file(png, o),
        "png_presets": lambda o: ib.bake_file(png, o, presets=presets),
        # the array path (the add-on's Blender-buffer bake): numpy in, files out
        "array": lambda o: ib.bake(np.ascontiguousarray(ib.read_image(exr)[:, :, :3]), o, source_path=exr,
                                   face_size=64, mip_count=5),
    }
    # A TIFF: read by the build's OpenImageIO plugin, refused in words by a
    # wheel (which carries none).
    tif = os.path.join(sources, "forest.tif")
    report["tif"] = {"format": list(ib.image_format(tif))}
    try:
        report["tif"]["read"] = list(ib.read_image(tif).shape)
    except (RuntimeError, ValueError, OSError) as e:
        report["tif"]["error"] = str(e)
    report["cases"] = {}
    for name, run in cases.items():
        folder = os.path.join(out, name)
        result = run(folder)
        manifest = result.get("manifest", result)
        report["cases"][name] = sorted(f["path"] if isinstance(f, dict) else f for f in manifest["files"])
    report["libraries"] = mapped_libraries()
    with open(os.path.join(out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)
    print("bake_cases: %d cases with %s (Python %s)%s" % (
        len(cases), report["module"], report["python"],
        ", after %s" % ", ".join(os.path.basename(p) for p in report["foreign"]) if foreign else ""))


if __name__ == "__main__":
    main()
