"""Reads the dynamic loader's LD_DEBUG=bindings log of a bake (check_wheels.sh's
clash run) and checks that our module and the other libraries in the process
kept to themselves:

  python3 check_bindings.py LOG_PREFIX MODULE_BASENAME

- every symbol our module imports is bound to glibc (libc, libm, libpthread,
  libdl, the loader) or to the Python interpreter, never to another
  library's OpenEXR, Imath, TBB, libstdc++, zlib ...;
- nothing else binds to a symbol in our module but the interpreter, to
  PyInit_iblbake_core.
Exits 1 and prints the offending bindings otherwise."""
import glob
import os
import re
import sys

# binding file /path/a.so [0] to /path/b.so [0]: normal symbol `name' [VERSION]
LINE = re.compile(r"binding file (\S+) \[\d+\] to (\S+) \[\d+\]: \S+ symbol `([^']+)'")
GLIBC = re.compile(r"/(libc|libm|libpthread|libdl|librt|ld-linux-x86-64)\.so")
PYTHON = re.compile(r"((^|/)python3[.\d]*$|libpython3)")


def main():
    prefix, module = sys.argv[1:3]
    ours_out, into_ours, seen = [], [], 0
    for path in glob.glob(prefix + "*"):
        with open(path, errors="replace") as f:
            for line in f:
                m = LINE.search(line)
                if not m:
                    continue
                src, dst, sym = m.groups()
                if os.path.basename(src) == module:
                    seen += 1
                    if not (GLIBC.search(dst) or PYTHON.search(dst) or os.path.basename(dst) == module):
                        ours_out.append("%s -> %s (%s)" % (module, dst, sym))
                elif os.path.basename(dst) == module and not (PYTHON.search(src) and sym == "PyInit_iblbake_core"):
                    into_ours.append("%s -> %s (%s)" % (src, module, sym))
    problems = sorted(set(ours_out))[:20] + sorted(set(into_ours))[:20]
    if seen == 0:
        problems.append("no binding of %s in the log (LD_DEBUG=bindings not in effect?)" % module)
    print("check_bindings: %d bindings of %s, %d to libraries other than glibc and Python, %d into it" % (
        seen, module, len(ours_out), len(into_ours)))
    for p in problems:
        print("  " + p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
