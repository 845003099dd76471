#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite with ctest.
# Usage: scripts/test.sh [--sanitize address|thread] [ctest arguments...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
sanitize=""
if [ "${1:-}" = "--sanitize" ]; then
  sanitize=${2:?"--sanitize needs address or thread"}
  shift 2
fi
bash "$root/scripts/setup.sh"
build_dir="$root/build${sanitize:+-$sanitize}"
# The build's own output goes to a log; on failure its tail is shown.
mkdir -p "$build_dir"
if ! bash "$root/scripts/build.sh" "$build_dir" -DHAPVOX_SANITIZE="$sanitize" >"$build_dir/build.log" 2>&1; then
  tail -n 60 "$build_dir/build.log"
  echo "test.sh: build failed (full log: $build_dir/build.log)" >&2
  exit 1
fi
export ASAN_OPTIONS=${ASAN_OPTIONS:-"detect_leaks=0:abort_on_error=1"}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-"print_stacktrace=1:halt_on_error=1"}
export TSAN_OPTIONS=${TSAN_OPTIONS:-"halt_on_error=1 second_deadlock_stack=1 suppressions=$root/scripts/tsan.supp"}
cd "$build_dir"
ctest --output-on-failure -j "$(nproc)" "$@"
