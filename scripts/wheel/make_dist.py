#!/usr/bin/env python3
"""Writes dist/ from the wheels' modules (scripts/package.sh calls it):

  iblbake_core-VER-cpXY-cpXY-manylinux_2_N_x86_64.whl   one per Python
  iblbake-blender4.2+-extension-VER-linux-x64.zip
                                the Blender 4.2+ extension: the add-on in a
                                folder iblbake/, its manifest naming the three
                                wheels (iblbake/wheels/), platforms linux-x64
  build-info.json               what went in, and per ELF file: the libraries
                                and the highest glibc symbol version it needs,
                                its size and sha256
  SHA256SUMS

Every module is checked first (readelf): it needs glibc's libraries alone, no
libstdc++ or libgcc_s symbol version, no RPATH, and exports
PyInit_iblbake_core alone. The platform tag is the highest glibc version any
module needs, measured here. Zips are reproducible: sorted entries, fixed
times, fixed permissions."""
import argparse
import base64
import hashlib
import io
import json
import os
import re
import subprocess
import sys
import zipfile

GLIBC_LIBS = {"libc.so.6", "libm.so.6", "libdl.so.2", "libpthread.so.0", "librt.so.1", "ld-linux-x86-64.so.2"}
EXPORT = "PyInit_iblbake_core"
ZIP_TIME = (1980, 1, 1, 0, 0, 0)
MODULE = re.compile(r"iblbake_core\.cpython-(\d)(\d+)-x86_64-linux-gnu\.so$")


def readelf(*args):
    return subprocess.run(["readelf", "-W", *args], check=True, capture_output=True, text=True).stdout


def version_key(v):
    return tuple(int(x) for x in v.split("."))


def inspect_elf(path):
    """{'needed': [...], 'glibc': 'X.Y', 'versions': {lib: [...]}, 'exports': [...], 'runpath': bool}"""
    dynamic = readelf("-d", path)
    needed = re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", dynamic)
    versions = {}
    lib = None
    for line in readelf("-V", path).splitlines():
        m = re.search(r"File: (\S+)", line)
        if m:
            lib = m.group(1)
        m = re.search(r"Name: (\S+)\s+Flags", line)
        if m and lib:
            versions.setdefault(lib, []).append(m.group(1))
    exports = []
    for line in readelf("--dyn-syms", path).splitlines():
        f = line.split()
        # Num: Value Size Type Bind Vis Ndx Name: defined (Ndx not UND) global or weak symbols
        if len(f) >= 8 and f[0].endswith(":") and f[6] != "UND" and f[4] in ("GLOBAL", "WEAK"):
            exports.append(f[7].split("@")[0])
    glibc = max((v[len("GLIBC_"):] for vs in versions.values() for v in vs if v.startswith("GLIBC_")),
                key=version_key, default="2.2.5")
    return {"needed": needed, "glibc": glibc, "versions": versions, "exports": sorted(set(exports)),
            "runpath": "RPATH" in dynamic or "RUNPATH" in dynamic}


def check_module(path, info):
    """The reasons this module is not self-contained, or []."""
    why = []
    foreign = sorted(set(info["needed"]) - GLIBC_LIBS)
    if foreign:
        why.append("needs libraries outside glibc: %s" % ", ".join(foreign))
    for lib, vs in info["versions"].items():
        odd = [v for v in vs if not v.startswith("GLIBC_")]
        if odd:
            why.append("needs %s from %s (libstdc++/libgcc must be linked in)" % (", ".join(odd), lib))
    if info["exports"] != [EXPORT]:
        why.append("exports %s (only %s may be)" % (info["exports"][:8], EXPORT))
    if info["runpath"]:
        why.append("has an RPATH/RUNPATH")
    return ["%s: %s" % (os.path.basename(path), w) for w in why]


def record_hash(data):
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def write_zip(path, entries):
    """entries: [(name, bytes, executable)], written sorted with fixed times."""
    tmp = path + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
        for name, data, executable in sorted(entries, key=lambda e: e[0]):
            zi = zipfile.ZipInfo(name, ZIP_TIME)
            zi.compress_type = zipfile.ZIP_DEFLATED
            zi.external_attr = (0o100755 if executable else 0o100644) << 16
            z.writestr(zi, data)
    os.replace(tmp, path)


def make_wheel(out_dir, module_path, version, py_major, py_minor, tag, source_version):
    cp = "cp%s%s" % (py_major, py_minor)
    dist_info = "iblbake_core-%s.dist-info" % version
    with open(module_path, "rb") as f:
        module = f.read()
    metadata = "\n".join([
        "Metadata-Version: 2.1",
        "Name: iblbake_core",
        "Version: %s" % version,
        "Summary: iblbake's native core: a world HDRI into image-based lighting (irradiance + SH9, "
        "GGX prefiltered specular, BRDF LUT), self-contained",
        "License: GPL-3.0-or-later",
        "Requires-Python: >=%s.%s,<%s.%d" % (py_major, py_minor, py_major, int(py_minor) + 1),
        "Platform: linux-x86_64",
        "",
        "Built from iblbake %s on Debian 11 (scripts/package.sh). Needs glibc only; see build-info.json." % source_version,
        ""])
    wheel = "\n".join(["Wheel-Version: 1.0", "Generator: iblbake scripts/wheel/make_dist.py",
                       "Root-Is-Purelib: false", "Tag: %s-%s-%s" % (cp, cp, tag), ""])
    files = [(os.path.basename(module_path), module, True),
             (dist_info + "/METADATA", metadata.encode(), False),
             (dist_info + "/WHEEL", wheel.encode(), False)]
    record = "".join("%s,%s,%d\n" % (n, record_hash(d), len(d)) for n, d, _ in files)
    record += dist_info + "/RECORD,,\n"
    files.append((dist_info + "/RECORD", record.encode(), False))
    name = "iblbake_core-%s-%s-%s-%s.whl" % (version, cp, cp, tag)
    write_zip(os.path.join(out_dir, name), files)
    return name


def extension_manifest(text, wheels):
    """The add-on's blender_manifest.toml for this zip: linux-x64, its wheels."""
    listed = ", ".join('"./wheels/%s"' % w for w in wheels)
    text, n = re.subn(r"\nplatforms = [^\n]*", '\nplatforms = ["linux-x64"]\nwheels = [%s]' % listed, text)
    if n != 1:
        raise SystemExit("make_dist: blender_manifest.toml has no single 'platforms = ' line")
    return text


def addon_files(addon):
    """The add-on's Python sources (as addon/stage_files.cmake stages them)."""
    out = []
    for dirpath, dirnames, filenames in os.walk(addon):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for fn in sorted(filenames):
            if fn.endswith(".py"):
                p = os.path.join(dirpath, fn)
                out.append((os.path.relpath(p, addon).replace(os.sep, "/"), p))
    return out


def sha256_file(path):
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--modules", required=True, help="folder with cpXY/iblbake_core.cpython-XY-*.so")
    ap.add_argument("--addon", required=True, help="addon/iblbake")
    ap.add_argument("--out", required=True, help="dist/")
    ap.add_argument("--source-version", default="unknown")
    ap.add_argument("--deps", help="versions of the static libraries (one 'source version' a line)")
    ap.add_argument("--headers", help="the .debs the headers came from (one a line)")
    a = ap.parse_args()

    modules = []
    for sub in sorted(os.listdir(a.modules)):
        for fn in sorted(os.listdir(os.path.join(a.modules, sub))):
            m = MODULE.match(fn)
            if m:
                modules.append((os.path.join(a.modules, sub, fn), m.group(1), m.group(2)))
    if not modules:
        raise SystemExit("make_dist: no iblbake_core modules under %s" % a.modules)
    infos = {p: inspect_elf(p) for p, _, _ in modules}
    problems = [w for p in infos for w in check_module(p, infos[p])]
    if problems:
        raise SystemExit("make_dist: not self-contained:\n  " + "\n  ".join(problems))
    glibc = max((i["glibc"] for i in infos.values()), key=version_key)
    tag = "manylinux_%s_x86_64" % glibc.replace(".", "_")

    with open(os.path.join(a.addon, "blender_manifest.toml")) as f:
        manifest_text = f.read()
    version = re.search(r'\nversion = "([^"]+)"', manifest_text).group(1)
    os.makedirs(a.out, exist_ok=True)
    for old in os.listdir(a.out):  # only what an earlier run of this script made
        if old.endswith((".whl", ".zip")) or old in ("build-info.json", "SHA256SUMS"):
            os.remove(os.path.join(a.out, old))
    wheels = [make_wheel(a.out, p, version, ma, mi, tag, a.source_version) for p, ma, mi in modules]

    entries = [("iblbake/" + rel, open(p, "rb").read(), False) for rel, p in addon_files(a.addon)]
    entries.append(("iblbake/blender_manifest.toml", extension_manifest(manifest_text, wheels).encode(), False))
    for w in wheels:
        entries.append(("iblbake/wheels/" + w, open(os.path.join(a.out, w), "rb").read(), False))
    zip_name = "iblbake-blender4.2+-extension-%s-linux-x64.zip" % version
    write_zip(os.path.join(a.out, zip_name), entries)

    def lines(path):
        return [l.strip() for l in open(path)] if path and os.path.isfile(path) else []
    info = {
        "version": version, "source": a.source_version, "platform_tag": tag,
        "built_on": "Debian 11 (bullseye), glibc 2.31, GCC %s" % os.environ.get("IBLBAKE_WHEEL_GCC", "10"),
        "static_libraries": lines(a.deps), "headers_from": lines(a.headers),
        "zip": {"name": zip_name, "size": os.path.getsize(os.path.join(a.out, zip_name))},
        "wheels": {w: {"size": os.path.getsize(os.path.join(a.out, w))} for w in wheels},
        "modules": {os.path.basename(p): {"glibc": infos[p]["glibc"], "needed": infos[p]["needed"],
                                          "size": os.path.getsize(p), "sha256": sha256_file(p)}
                    for p, _, _ in modules},
    }
    with open(os.path.join(a.out, "build-info.json"), "w") as f:
        json.dump(info, f, indent=1)
        f.write("\n")
    with open(os.path.join(a.out, "SHA256SUMS"), "w") as f:
        for name in sorted(wheels + [zip_name, "build-info.json"]):
            f.write("%s  %s\n" % (sha256_file(os.path.join(a.out, name)), name))
    print("make_dist: %s (%.1f MB): %s; every module needs glibc %s at most" % (
        zip_name, info["zip"]["size"] / 1e6, ", ".join(wheels), glibc))


if __name__ == "__main__":
    sys.exit(main())
