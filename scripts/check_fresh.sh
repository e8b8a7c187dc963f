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
  TOP="${IBLBAKE_CHROOT_DIR:-/var/tmp/iblbake-chroots}"
  case "$TOP/" in "$REPO"/*) echo "check_fresh: IBLBAKE_CHROOT_DIR must be outside the checkout" >&2; exit 1 ;; esac
  CACHE="$TOP/cache"
  BASE_TAR="$CACHE/$SUITE-minbase.tar.zst"
  DEBS="$CACHE/$SUITE-debs"
  mkdir -p "$CACHE"

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

  # --- host tools ----------------------------------------------------------------
  need=()
  command -v debootstrap >/dev/null || need+=(debootstrap)
  command -v zstd >/dev/null || need+=(zstd)
  command -v git >/dev/null || need+=(git)
  if [ ${#need[@]} -gt 0 ]; then
    echo "check_fresh: installing on the host: ${need[*]}"
    apt-get -o DPkg::Lock::Timeout=900 update -qq
    DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends "${need[@]}"
  fi

  # --- the mirror, from the host's apt sources (never written into the repo) -----
  # Prints "ARCHIVE_URI SECURITY_URI" (SECURITY_URI may be empty).
  host_mirrors() {
    local files=()
    [ -f /etc/apt/sources.list ] && files+=(/etc/apt/sources.list)
    shopt -s nullglob
    local f
    for f in /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources; do files+=("$f"); done
    shopt -u nullglob
    [ ${#files[@]} -gt 0 ] || return 0
    awk '
      function take(uri, suites,   n, a, i, sec) {
        n = split(suites, a, /[ \t]+/); sec = 0
        for (i = 1; i <= n; i++) if (a[i] ~ /-security$/) sec = 1
        if (sec) { if (security == "") security = uri } else if (archive == "") archive = uri
      }
      FILENAME ~ /\.sources$/ {
        if ($0 ~ /^[ \t]*$/) { if (uris != "" && types ~ /(^|[ \t])deb([ \t]|$)/) take(uris, suites); uris = suites = types = ""; next }
        if ($1 == "Types:") { types = $0; sub(/^Types:[ \t]*/, "", types) }
        if ($1 == "URIs:") uris = $2
        if ($1 == "Suites:") { suites = $0; sub(/^Suites:[ \t]*/, "", suites) }
        next
      }
      ENDFILE { if (uris != "" && types ~ /(^|[ \t])deb([ \t]|$)/) take(uris, suites); uris = suites = types = "" }
      $1 == "deb" {
        i = 2
        if ($2 ~ /^\[/) { while (i <= NF && $i !~ /\]$/) i++; i++ }
        take($i, $(i + 1))
      }
      END { print archive, security }
    ' "${files[@]}"
  }
  read -r MIRROR SECURITY_MIRROR < <(host_mirrors) || true
  MIRROR="${IBLBAKE_MIRROR:-$MIRROR}"
  [ -n "$MIRROR" ] || { echo "check_fresh: no Debian mirror in the host's apt sources; set IBLBAKE_MIRROR" >&2; exit 1; }
  MIRROR="${MIRROR%/}"
  SECURITY_MIRROR="${SECURITY_MIRROR%/}"

  # --- the chroot and its clean-up -------------------------------------------------
  RUN="$TOP/run-$SUITE-$$"
  IMAGE="$RUN.img"       # the chroot's own file system, when a loop mount works
  OUTPUT="$RUN.output"   # what the commands inside printed (read for warnings)
  MOUNTS=()
  cleanup() {
    local rc=$?
    local i
    if [ -n "${PHASE_OPEN:-}" ]; then
      PHASE="$PHASE (failed)"
      phase_end
    fi
    PHASE="clean up (unmount, delete)"; PHASE_T=$SECONDS
    for ((i = ${#MOUNTS[@]} - 1; i >= 0; i--)); do
      umount -R "${MOUNTS[$i]}" 2>/dev/null || umount -lR "${MOUNTS[$i]}" 2>/dev/null || true
    done
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
  if [ ! -s "$BASE_TAR" ]; then
    phase_start "debootstrap minbase (download)"
    BOOT="$TOP/boot-$SUITE-$$"
    rm -rf "$BOOT"
    if ! debootstrap --variant=minbase "$SUITE" "$BOOT" "$MIRROR"; then
      tail -n 30 "$BOOT/debootstrap/debootstrap.log" 2>/dev/null >&2 || true
      rm -rf "$BOOT"
      exit 1
    fi
    rm -f "$BOOT/etc/resolv.conf" "$BOOT/etc/hostname"
    tar -C "$BOOT" --numeric-owner -cf - . | zstd -q -T0 -3 -o "$BASE_TAR.tmp"
    mv "$BASE_TAR.tmp" "$BASE_TAR"
    rm -rf "$BOOT"
    phase_end
  fi

  if [ -n "$BASE_ONLY" ]; then
    echo "check_fresh: base of $SUITE cached at $BASE_TAR"
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
  zstd -q -dc "$BASE_TAR" | tar -C "$RUN" --numeric-owner -xf -
  phase_end

  phase_start "configure apt, mounts, copy checkout"
  if [ "$SUITE" = sid ]; then
    printf 'deb %s sid main\n' "$MIRROR" > "$RUN/etc/apt/sources.list"
    # unstable's Release files on a snapshot mirror are past their Valid-Until
    echo 'Acquire::Check-Valid-Until "false";' > "$RUN/etc/apt/apt.conf.d/99iblbake-sid"
  else
    {
      printf 'deb %s %s main\n' "$MIRROR" "$SUITE"
      printf 'deb %s %s-updates main\n' "$MIRROR" "$SUITE"
      [ -z "$SECURITY_MIRROR" ] || printf 'deb %s %s-security main\n' "$SECURITY_MIRROR" "$SUITE"
    } > "$RUN/etc/apt/sources.list"
  fi
  rm -f "$RUN/etc/apt/sources.list.d/"*.sources 2>/dev/null || true
  # The host's network, as it is: its name servers, hosts, and the CA
  # certificates its administrator added (a TLS-inspecting proxy's, without
  # which npm cannot reach its registry); ca-certificates, once installed,
  # trusts them as it does on the host.
  cp -L /etc/resolv.conf "$RUN/etc/resolv.conf"
  cp /etc/hosts "$RUN/etc/hosts"
  local crt
  for crt in /usr/local/share/ca-certificates/*.crt; do
    [ -f "$crt" ] || continue
    mkdir -p "$RUN/usr/local/share/ca-certificates"
    cp "$crt" "$RUN/usr/local/share/ca-certificates/"
  done
  [ -e "$RUN/etc/mtab" ] || ln -s ../proc/self/mounts "$RUN/etc/mtab"  # as on an installed system
  # dpkg without an fsync per file (a throw-away chroot; what is installed is the same)
  echo force-unsafe-io > "$RUN/etc/dpkg/dpkg.cfg.d/iblbake-unsafe-io"
  mount_in() {  # mount_in TARGET mount-args...
    local target="$RUN$1"; shift
    mkdir -p "$target"
    mount "$@" "$target"
    MOUNTS+=("$target")
  }
  mount_in /proc -t proc proc
  mount_in /sys --rbind /sys
  mount --make-rslave "$RUN/sys"
  mount_in /dev --rbind /dev
  mount --make-rslave "$RUN/dev"
  if [ "${IBLBAKE_DEB_CACHE:-1}" != 0 ]; then
    mkdir -p "$DEBS"
    mount_in /var/cache/apt/archives --bind "$DEBS"
  fi
  mkdir -p "$RUN/root/iblbake"
  if COMMIT="$(git -C "$REPO" rev-parse --short HEAD 2>/dev/null)"; then
    git -C "$REPO" archive --format=tar HEAD | tar -C "$RUN/root/iblbake" -xf -
    if ! git -C "$REPO" diff --quiet HEAD 2>/dev/null; then
      echo "check_fresh: note: uncommitted changes are not part of the check (it tests HEAD $COMMIT)"
    fi
  else  # not a git checkout (an unpacked source tree): its files without build products
    COMMIT="(no git)"
    tar -C "$REPO" --exclude=./build --exclude='./build-*' --exclude=./out --exclude=./.git \
      --exclude=__pycache__ --exclude=.pytest_cache -cf - . | tar -C "$RUN/root/iblbake" -xf -
  fi
  phase_end

  in_chroot() {  # each output line prefixed with the seconds since the phase began
    local t=$SECONDS line
    chroot "$RUN" /usr/bin/env -i HOME=/root LANG=C.UTF-8 TERM=dumb \
      PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
      IBLBAKE_INSIDE_FRESH_CHECK=1 \
      /bin/bash -c "cd /root/iblbake && $1" 2>&1 |
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
