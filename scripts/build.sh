#!/usr/bin/env bash
# Configures and builds iblbake (Release) into build/. Idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${IBLBAKE_BUILD_DIR:-build}"
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=/usr/bin/python3 >/dev/null
cmake --build "$BUILD_DIR" -j"$(nproc)"
