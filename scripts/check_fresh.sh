#!/usr/bin/env bash
# Proves the README's two commands on a brand-new Debian:
#   bash scripts/check_fresh.sh SUITE [--keep DIR | --base-only]   SUITE: bookworm | trixie | sid
# debootstraps a minbase chroot of SUITE (the pristine base is cached as a
# tarball, so only the first run downloads it), copies this checkout's HEAD in
# (git archive: no build/, no untracked or uncommitted files), and runs, as
# root inside it:  bash scripts/bake_default.sh  then  bash scripts/test.sh
# The mirror is read from the host's apt sources at run time (IBLBAKE_MIRROR
# overrides); the host's resolv.conf, hosts and locally added CA certificates
# (/usr/local/share/ca-certificates) are copied in. Needs root (debootstrap,
# mounts). Prints the time of each phase.
#
# Environment:
#   IBLBAKE_CHROOT_DIR   where chroots and caches live (default /var/tmp/iblbake-chroots)
#   IBLBAKE_DEB_CACHE=0  do not keep downloaded .debs between runs (default: kept in
#                        CHROOT_DIR/cache/SUITE-debs; apt still resolves, unpacks and
#                        configures every package in the new chroot, only the download is saved)
#   IBLBAKE_MIRROR       a Debian mirror URI instead of the host's
# --keep DIR: leave the chroot at DIR when done, passed or not (a ready
# development chroot, see scripts/in_chroot.sh) instead of deleting it. --base-only: only make the
# cached base tarball.
set -euo pipefail
# All in one function: bash reads it whole before running it, so editing
# this file during a (long) run cannot change what the run does.
main() {
  usage() { echo "usage: $0 bookworm|trixie|sid [--keep DIR | --base-only]" >&2; exit 2; }
  SUITE="${1:-}"
  case "$SUITE" in bookworm|trixie|sid) ;; *) usage ;; esac
  shift
  KEEP=""
  BASE_ONLY=""
  while [ $# -gt 0 ]; do
    case "$1" in
      --keep) KEEP="${2:?--keep needs a folder}"; shift 2 ;;
      --base-only) BASE_ONLY=1; shift ;;
      *) usage ;;
    esac
  done
  if [ -n "${IBLBAKE_INSIDE_FRESH_CHECK:-}" ]; then
    echo "check_fresh: already inside a fresh-machine check; not nesting another" >&2
    exit 0
  fi
  [ "$(id -u)" -eq 0 ] || { echo "check_fresh: needs root (debootstrap, bind mounts)" >&2; exit 1; }

  REPO="$(cd "$(dirname "$0")/.." && pwd)"
  . "$REPO/scripts/chroot_lib.sh"
  case "$CHROOT_TOP/" in "$REPO"/*) echo "check_fresh: IBLBAKE_CHROOT_DIR must be outside the checkout" >&2; exit 1 ;; esac

  # --- timings -----------------------------------------------------------------
  PHASES=()
  T0=$SECONDS
  phase_start() { PHASE="$1"; PHASE_T=$SECONDS; PHASE_OPEN=1; echo "== check_fresh $SUITE: $1"; }
  phase_end() { PHASES+=("$(printf '%-34s %6d s' "$PHASE" $((SECONDS - PHASE_T)))"); PHASE_OPEN=""; }
  report() {
    echo "== check_fresh $SUITE: phase times"
    local p
    for p in "${PHASES[@]}"; do echo "   $p"; done
    printf '   %-34s %6d s\n' total $((SECONDS - T0))
  }

  chroot_host_tools
  chroot_mirrors

  # --- the chroot and its clean-up -------------------------------------------------
  RUN="$CHROOT_TOP/run-$SUITE-$$"
  IMAGE="$RUN.img"       # the chroot's own file system, when a loop mount works
  OUTPUT="$RUN.output"   # what the commands inside printed (read for warnings)
  cleanup() {
    local rc=$?
    if [ -n "${PHASE_OPEN:-}" ]; then
      PHASE="$PHASE (failed)"
      phase_end
    fi
    PHASE="clean up (unmount, delete)"; PHASE_T=$SECONDS
    chroot_umount_all
    if [ -d "$RUN" ]; then
      if grep -q " $RUN/" /proc/mounts; then
        echo "check_fresh: mounts under $RUN remain; not deleting it" >&2
      elif [ -n "$KEEP" ]; then  # kept whatever the outcome: a failure is easy to look into
        rm -rf "$KEEP"
        mkdir -p "$(dirname "$KEEP")"
        mv "$RUN" "$KEEP"
        echo "check_fresh: chroot kept at $KEEP"
      elif grep -q " $RUN " /proc/mounts; then  # its own file system: one file to delete
        umount "$RUN" && rm -f "$IMAGE" && rmdir "$RUN"
      else
        rm -rf "$RUN"
      fi
    fi
    rm -f "$OUTPUT"
    if [ ${#PHASES[@]} -gt 0 ]; then
      phase_end
      report
    fi
    exit $rc
  }
  trap cleanup EXIT
  trap 'exit 130' INT TERM HUP

  # --- 1. pristine base (cached) -----------------------------------------------------
  if [ ! -s "$CHROOT_CACHE/$SUITE-minbase.tar.zst" ]; then
    phase_start "debootstrap minbase (download)"
    chroot_base "$SUITE"
    phase_end
  fi

  if [ -n "$BASE_ONLY" ]; then
    echo "check_fresh: base of $SUITE cached at $CHROOT_CACHE/$SUITE-minbase.tar.zst"
    exit 0
  fi

  phase_start "unpack cached base"
  rm -rf "$RUN"
  mkdir -p "$RUN"
  # A throw-away chroot lives in a file system of its own (a sparse ext4 image
  # without journal or discard, loop-mounted): deleting it is deleting one
  # file, where deleting a 5 GB tree file by file took up to 6 minutes here.
  # Where loop devices are missing, a plain folder.
  if [ -z "$KEEP" ] && command -v mkfs.ext4 >/dev/null && truncate -s 48G "$IMAGE" &&
     mkfs.ext4 -q -F -E nodiscard -O ^has_journal "$IMAGE" 2>/dev/null &&
     mount -o loop,nodiscard,noatime "$IMAGE" "$RUN" 2>/dev/null; then
    echo "check_fresh: chroot in its own file system ($IMAGE, sparse)"
  else
    rm -f "$IMAGE"
  fi
  chroot_unpack "$SUITE" "$RUN"
  phase_end

  phase_start "mounts, copy checkout"
  chroot_mount "$RUN" "$SUITE"
  mkdir -p "$RUN/root/iblbake"
  if COMMIT="$(git -C "$REPO" rev-parse --short HEAD 2>/dev/null)"; then
    git -C "$REPO" archive --format=tar HEAD | tar -C "$RUN/root/iblbake" -xf -
    if ! git -C "$REPO" diff --quiet HEAD 2>/dev/null; then
      echo "check_fresh: note: uncommitted changes are not part of the check (it tests HEAD $COMMIT)"
    fi
  else  # not a git checkout (an unpacked source tree): its files without build products
    COMMIT="(no git)"
    tar -C "$REPO" --exclude=./build --exclude='./build-*' --exclude=./out --exclude=./.git \
      --exclude=__pycache__ --exclude=.pytest_cache --exclude=./dist -cf - . | tar -C "$RUN/root/iblbake" -xf -
  fi
  # The wheels and the extension zip scripts/package.sh made, when there are:
  # the suite's Blender (4.2+) installs that zip in the tests (tests/blender/test_extension.py).
  if ls "$REPO"/dist/iblbake-*.zip >/dev/null 2>&1; then
    cp -r "$REPO/dist" "$RUN/root/iblbake/dist"
    echo "check_fresh: dist/ copied in: $(cd "$REPO/dist" && echo *.zip)"
  fi
  phase_end

  in_chroot() {  # each output line prefixed with the seconds since the phase began
    local t=$SECONDS line
    local CHROOT_ENV=(IBLBAKE_INSIDE_FRESH_CHECK=1)
    chroot_run "$RUN" "cd /root/iblbake && $1" 2>&1 |
      while IFS= read -r line; do printf '[%5d s] %s\n' $((SECONDS - t)) "$line"; done | tee -a "$OUTPUT"
  }

  echo "check_fresh $SUITE: HEAD $COMMIT, mirror from the host's apt sources"
  phase_start "1. bash scripts/bake_default.sh"
  in_chroot "bash scripts/bake_default.sh"
  phase_end
  # The build ran in step 1: it must be free of compiler and linker warnings.
  if grep -E ':[0-9]+:[0-9]+: warning:|^\[ *[0-9]+ s\] [^ ]*(ld|lto-wrapper|collect2)[^ ]*: warning:' "$OUTPUT"; then
    echo "check_fresh $SUITE: FAIL: the build printed the warnings above" >&2
    exit 1
  fi
  in_chroot "cat /etc/debian_version; blender --version 2>/dev/null | head -n 1; gcc --version | head -n 1; /usr/bin/python3 --version" || true

  phase_start "2. bash scripts/test.sh"
  in_chroot "bash scripts/test.sh"
  phase_end
  echo "check_fresh $SUITE: PASS (HEAD $COMMIT)"
}
main "$@"; exit $?  # one line: nothing after it is read, even if this file changes
