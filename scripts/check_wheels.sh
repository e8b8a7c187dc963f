#!/usr/bin/env bash
# Proves dist/'s wheels on machines that never built them:
#   bash scripts/check_wheels.sh [SUITE...]     (as root; default: bookworm trixie sid)
# For each suite, a brand-new minbase chroot with python3 and python3-numpy
# alone (none of the build's libraries: no OpenEXR, Imath, TBB, libpng,
# libjpeg, zstd, libstdc++ beyond what those two pull in) unpacks the wheel
# for its Python (bookworm cp311, trixie cp313, sid cp314) and bakes
# tests/wheels/bake_cases.py's cases (an EXR and a PNG, with and without every
# engine preset, and a numpy array); every file must match, bit for bit, the
# same cases baked on this host by the build's own module (build/native,
# linked against the host's libraries; tests/wheels/compare_bakes.py).
# In sid, then, the clash test: Debian's python3-openimageio (OpenImageIO
# 3.1, OpenEXR 3.4, TBB) is installed and loaded with global visibility
# before the wheel, as Blender loads its own libraries before an add-on's
# module, and the bakes must still match; the loader's own log
# (LD_DEBUG=bindings, tests/wheels/check_bindings.py) must show our module's
# calls bound to glibc and Python alone, and nothing bound into it.
# Before that, on the host: python3-wheel's `wheel unpack` (every file
# against RECORD) of each wheel, and pip's install of the host Python's one.
# Needs dist/ (scripts/package.sh) and the host build (scripts/build.sh).
# Prints the time of each suite.
set -euo pipefail
main() {
  [ "$(id -u)" -eq 0 ] || { echo "check_wheels: needs root (chroots)" >&2; exit 1; }
  REPO="$(cd "$(dirname "$0")/.." && pwd)"
  . "$REPO/scripts/chroot_lib.sh"
  local suites=("$@")
  [ ${#suites[@]} -gt 0 ] || suites=(bookworm trixie sid)
  local host_module
  host_module="$(ls "$REPO"/build/native/iblbake_core*.so 2>/dev/null | head -n 1)"
  [ -n "$host_module" ] || { echo "check_wheels: no build/native/iblbake_core*.so: run scripts/build.sh first" >&2; exit 1; }
  ls "$REPO"/dist/iblbake_core-*.whl >/dev/null 2>&1 || { echo "check_wheels: no wheels in dist/: run scripts/package.sh first" >&2; exit 1; }
  command -v idiff >/dev/null && command -v oiiotool >/dev/null ||
    { echo "check_wheels: needs idiff and oiiotool (openimageio-tools, scripts/install_deps.sh)" >&2; exit 1; }
  local forest=/usr/share/blender/datafiles/studiolights/world/forest.exr
  [ -f "$forest" ] || { echo "check_wheels: needs Blender's forest.exr (blender-data, scripts/install_deps.sh)" >&2; exit 1; }
  chroot_host_tools
  chroot_mirrors

  # Work at one absolute path, the same inside each chroot as on the host, so
  # the manifests' source paths agree.
  local work=/var/tmp/iblbake-wheel-check
  mkdir -p "$CHROOT_TOP"
  exec 9>"$CHROOT_TOP/wheel-check.lock"
  flock 9
  root=""  # global: the EXIT trap reads it after main has returned
  cleanup() {
    local rc=$?
    chroot_umount_all
    [ -z "$root" ] || rm -rf "$root"
    exit $rc
  }
  trap cleanup EXIT
  trap 'exit 130' INT TERM HUP

  rm -rf "$work"
  mkdir -p "$work/src"
  cp "$forest" "$work/src/forest.exr"
  oiiotool "$work/src/forest.exr" --colorconvert linear sRGB -d uint8 -o "$work/src/forest.png"
  oiiotool "$work/src/forest.exr" -o "$work/src/forest.hdr"
  oiiotool "$work/src/forest.exr" -d float -o "$work/src/forest.tif"
  # A 4K half-float ZIP world: streamed, its blocks decoded by iblbake itself
  # (native/src/io/exr_zip.h) with the wheel's own libdeflate.
  oiiotool "$work/src/forest.exr" --resize:filter=triangle 4096x2048 -d half --compression zip -o "$work/src/forest_zip.exr"
  cp "$REPO/tests/wheels/bake_cases.py" "$work/"
  local t=$SECONDS
  (cd "$work" && IBLBAKE_CACHE_DIR="$work/cache" /usr/bin/python3 bake_cases.py "$(dirname "$host_module")" src ref)
  echo "check_wheels: reference baked on the host in $((SECONDS - t)) s"

  # Read by other tools than ours first: python3-wheel's unpack checks every
  # file against RECORD; pip installs the wheel for this host's Python (its
  # tags, its metadata), which then imports.
  local w pytag
  for w in "$REPO"/dist/iblbake_core-*.whl; do
    /usr/bin/python3 -m wheel unpack -d "$work/unpacked" "$w" >/dev/null
  done
  pytag="$(/usr/bin/python3 -c 'import sys; print("cp%d%d" % sys.version_info[:2])')"
  /usr/bin/python3 -m pip install -q --no-index --no-deps --no-compile --target "$work/pip" \
    "$(ls "$REPO"/dist/iblbake_core-*-"$pytag"-"$pytag"-*.whl)"
  /usr/bin/python3 -c "import sys; sys.path.insert(0, sys.argv[1]); import iblbake_core as ib; \
    assert ib.__file__.startswith(sys.argv[1]), ib.__file__; print('check_wheels: pip installed', ib.__file__)" "$work/pip"

  local suite py failed=0
  for suite in "${suites[@]}"; do
    case "$suite" in bookworm) py=311 ;; trixie) py=313 ;; sid) py=314 ;;
      *) echo "check_wheels: unknown suite $suite (bookworm, trixie, sid)" >&2; exit 2 ;; esac
    t=$SECONDS
    local wheel
    wheel="$(ls "$REPO"/dist/iblbake_core-*-cp$py-cp$py-*.whl | head -n 1)"
    root="$CHROOT_TOP/wheels-$suite-$$"
    rm -rf "$root"
    chroot_unpack "$suite" "$root"
    chroot_mount "$root" "$suite"
    chroot_apt "$root" python3 python3-numpy
    mkdir -p "$root$work"
    cp -r "$work/src" "$work/bake_cases.py" "$root$work/"
    cp "$wheel" "$root$work/"
    # Unpacked as an installer would (a wheel is a zip), then baked.
    chroot_run "$root" "cd $work && python3 -c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(\"site\")' \
      $(basename "$wheel") && echo \"check_wheels: $suite: libraries of the build's names in this chroot:\" \
      \$(ls /usr/lib/x86_64-linux-gnu | grep -E '^lib(OpenEXR|Imath|Iex|tbb|png|jpeg|zstd|crypto|stdc)' | tr '\n' ' ')"
    chroot_run "$root" "cd $work && python3 bake_cases.py site src out"
    rm -rf "$work/out-$suite"
    cp -r "$root$work/out" "$work/out-$suite"
    /usr/bin/python3 "$REPO/tests/wheels/compare_bakes.py" "$work/ref" "$work/out-$suite" --wheel || failed=1
    if [ "$suite" = sid ]; then
      chroot_apt "$root" python3-openimageio
      chroot_run "$root" "cd $work && rm -rf out bindings* && LD_DEBUG=bindings LD_DEBUG_OUTPUT=$work/bindings \
        python3 bake_cases.py site src out --foreign"
      rm -rf "$work/out-$suite-foreign"
      cp -r "$root$work/out" "$work/out-$suite-foreign"
      /usr/bin/python3 "$REPO/tests/wheels/compare_bakes.py" "$work/ref" "$work/out-$suite-foreign" --wheel --expect-foreign ||
        failed=1
      /usr/bin/python3 "$REPO/tests/wheels/check_bindings.py" "$root$work/bindings" \
        "$(basename "$(ls "$root$work"/site/iblbake_core*.so)")" || failed=1
    fi
    chroot_umount_all
    rm -rf "$root"
    root=""
    echo "check_wheels: $suite (cp$py) done in $((SECONDS - t)) s"
  done
  [ $failed -eq 0 ] || { echo "check_wheels: FAIL" >&2; exit 1; }
  echo "check_wheels: PASS (${suites[*]})"
}
main "$@"; exit $?
