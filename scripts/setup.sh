#!/usr/bin/env bash
# Installs the Debian packages hapvox needs to build, test and run, and any named as
# arguments (scripts/fuzz.sh adds clang).
# Idempotent: prints nothing and touches nothing when all are present.
set -euo pipefail

packages=(
  build-essential cmake pkg-config ccache
  libopenvdb-dev libboost-iostreams-dev libtbb-dev libblosc-dev
  libhdf5-dev libeigen3-dev libcli11-dev zlib1g-dev libtomlplusplus-dev
  libnifti2-dev libgdcm-dev
  libssl-dev  # libcrypto's SHA-256: the device bridge's HMAC tags (--device-key)
  libgtest-dev libgmock-dev libbenchmark-dev
  libegl-dev libegl-mesa0 libgl1-mesa-dri libopengl-dev libgl-dev libpng-dev
  libglfw3-dev libimgui-dev  # the sculpting window and its overlay
  xvfb xauth  # a display for the window's tests on a machine without one
  python3-h5py python3-numpy python3-matplotlib
  python3-nibabel mricron-data  # an independent NIfTI reader and real NIfTI files, for tests
  python3-pydicom  # DICOM test files and series written by another tool, for tests
  time  # GNU time: the input-limit tests measure hapvox's memory and time with it
  parallel  # sweep --hosts runs its rows through GNU parallel (GPL-3): a program run, never linked
  pybind11-dev python3-dev python3-pytest  # the Python bindings (python/) and their tests
  dpkg-dev  # cpack -G DEB: dpkg-shlibdeps works out the package's dependencies
  tetgen  # a program the mesh comparison runs (AGPL-3): never linked (docs/licences.md)
  "$@"
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "setup: installing ${missing[*]}" >&2
sudo_cmd=""
[ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo_cmd apt-get update -qq
$sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
