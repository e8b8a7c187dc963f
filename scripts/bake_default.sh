#!/usr/bin/env bash
# The README's main command: installs dependencies, builds, and bakes Blender's
# bundled forest.exr with the default settings into out/forest (EXR + PNG).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh
SOURCE="${1:-/usr/share/blender/datafiles/studiolights/world/forest.exr}"
OUT="${2:-out/forest}"
"${IBLBAKE_BUILD_DIR:-build}/native/iblbake" bake "$SOURCE" -o "$OUT" --format exr,png
echo "outputs: $(cd "$OUT" && pwd) (manifest.json describes every file)"
