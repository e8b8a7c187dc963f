#!/usr/bin/env bash
# The README's main command: installs dependencies, builds, and bakes a
# default world - Blender's bundled forest.exr as the scene world's
# Environment Texture - through the iblbake add-on in headless Blender, with
# the default settings, into out/forest (EXR + PNG + manifest.json).
#   bash scripts/bake_default.sh [IMAGE [OUTDIR]]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh
SOURCE="${1:-/usr/share/blender/datafiles/studiolights/world/forest.exr}"
OUT="${2:-out/forest}"
export IBLBAKE_CORE_DIR="$(pwd)/${IBLBAKE_BUILD_DIR:-build}/native"
blender -b --factory-startup --python-exit-code 1 --python blender_scripts/bake_world.py -- \
  --hdri "$SOURCE" --out "$OUT" --format exr,png
echo "outputs: $(cd "$OUT" && pwd) (manifest.json describes every file)"
