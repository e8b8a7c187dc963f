#!/bin/sh
# npm_setup.sh DIR CACHE: installs the pinned npm packages of DIR/package-lock.json
# into DIR/node_modules with `npm ci` (cache in CACHE, offline when it holds
# everything), unless node_modules already matches the lock file.
set -eu
cd "$1"
stamp=node_modules/.iblbake-lock.sha256
want=$(sha256sum package-lock.json | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
  echo "npm_setup: node_modules matches package-lock.json"
  exit 0
fi
echo "npm_setup: npm ci ($(node --version), npm $(npm --version)) into $1"
npm ci --no-audit --no-fund --prefer-offline --cache "$2"
echo "$want" > "$stamp"
