#!/usr/bin/env bash
# The benchmark in one command: builds (Release), then runs bench/run.py with
# the given options. See docs/benchmarks.md.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh >/dev/null
exec /usr/bin/python3 bench/run.py "$@"
