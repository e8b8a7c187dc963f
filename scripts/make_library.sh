#!/usr/bin/env bash
# A library of worlds to try a batch on (docs/farm.md): Blender's eight
# studio-light worlds, each resized, turned about the up axis (a circular
# shift of columns) and tinted with oiiotool (openimageio-tools), as EXR
# and Radiance .hdr, plus two broken files (a cut EXR, text named .hdr).
#   bash scripts/make_library.sh DIR [PER_WORLD]    PER_WORLD: variants of each (default 7: 56 worlds)
# Write it outside the checkout; nothing here is committed.
set -euo pipefail
DIR="${1:?usage: make_library.sh DIR [PER_WORLD]}"
PER="${2:-7}"
SRC=/usr/share/blender/datafiles/studiolights/world
command -v oiiotool >/dev/null || { echo "make_library: needs oiiotool (apt-get install openimageio-tools)" >&2; exit 1; }
[ -d "$SRC" ] || { echo "make_library: no $SRC (apt-get install blender-data)" >&2; exit 1; }
mkdir -p "$DIR"
SIZES=(2048x1024 1024x512 4096x2048 1536x768)
TINTS=(1,1,1 1.3,1.1,0.8 0.8,0.95,1.3 1,0.85,0.85 2,2,2 0.5,0.5,0.5 1.1,1.2,0.9)
n=0
for src in "$SRC"/*.exr; do
  stem=$(basename "$src" .exr)
  for ((v = 0; v < PER; v++)); do
    size=${SIZES[$((v % ${#SIZES[@]}))]}
    w=${size%x*}
    shift_px=$(( (w * v * 45 / 360) % w ))   # v x 45 degrees
    tint=${TINTS[$((v % ${#TINTS[@]}))]}
    ext=exr
    [ $((v % 3)) -eq 2 ] && ext=hdr
    out="$DIR/${stem}_v$v.$ext"
    oiiotool "$src" --resize "$size" --cshift "+$shift_px+0" --mulc "$tint" -d float -o "$out"
    n=$((n + 1))
  done
done
# Two broken worlds: a cut EXR and a text file named .hdr.
head -c 20000 "$DIR/forest_v0.exr" > "$DIR/broken_cut.exr"
printf 'these are my notes, not a picture\n' > "$DIR/broken_notes.hdr"
echo "make_library: $n worlds and 2 broken files in $DIR"
