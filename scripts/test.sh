#!/usr/bin/env bash
# The README's test command: installs dependencies, builds, runs every test
# (GoogleTest and pytest, through CTest).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh
cd "${IBLBAKE_BUILD_DIR:-build}"
ctest --output-on-failure -j1 "$@"
