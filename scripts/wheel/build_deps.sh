#!/usr/bin/env bash
# Runs inside the wheels' Debian 11 build chroot (scripts/package.sh): builds
# the static, position-independent libraries the wheels' module links in,
# from Debian 12's source packages (apt-get source; the versions Debian 12's
# own build of iblbake links, so the wheels decode and compress as it does):
# zlib, libpng, libjpeg-turbo, zstd, libdeflate, Imath, OpenEXR and oneTBB,
# into PREFIX.
# OpenSSL's libcrypto (SHA-256 only) is Debian 11's own libcrypto.a, which is
# already position-independent. Every unit gets scripts/wheel/glibc_pins.h.
#   bash build_deps.sh PREFIX PINS_HEADER
set -euo pipefail
PREFIX="$1"
PINS="$2"
SRC=/var/tmp/wheel-deps-src
J="$(nproc)"
export CFLAGS="-O2 -fPIC -include $PINS" CXXFLAGS="-O2 -fPIC -include $PINS"
rm -rf "$SRC" "$PREFIX"
mkdir -p "$SRC" "$PREFIX"
cd "$SRC"
# The _apt user cannot write here: apt downloads as root, and says so.
apt-get source -qq zlib libpng1.6 libjpeg-turbo libzstd libdeflate imath openexr onetbb 2>&1 | grep -v "unsandboxed as root" || true
for d in zlib libpng1.6 libjpeg-turbo libzstd libdeflate imath openexr onetbb; do
  ls -d "$SRC/$d"-*/ >/dev/null || { echo "build_deps: apt-get source $d gave nothing" >&2; exit 1; }
done
dir() { ls -d "$SRC/$1"-*/ | head -n 1; }
quiet() {  # a step's output only when it fails
  local log="$SRC/step.log"
  if ! "$@" >"$log" 2>&1; then tail -n 40 "$log" >&2; echo "build_deps: failed: $*" >&2; exit 1; fi
}
cm() {  # cm SOURCE_DIR CMAKE_ARGS...: configure, build, install
  local s="$1"; shift
  quiet cmake -S "$s" -B "$s/_b" -DCMAKE_BUILD_TYPE=Release -DCMAKE_POSITION_INDEPENDENT_CODE=ON \
    -DCMAKE_INSTALL_PREFIX="$PREFIX" -DCMAKE_PREFIX_PATH="$PREFIX" -DCMAKE_INSTALL_LIBDIR="$PREFIX/lib" "$@"
  quiet cmake --build "$s/_b" -j"$J"
  quiet cmake --install "$s/_b"
}

echo "build_deps: zlib"
(cd "$(dir zlib)" && quiet ./configure --static --prefix="$PREFIX" && quiet make -j"$J" && quiet make install)
echo "build_deps: libpng"
(cd "$(dir libpng1.6)" && quiet ./configure --disable-shared --enable-static --prefix="$PREFIX" \
   CPPFLAGS="-I$PREFIX/include" LDFLAGS="-L$PREFIX/lib" && quiet make -j"$J" && quiet make install)
echo "build_deps: libjpeg-turbo"
cm "$(dir libjpeg-turbo)" -DENABLE_SHARED=OFF -DWITH_TURBOJPEG=OFF
echo "build_deps: zstd"
cm "$(dir libzstd)build/cmake" -DZSTD_BUILD_SHARED=OFF -DZSTD_BUILD_PROGRAMS=OFF -DZSTD_BUILD_TESTS=OFF
echo "build_deps: libdeflate"
# Its Makefile (1.14: no CMake yet) builds the static library alone; the
# header and the pkg-config file are installed as its `install` would.
(cd "$(dir libdeflate)" && quiet make -j"$J" libdeflate.a DISABLE_SHARED=1 &&
  install -m644 libdeflate.a "$PREFIX/lib" && install -m644 libdeflate.h "$PREFIX/include" &&
  mkdir -p "$PREFIX/lib/pkgconfig" &&
  sed -e "s|@PREFIX@|$PREFIX|" -e "s|@LIBDIR@|$PREFIX/lib|" -e "s|@INCDIR@|$PREFIX/include|" \
      -e "s|@VERSION@|$(sed -n 's/^#define LIBDEFLATE_VERSION_STRING.*"\(.*\)"/\1/p' libdeflate.h)|" \
      libdeflate.pc.in > "$PREFIX/lib/pkgconfig/libdeflate.pc")
echo "build_deps: Imath"
cm "$(dir imath)" -DBUILD_SHARED_LIBS=OFF -DBUILD_TESTING=OFF
echo "build_deps: OpenEXR"
cm "$(dir openexr)" -DBUILD_SHARED_LIBS=OFF -DBUILD_TESTING=OFF -DOPENEXR_BUILD_TOOLS=OFF \
  -DOPENEXR_INSTALL_EXAMPLES=OFF -DOPENEXR_INSTALL_TOOLS=OFF -DZLIB_ROOT="$PREFIX"
echo "build_deps: oneTBB"
# Debian 12's patch adds a warning option GCC 10 does not know.
sed -i 's/ -Wno-error=use-after-free//' "$(dir onetbb)cmake/compilers/GNU.cmake"
# A static TBB already loads no library (__TBB_DYNAMIC_LOAD_ENABLED=0), but
# it still refers weakly to scalable_malloc and the RML server's entry points:
# in a process where another TBB's libtbbmalloc is loaded globally (Blender,
# OpenImageIO's module), the loader bound those to it (LD_DEBUG=bindings in
# scripts/check_wheels.sh's clash test). No weak symbols: malloc it is.
CXXFLAGS="$CXXFLAGS -D__TBB_WEAK_SYMBOLS_PRESENT=0" \
  cm "$(dir onetbb)" -DBUILD_SHARED_LIBS=OFF -DTBB_TEST=OFF -DTBB_STRICT=OFF -DTBBMALLOC_BUILD=OFF
# What was built, for dist/build-info.json.
{
  (cd "$SRC" && for f in *.dsc; do sed -n 's/^Source: //p; s/^Version: //p' "$f" | paste -sd' '; done)
  echo "openssl (libcrypto.a of Debian 11's libssl-dev) $(dpkg-query -W -f='${Version}' libssl-dev)"
} > "$PREFIX/versions.txt"
rm -rf "$SRC"
echo "build_deps: done: $(paste -sd, "$PREFIX/versions.txt")"
