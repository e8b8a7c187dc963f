# Debian chroots from the host's own mirror, shared by check_fresh.sh (the
# README's commands on a new machine), package.sh (the wheels, built on Debian
# 11) and check_wheels.sh (the wheels on machines that never built them).
# Sourced, never run; needs root. Functions only, all prefixed chroot_.
#
#   chroot_mirrors              sets MIRROR and SECURITY_MIRROR from the host's apt
#                               sources (IBLBAKE_MIRROR overrides; never written into the repo)
#   chroot_base SUITE           the pristine minbase of SUITE, cached as a tarball; sets BASE_TAR
#   chroot_unpack SUITE ROOT    ROOT := that base, with apt sources, the host's network
#                               files and CA certificates
#   chroot_mount ROOT SUITE     /proc, /sys, /dev and the suite's .deb cache; undone by chroot_umount_all
#   chroot_run ROOT CMD         CMD under bash inside ROOT, with a clean environment (+ CHROOT_ENV)
#   chroot_apt ROOT PKG...      apt-get install --no-install-recommends, quietly
#
# IBLBAKE_CHROOT_DIR: where bases, .deb caches and chroots live (default
# /var/tmp/iblbake-chroots). IBLBAKE_DEB_CACHE=0: keep no .debs between runs.

CHROOT_TOP="${IBLBAKE_CHROOT_DIR:-/var/tmp/iblbake-chroots}"
CHROOT_CACHE="$CHROOT_TOP/cache"
CHROOT_MOUNTS=()

chroot_host_tools() {  # debootstrap, zstd and git on the host
  local need=()
  command -v debootstrap >/dev/null || need+=(debootstrap)
  command -v zstd >/dev/null || need+=(zstd)
  command -v git >/dev/null || need+=(git)
  if [ ${#need[@]} -gt 0 ]; then
    echo "chroot: installing on the host: ${need[*]}"
    apt-get -o DPkg::Lock::Timeout=900 update -qq
    DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends "${need[@]}"
  fi
}

# Prints "ARCHIVE_URI SECURITY_URI" (SECURITY_URI may be empty) from the
# host's one-line and deb822 apt sources.
chroot_host_mirrors() {
  local files=() f
  [ -f /etc/apt/sources.list ] && files+=(/etc/apt/sources.list)
  shopt -s nullglob
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

chroot_mirrors() {
  [ -z "${MIRROR:-}" ] || return 0
  read -r MIRROR SECURITY_MIRROR < <(chroot_host_mirrors) || true
  MIRROR="${IBLBAKE_MIRROR:-$MIRROR}"
  [ -n "$MIRROR" ] || { echo "chroot: no Debian mirror in the host's apt sources; set IBLBAKE_MIRROR" >&2; return 1; }
  MIRROR="${MIRROR%/}"
  SECURITY_MIRROR="${SECURITY_MIRROR%/}"
}

chroot_base() {  # chroot_base SUITE: the cached minbase tarball of SUITE
  local suite="$1" boot
  chroot_mirrors
  mkdir -p "$CHROOT_CACHE"
  BASE_TAR="$CHROOT_CACHE/$suite-minbase.tar.zst"
  [ -s "$BASE_TAR" ] && return 0
  boot="$CHROOT_TOP/boot-$suite-$$"
  rm -rf "$boot"
  if ! debootstrap --variant=minbase "$suite" "$boot" "$MIRROR"; then
    tail -n 30 "$boot/debootstrap/debootstrap.log" 2>/dev/null >&2 || true
    rm -rf "$boot"
    return 1
  fi
  rm -f "$boot/etc/resolv.conf" "$boot/etc/hostname"
  tar -C "$boot" --numeric-owner -cf - . | zstd -q -T0 -3 -o "$BASE_TAR.tmp"
  mv "$BASE_TAR.tmp" "$BASE_TAR"
  rm -rf "$boot"
}

# chroot_sources SUITE: the apt sources of SUITE (stable releases with their
# updates and security suites; unstable with its Valid-Until ignored, as on
# a snapshot mirror).
chroot_sources() {
  local suite="$1"
  if [ "$suite" = sid ]; then
    printf 'deb %s sid main\n' "$MIRROR"
  else
    printf 'deb %s %s main\n' "$MIRROR" "$suite"
    printf 'deb %s %s-updates main\n' "$MIRROR" "$suite"
    [ -z "$SECURITY_MIRROR" ] || printf 'deb %s %s-security main\n' "$SECURITY_MIRROR" "$suite"
  fi
}

chroot_unpack() {  # chroot_unpack SUITE ROOT (ROOT empty or missing)
  local suite="$1" root="$2" crt
  chroot_base "$suite"
  mkdir -p "$root"
  zstd -q -dc "$BASE_TAR" | tar -C "$root" --numeric-owner -xf -
  chroot_sources "$suite" > "$root/etc/apt/sources.list"
  [ "$suite" != sid ] || echo 'Acquire::Check-Valid-Until "false";' > "$root/etc/apt/apt.conf.d/99iblbake-sid"
  rm -f "$root/etc/apt/sources.list.d/"*.sources 2>/dev/null || true
  # The host's network, as it is: its name servers, hosts, and the CA
  # certificates its administrator added (a TLS-inspecting proxy's, without
  # which npm cannot reach its registry); ca-certificates, once installed,
  # trusts them as it does on the host.
  cp -L /etc/resolv.conf "$root/etc/resolv.conf"
  cp /etc/hosts "$root/etc/hosts"
  for crt in /usr/local/share/ca-certificates/*.crt; do
    [ -f "$crt" ] || continue
    mkdir -p "$root/usr/local/share/ca-certificates"
    cp "$crt" "$root/usr/local/share/ca-certificates/"
  done
  [ -e "$root/etc/mtab" ] || ln -s ../proc/self/mounts "$root/etc/mtab"  # as on an installed system
  # dpkg without an fsync per file (a throw-away chroot; what is installed is the same)
  echo force-unsafe-io > "$root/etc/dpkg/dpkg.cfg.d/iblbake-unsafe-io"
}

chroot_mount_one() {  # chroot_mount_one TARGET mount-args...
  local target="$1"; shift
  mkdir -p "$target"
  mount "$@" "$target"
  CHROOT_MOUNTS+=("$target")
}

chroot_mount() {  # chroot_mount ROOT SUITE
  local root="$1" suite="$2"
  chroot_mount_one "$root/proc" -t proc proc
  chroot_mount_one "$root/sys" --rbind /sys
  mount --make-rslave "$root/sys"
  chroot_mount_one "$root/dev" --rbind /dev
  mount --make-rslave "$root/dev"
  if [ "${IBLBAKE_DEB_CACHE:-1}" != 0 ]; then
    mkdir -p "$CHROOT_CACHE/$suite-debs"
    chroot_mount_one "$root/var/cache/apt/archives" --bind "$CHROOT_CACHE/$suite-debs"
  fi
}

chroot_umount_all() {
  local i
  for ((i = ${#CHROOT_MOUNTS[@]} - 1; i >= 0; i--)); do
    umount -R "${CHROOT_MOUNTS[$i]}" 2>/dev/null || umount -lR "${CHROOT_MOUNTS[$i]}" 2>/dev/null || true
  done
  CHROOT_MOUNTS=()
}

# chroot_run ROOT CMD: CMD under bash in ROOT, in a clean environment plus
# the VAR=value words of the array CHROOT_ENV.
chroot_run() {
  local root="$1" cmd="$2"
  chroot "$root" /usr/bin/env -i HOME=/root LANG=C.UTF-8 TERM=dumb \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin ${CHROOT_ENV[@]+"${CHROOT_ENV[@]}"} \
    /bin/bash -c "$cmd"
}

chroot_apt() {  # chroot_apt ROOT PKG...: installed with --no-install-recommends
  local root="$1"; shift
  chroot_run "$root" "apt-get -o DPkg::Lock::Timeout=900 update -qq &&
    DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends $* >/dev/null"
}
