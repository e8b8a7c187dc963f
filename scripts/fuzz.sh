#!/usr/bin/env bash
# Fuzzes the image readers (tests/fuzz/fuzz_read_image.cpp) with libFuzzer
# for a bounded time, niced. Installs clang and its runtime on demand (not a
# test dependency), builds into build-fuzz/ (sanitized: address, undefined,
# fuzzer), seeds from the hostile corpus (tests/hostile/corpus.py) and keeps
# what it finds in build-fuzz/findings/.
#
#   bash scripts/fuzz.sh [SECONDS (default 600)] [JOBS (default 1)]
#
# Exit code: 0 when nothing was found, 1 when a crash, leak, timeout or
# out-of-memory input was saved (its path is printed).
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_TOTAL="${1:-600}"
JOBS="${2:-1}"
OUT="${IBLBAKE_FUZZ_DIR:-build-fuzz}"

need=()
command -v clang++ >/dev/null || need+=(clang)
ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1 || need+=(libclang-rt-dev)
if [ ${#need[@]} -gt 0 ]; then
  echo "fuzz: installing ${need[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get -o DPkg::Lock::Timeout=900 update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends "${need[@]}"
fi
bash scripts/install_deps.sh >/dev/null

mkdir -p "$OUT/obj" "$OUT/corpus" "$OUT/seeds" "$OUT/findings"
CXX=clang++
SAN=(-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g -O1)
INC=(-Inative/include $(pkg-config --cflags OpenEXR libpng libjpeg OpenImageIO))
SRCS=(native/src/io/image_io.cpp native/src/io/exr_file.cpp native/src/io/png_file.cpp native/src/io/jpeg_file.cpp
      native/src/io/hdr_file.cpp
      native/src/io/tiff_check.cpp native/src/io/text.cpp native/src/math/half.cpp native/src/image/image.cpp)
echo "fuzz: building into $OUT"
objs=()
for s in "${SRCS[@]}" tests/fuzz/fuzz_read_image.cpp; do
  o="$OUT/obj/$(basename "${s%.cpp}").o"
  nice $CXX -std=c++17 "${SAN[@]}" -fsanitize=fuzzer-no-link "${INC[@]}" -c "$s" -o "$o"
  objs+=("$o")
done
nice $CXX -std=c++17 "${SAN[@]}" -fsanitize=fuzzer-no-link -fPIC -shared "${INC[@]}" native/src/io/oiio_plugin.cpp \
  -o "$OUT/libiblbake_oiio.so" $(pkg-config --libs OpenImageIO)
nice $CXX "${SAN[@]}" -fsanitize=fuzzer "${objs[@]}" -o "$OUT/fuzz_read_image" \
  $(pkg-config --libs OpenEXR libpng libjpeg) -ltbb -ldl -lpthread

# Seeds: the corpus's inputs under 64 KiB (good files of every format, cuts, fuzzed headers, bombs).
if [ -z "$(ls -A "$OUT/seeds")" ]; then
  tmp=$(mktemp -d)
  /usr/bin/python3 tests/hostile/corpus.py "$tmp" >/dev/null
  # The target reads its first byte as the extension's index: 0 .exr, 1 .png, 2 .hdr, 3 .tga, 4 .tif, 5 .jpg, 6 .bmp.
  for f in "$tmp"/*; do
    [ "$(stat -c %s "$f")" -le 65536 ] || continue
    case "$f" in
      *.exr) b='\x00' ;; *.png) b='\x01' ;; *.hdr) b='\x02' ;; *.tga) b='\x03' ;; *.tif) b='\x04' ;;
      *.jpg) b='\x05' ;; *.bmp) b='\x06' ;; *) b='\x07' ;;
    esac
    { printf "$b"; cat "$f"; } > "$OUT/seeds/$(basename "$f")"
  done
  rm -rf "$tmp"
fi

echo "fuzz: running for $SECONDS_TOTAL s with $JOBS job(s), niced"
export IBLBAKE_OIIO_PLUGIN="$PWD/$OUT/libiblbake_oiio.so"
export ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:${UBSAN_OPTIONS:-}"
export IBLBAKE_FUZZ_TMP="${IBLBAKE_FUZZ_TMP:-/dev/shm}"
set +e
PAR=()
[ "$JOBS" -le 1 ] || PAR=(-fork="$JOBS" -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
( cd "$OUT" && nice -n 19 ./fuzz_read_image -max_total_time="$SECONDS_TOTAL" -rss_limit_mb=2048 -timeout=60 -report_slow_units=120 \
    -max_len=65536 "${PAR[@]}" -artifact_prefix=findings/ -print_final_stats=1 corpus seeds > fuzz.log 2>&1 )
rc=$?
set -e
tail -n 25 "$OUT/fuzz.log"
found=$(ls "$OUT/findings" | wc -l)
echo "fuzz: exit $rc, $found finding(s) in $OUT/findings, corpus $(ls "$OUT/corpus" | wc -l) inputs"
[ "$found" -eq 0 ]
