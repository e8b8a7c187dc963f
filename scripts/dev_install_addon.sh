#!/usr/bin/env bash
# Developer install: links this checkout's addon/iblbake into Blender's user
# add-on folder and enables it, so edits show up after a restart (or F8).
# The add-on finds the module in build/native (see addon/iblbake/core/native.py).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
DEST="$(blender -b --factory-startup --python-expr \
  "import bpy; print('ADDONS=' + bpy.utils.user_resource('SCRIPTS', path='addons', create=True))" 2>/dev/null \
  | sed -n 's/^ADDONS=//p')"
[ -n "$DEST" ] || { echo "could not ask Blender for its user add-on folder" >&2; exit 1; }
mkdir -p "$DEST"
ln -sfn "$ROOT/addon/iblbake" "$DEST/iblbake"
blender -b --python-expr "import addon_utils, bpy; addon_utils.enable('iblbake', default_set=True); bpy.ops.wm.save_userpref()" >/dev/null
echo "linked $ROOT/addon/iblbake -> $DEST/iblbake (enabled)"
