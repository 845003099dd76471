#!/usr/bin/env bash
# CI's package stage (issue 14): hapvox as a library an application embeds, installed two
# ways, each checked by the embed example (examples/embed) against `hapvox replay`:
#   1. `cmake --install` into a fresh prefix: the installed headers compile alone without
#      dependency headers (tests/api/check_headers.sh), examples/embed builds against the
#      prefix with find_package(hapvox), and its own 1 kHz loop's forces equal a lockstep
#      replay's bit for bit, linked to the shared libraries and again to the static ones;
#   2. the Debian package (cpack -G DEB): its dependencies resolve in Debian's archive
#      (apt-get --simulate), it unpacks into a clean root where `hapvox --version` runs,
#      the embed example builds and agrees again, and the installed Python module imports.
# Usage: scripts/package_check.sh [BUILD_DIR] (default build/, configured and built here).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-"$root/build"}
work=$(mktemp -d /tmp/hapvox-package.XXXXXX)
trap 'rm -rf "$work"' EXIT
mkdir -p "$build"
if ! bash "$root/scripts/build.sh" "$build" >"$build/package-stage.log" 2>&1; then
  tail -n 60 "$build/package-stage.log"
  echo "package_check: build failed (full log: $build/package-stage.log)" >&2
  exit 1
fi
volume=$root/data/engine_256x256x128_uint8.nrrd
trace=$root/traces/engine_press.csv
"$build/tools/hapvox" replay "$trace" --volume "$volume" -q -o "$work/press.h5" >/dev/null

embed_against() {  # PREFIX NAME [CMAKE ARGS]: builds examples/embed against PREFIX, compares
  cmake -S "$root/examples/embed" -B "$work/$2" -DCMAKE_PREFIX_PATH="$1" "${@:3}" >"$work/$2.log" 2>&1 &&
    cmake --build "$work/$2" >>"$work/$2.log" 2>&1 || {
    tail -n 40 "$work/$2.log"
    echo "package_check: examples/embed did not build against $1" >&2
    exit 1
  }
  "$work/$2/embed" "$volume" "$trace" --compare "$work/press.h5"
}

echo "-- cmake --install --strip into $work/prefix"
cmake --install "$build" --prefix "$work/prefix" --strip >/dev/null
bash "$root/tests/api/check_headers.sh" "${CXX:-c++}" "$work/prefix/include"
embed_against "$work/prefix" embed-prefix
echo "-- the same with hapvox's static libraries (hapvox::haptics_static)"
embed_against "$work/prefix" embed-static -DEMBED_STATIC=ON

echo "-- cpack -G DEB"
(cd "$build" && cpack -G DEB >"$work/cpack.log" 2>&1) || {
  tail -n 40 "$work/cpack.log"
  exit 1
}
deb=$(ls "$build"/hapvox_*.deb)
dpkg-deb --field "$deb" Package Version Depends
apt-get install --simulate --no-install-recommends "$deb" >"$work/apt.log" 2>&1 || {
  cat "$work/apt.log"
  echo "package_check: the package's dependencies do not resolve" >&2
  exit 1
}
dpkg-deb -x "$deb" "$work/root"
libdir=$(dirname "$(find "$work/root" -name 'libhapvox_haptics.so' | head -n 1)")
LD_LIBRARY_PATH=$libdir "$work/root/usr/bin/hapvox" --version | head -n 1
embed_against "$work/root/usr" embed-deb
PYTHONPATH="$work/root/usr/lib/python3/dist-packages" /usr/bin/python3 -c \
  'import hapvox, sys; print("python: import hapvox", hapvox.__version__, "from", hapvox.__file__)'
