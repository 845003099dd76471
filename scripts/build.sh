#!/usr/bin/env bash
# Configures and builds hapvox.
# Usage: scripts/build.sh [--target "TARGET..."]... [BUILD_DIR] [extra cmake args...]
# Without --target, everything (the hapvox command and the test suite) is built; with it,
# only the targets named (a space-separated list, or --target given again). The
# compiler runs through ccache when ccache is on PATH (its cache lives under $HOME), told
# that precompiled headers are safe to cache: without that sloppiness a file-by-file build
# (-DCMAKE_UNITY_BUILD=OFF, which uses engine/'s precompiled OpenVDB and Eigen headers)
# caches nothing. A unity build's batch files #include sources by absolute path, so a clone
# in another folder misses the cache for them; CI is timed cold (.ci/run).
# CCACHE_BASEDIR makes paths under the checkout relative and CCACHE_NOHASHDIR leaves the
# working directory out of the hash, so a clone in another folder (CI's) hits the cache.
# CI compiles three configurations (ASan, TSan, release) of about 4 GB of objects each:
# ccache's default 5 GB limit evicted the first while the last was built, and every CI run
# then compiled cold (64 min once), so hapvox's compiles allow the cache 25 GB unless
# CCACHE_MAXSIZE says otherwise.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
targets=()
while [ "${1:-}" = "--target" ]; do
  read -ra named <<<"${2:?"--target needs a target name, e.g. hapvox"}"
  targets+=("${named[@]}")
  shift 2
done
target=()
if [ ${#targets[@]} -gt 0 ]; then target=(--target "${targets[@]}"); fi
build_dir=${1:-"$root/build"}
shift || true
launcher=()
if command -v ccache >/dev/null 2>&1; then
  ccache="env;CCACHE_SLOPPINESS=pch_defines,time_macros,include_file_mtime,include_file_ctime;CCACHE_BASEDIR=$root;CCACHE_NOHASHDIR=1;CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-25G};ccache"
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER="$ccache" -DCMAKE_CXX_COMPILER_LAUNCHER="$ccache")
fi
cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo "${launcher[@]}" "$@" >/dev/null
cmake --build "$build_dir" -j "$(nproc)" "${target[@]}"
