#!/usr/bin/env bash
# Makes dist/: the Blender 4.2+ extension zip for linux-x64 and the three
# self-contained wheels of iblbake_core inside it (CPython 3.11, 3.13, 3.14).
#   bash scripts/package.sh          (as root, on Debian 12 or 13)
#
# Built in a Debian 11 (bullseye, glibc 2.31, GCC 10) chroot from the host's
# own mirror, kept between runs in $IBLBAKE_CHROOT_DIR/wheel-build (remade
# when scripts/wheel/ changes):
#   - zlib, libpng, libjpeg-turbo, zstd, Imath, OpenEXR and oneTBB from
#     Debian 12's source packages as static, position-independent libraries
#     (scripts/wheel/build_deps.sh), OpenSSL's libcrypto from Debian 11;
#   - Python's headers from Debian's libpython3.11-dev (12), libpython3.13-dev
#     (13) and libpython3.14-dev (unstable), pybind11 from unstable and
#     nlohmann-json from 12: downloaded with the host's apt and unpacked, not
#     installed;
#   - the module once per Python, everything but the C runtime linked in,
#     only PyInit_iblbake_core exported (native/python/wheel_modules.cmake).
# Then every ELF file is checked: it needs no library but glibc's, no glibc
# symbol version above the tag it is given (measured, not assumed), and
# exports nothing else. scripts/wheel/make_dist.py writes the wheels, the
# zip and dist/build-info.json (per file: glibc needed, size, sha256).
# Nothing is fetched but Debian packages. The source is this working tree
# (its tracked and untracked, not ignored, files).
set -euo pipefail
main() {
  [ "$(id -u)" -eq 0 ] || { echo "package: needs root (a Debian 11 chroot builds the wheels)" >&2; exit 1; }
  REPO="$(cd "$(dirname "$0")/.." && pwd)"
  . "$REPO/scripts/chroot_lib.sh"
  local pythons="3.11;3.13;3.14"
  local root="$CHROOT_TOP/wheel-build"
  local t0=$SECONDS
  mkdir -p "$CHROOT_TOP"
  exec 9>"$CHROOT_TOP/wheel-build.lock"
  flock 9  # one package.sh at a time per chroot folder
  trap 'chroot_umount_all' EXIT
  trap 'exit 130' INT TERM HUP
  chroot_host_tools
  local host_need=()
  command -v readelf >/dev/null || host_need+=(binutils)
  [ -x /usr/bin/python3 ] || host_need+=(python3)
  if [ ${#host_need[@]} -gt 0 ]; then
    apt-get -o DPkg::Lock::Timeout=900 update -qq
    DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends "${host_need[@]}"
  fi
  chroot_mirrors

  # --- 1. the build chroot: Debian 11, its tools, the static libraries -------------
  local tools=(build-essential cmake pkg-config dpkg-dev nasm ca-certificates libssl-dev xz-utils bzip2)
  local stamp
  stamp="$(cat "$REPO/scripts/wheel/build_deps.sh" "$REPO/scripts/wheel/glibc_pins.h" "$REPO/scripts/chroot_lib.sh" \
           <(echo "${tools[*]}") | sha256sum | cut -c1-16)"
  if [ "$(cat "$root/.iblbake-stamp" 2>/dev/null)" != "$stamp" ]; then
    echo "package: making the Debian 11 build chroot ($root)"
    rm -rf "$root"
    chroot_unpack bullseye "$root"
    # Debian 12's sources for the static libraries (apt-get source only).
    {
      printf 'deb-src %s bookworm main\n' "$MIRROR"
      printf 'deb-src %s bookworm-updates main\n' "$MIRROR"
      [ -z "$SECURITY_MIRROR" ] || printf 'deb-src %s bookworm-security main\n' "$SECURITY_MIRROR"
    } >> "$root/etc/apt/sources.list"
    chroot_mount "$root" bullseye
    chroot_apt "$root" "${tools[@]}"
    mkdir -p "$root/opt/wheel"
    cp "$REPO/scripts/wheel/build_deps.sh" "$REPO/scripts/wheel/glibc_pins.h" "$root/opt/wheel/"
    local t=$SECONDS
    chroot_run "$root" "bash /opt/wheel/build_deps.sh /opt/deps /opt/wheel/glibc_pins.h"
    echo "package: static libraries built in $((SECONDS - t)) s"
    echo "$stamp" > "$root/.iblbake-stamp"
  else
    chroot_mount "$root" bullseye
  fi

  # --- 2. Python's headers, pybind11, nlohmann-json: other releases' .debs, unpacked --------
  local headers="$root/opt/headers"
  local want=(libpython3.11-dev/bookworm libpython3.13-dev/trixie libpython3.14-dev/sid
              pybind11-dev/sid nlohmann-json3-dev/bookworm)
  if [ "$(cat "$headers/.iblbake-want" 2>/dev/null)" != "${want[*]}" ]; then
    local side="$CHROOT_CACHE/wheel-headers"
    rm -rf "$side/debs" "$headers"
    mkdir -p "$side/lists/partial" "$side/archives/partial" "$side/debs" "$headers"
    local s
    for s in bookworm trixie sid; do printf 'deb %s %s main\n' "$MIRROR" "$s"; done > "$side/sources.list"
    # The host's apt, its own keyring, a private list of packages: nothing installed.
    local apt=(apt-get -q -o Dir::Etc::SourceList="$side/sources.list" -o Dir::Etc::SourceParts=/nonexistent
               -o Dir::State::Lists="$side/lists" -o Dir::Cache::Archives="$side/archives"
               -o Acquire::Check-Valid-Until=false -o APT::Sandbox::User=root)
    "${apt[@]}" update >/dev/null
    (cd "$side/debs" && "${apt[@]}" download "${want[@]}" >/dev/null)
    local deb
    for deb in "$side/debs"/*.deb; do dpkg-deb -x "$deb" "$headers"; done
    (cd "$side/debs" && ls *.deb) > "$headers/versions.txt"
    echo "${want[*]}" > "$headers/.iblbake-want"
  fi

  # --- 3. the modules ----------------------------------------------------------------
  local src="$root/opt/src/iblbake" stage="$root/opt/src/iblbake.new"
  rm -rf "$stage"
  mkdir -p "$stage" "$src"
  # This working tree's files, copied by content (the build folder is kept: an
  # unchanged file is not compiled again, a changed one always is, whichever
  # checkout built last).
  (cd "$REPO" && git ls-files -z -co --exclude-standard | tar --null -T - --ignore-failed-read -cf - 2>/dev/null) |
    tar -C "$stage" -xf -
  /usr/bin/python3 "$REPO/scripts/wheel/sync_tree.py" "$stage" "$src"
  rm -rf "$stage"
  cp "$REPO/scripts/wheel/glibc_pins.h" "$root/opt/wheel/"
  local t=$SECONDS
  chroot_run "$root" "bash /opt/src/iblbake/scripts/wheel/build_modules.sh /opt/src/iblbake /opt/build /opt/deps \
    /opt/headers /opt/wheel/glibc_pins.h '$pythons'" | grep -E 'warning|error|Linking' || true
  [ "${PIPESTATUS[0]}" -eq 0 ] || { echo "package: the modules did not build" >&2; exit 1; }
  echo "package: modules built in $((SECONDS - t)) s"

  # --- 4. the wheels, the zip, build-info.json ------------------------------------------
  local describe
  describe="$(git -C "$REPO" describe --always --dirty 2>/dev/null || echo unknown)"
  /usr/bin/python3 "$REPO/scripts/wheel/make_dist.py" --modules "$root/opt/build/wheel" --addon "$REPO/addon/iblbake" \
    --out "$REPO/dist" --source-version "$describe" --deps "$root/opt/deps/versions.txt" \
    --headers "$headers/versions.txt"
  echo "package: dist/ made in $((SECONDS - t0)) s"
}
main "$@"; exit $?
