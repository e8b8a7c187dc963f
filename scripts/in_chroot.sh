#!/usr/bin/env bash
# Runs a command as root in a development chroot (one that
# `scripts/check_fresh.sh SUITE --keep DIR` left, with every dependency
# installed), with host folders bind-mounted at the same paths inside:
#   bash scripts/in_chroot.sh [-b DIR]... [-e VAR=VALUE]... CHROOT CMD [ARGS...]
# CHROOT is a folder, or a suite name meaning $IBLBAKE_CHROOT_DIR/SUITE-dev
# (default folder /var/tmp/iblbake-chroots). The git checkout holding the
# current folder (else the current folder) is bound, and each -b DIR too; the
# command runs in the current folder's path. Mounts (/proc, /sys, /dev and the
# binds) live in a private mount namespace: they vanish when the command ends,
# however it ends, and several commands may use one chroot at once.
# Use a build folder of its own per chroot, e.g. -e IBLBAKE_BUILD_DIR=build-trixie.
set -euo pipefail
main() {
  local binds=() envs=() root cwd d
  while [ $# -gt 0 ]; do
    case "$1" in
      -b) binds+=("$(realpath "${2:?-b needs a folder}")"); shift 2 ;;
      -e) envs+=("${2:?-e needs VAR=VALUE}"); shift 2 ;;
      -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
      --) shift; break ;;
      *) break ;;
    esac
  done
  [ $# -ge 2 ] || { echo "usage: $0 [-b DIR]... [-e VAR=VALUE]... CHROOT CMD [ARGS...]" >&2; exit 2; }
  root="$1"; shift
  case "$root" in
    */*) ;;
    *) root="${IBLBAKE_CHROOT_DIR:-/var/tmp/iblbake-chroots}/$root-dev" ;;
  esac
  [ -x "$root/bin/bash" ] || { echo "in_chroot: no chroot at $root" >&2; exit 1; }
  [ "$(id -u)" -eq 0 ] || { echo "in_chroot: needs root (chroot, mounts)" >&2; exit 1; }
  root="$(realpath "$root")"
  cwd="$(pwd)"
  binds=("$(git -C "$cwd" rev-parse --show-toplevel 2>/dev/null || echo "$cwd")" "${binds[@]}")
  for d in "${binds[@]}"; do
    case "$d" in /|/proc*|/sys*|/dev*) echo "in_chroot: will not bind $d" >&2; exit 1 ;; esac
  done
  # In a new mount namespace (private propagation): nothing leaks to the host.
  exec unshare --mount --propagation private /bin/bash -euo pipefail -c '
    root="$1"; cwd="$2"; nb="$3"; shift 3
    binds=("${@:1:$nb}"); shift "$nb"
    ne="$1"; shift
    envs=("${@:1:$ne}"); shift "$ne"
    mount -t proc proc "$root/proc"
    mount --rbind /sys "$root/sys"
    mount --rbind /dev "$root/dev"
    for d in "${binds[@]}"; do
      mkdir -p "$root$d"
      mount --bind "$d" "$root$d"
    done
    cp -L /etc/resolv.conf "$root/etc/resolv.conf" 2>/dev/null || true
    [ -d "$root$cwd" ] || cwd=/root
    exec chroot "$root" /usr/bin/env -i HOME=/root LANG=C.UTF-8 TERM="${TERM:-dumb}" \
      PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "${envs[@]}" \
      /bin/bash -c "cd \"\$1\" && shift && exec \"\$@\"" in_chroot "$cwd" "$@"
  ' in_chroot "$root" "$cwd" "${#binds[@]}" "${binds[@]}" "${#envs[@]}" "${envs[@]}" "$@"
}
main "$@"
