#!/usr/bin/env bash
# Installs iblbake's build and test dependencies from Debian's archive
# (Debian 12 bookworm, Debian 13 trixie, Debian unstable; each proved in a
# fresh minbase chroot by scripts/check_fresh.sh).
# Does nothing when everything is already installed. Every package the build
# and the tests use is named here: installs use --no-install-recommends, which
# drops packages that CMake config files rely on silently.
set -euo pipefail

# --- which Debian ------------------------------------------------------------
. /etc/os-release 2>/dev/null || true
RELEASE=""
if [ "${ID:-}" = debian ]; then
  case "${VERSION_CODENAME:-}:${VERSION_ID:-}" in
    bookworm:*|*:12) RELEASE=bookworm ;;
    trixie:*|*:13) RELEASE=trixie ;;
    *:) RELEASE=sid ;;  # unstable (and testing) have no VERSION_ID
  esac
fi
if [ -z "$RELEASE" ]; then
  echo "install_deps: unsupported system (${PRETTY_NAME:-no /etc/os-release}): supported are Debian 12 bookworm, Debian 13 trixie and Debian unstable; elsewhere install the packages named in scripts/install_deps.sh by hand" >&2
  exit 1
fi

# --- what each part needs (one group a line; release differences here) -------
BUILD=(build-essential cmake pkg-config ca-certificates git)
LIBS=(libopenimageio-dev openimageio-tools libopenexr-dev libpng-dev libtbb-dev
      nlohmann-json3-dev libssl-dev libcli11-dev
      libdeflate-dev zlib1g-dev)  # EXR ZIP blocks, and the CLI's zlib one-shot calls, through libdeflate
HOSTILE=(libjpeg-dev)  # JPEG read with libjpeg directly (issue 15)
PYTHON=(python3-dev python3-numpy pybind11-dev)
TESTS=(libgtest-dev libgmock-dev python3-pytest)
BENCH=(python3-matplotlib time)  # bench/run.sh: plots, peak memory
BLENDER=(blender blender-data)
# Blender 5.2's own extension manager (bl_pkg) imports cattrs and requests,
# which Debian's blender package does not depend on.
[ "$RELEASE" != sid ] || BLENDER+=(python3-cattr python3-requests)
GUI=(xvfb xauth imagemagick xdotool)  # the panel's test in a real window (tests/gui)
# docs/farm.md's sbatch array on a one-node Slurm (tests/farm, CTest farm_slurm, run as root)
FARM=(munge slurmctld slurmd slurm-client)
# The bake on emulated AVX2 and plain x86-64 CPUs (tests/cpu, CTest cpu_emulated)
CPUS=(qemu-user)
EXPORT=(libzstd-dev python3-zstandard)
# scripts/package.sh and check_wheels.sh: Debian chroots; the wheels read by pip and python3-wheel
PACKAGING=(debootstrap zstd binutils python3-pip python3-wheel)
# Engine tests: Debian's chromium (headless, SwiftShader); node and npm from
# Debian unless an npm is already on PATH (nodesource's nodejs ships its own
# npm and conflicts with Debian's npm package).
BROWSER=(chromium)
command -v npm >/dev/null 2>&1 || BROWSER+=(nodejs npm)

PACKAGES=("${BUILD[@]}" "${LIBS[@]}" "${HOSTILE[@]}" "${PYTHON[@]}" "${TESTS[@]}" "${BENCH[@]}" "${BLENDER[@]}" "${GUI[@]}"
          "${FARM[@]}" "${CPUS[@]}" "${EXPORT[@]}" "${PACKAGING[@]}" "${BROWSER[@]}")

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present ($RELEASE)"
  exit 0
fi
echo "install_deps ($RELEASE): installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
APT=($SUDO apt-get -o DPkg::Lock::Timeout=900)
"${APT[@]}" update -qq
"${APT[@]}" install -y -qq --no-install-recommends "${missing[@]}"
