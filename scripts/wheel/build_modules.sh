#!/usr/bin/env bash
# Runs inside the wheels' Debian 11 build chroot (scripts/package.sh): builds
# iblbake_core for each Python in PYTHONS from the checkout at SRC into
# BUILD/wheel/cpXY/, against the static libraries in DEPS and the headers
# unpacked under HEADERS (native/python/wheel_modules.cmake).
#   bash build_modules.sh SRC BUILD DEPS HEADERS PINS_HEADER "3.11;3.13;3.14"
set -euo pipefail
SRC="$1" BUILD="$2" DEPS="$3" HEADERS="$4" PINS="$5" PYTHONS="$6"
export PKG_CONFIG_PATH="$DEPS/lib/pkgconfig"
export CFLAGS="-include $PINS" CXXFLAGS="-include $PINS"
cmake -S "$SRC" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release \
  -DIBLBAKE_WHEEL_PYTHONS="$PYTHONS" -DIBLBAKE_WHEEL_PYTHON_ROOT="$HEADERS" \
  -DCMAKE_PREFIX_PATH="$DEPS;$HEADERS/usr" -DCMAKE_FIND_PACKAGE_PREFER_CONFIG=ON \
  -DZLIB_LIBRARY="$DEPS/lib/libz.a" -DZLIB_INCLUDE_DIR="$DEPS/include" \
  -DPNG_LIBRARY="$DEPS/lib/libpng16.a" -DPNG_PNG_INCLUDE_DIR="$DEPS/include" \
  -DJPEG_LIBRARY="$DEPS/lib/libjpeg.a" -DJPEG_INCLUDE_DIR="$DEPS/include" \
  -DOPENSSL_USE_STATIC_LIBS=ON -DIBLBAKE_WHEEL_STRIP=ON >/dev/null
cmake --build "$BUILD" -j"$(nproc)"
